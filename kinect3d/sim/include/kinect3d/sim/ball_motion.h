// The ball's flight: gravity, quadratic air drag, bounces with restitution, then rolling with
// friction; it bounces off the robots among the obstacles (their hulls, moving as they drive).
// Integrated once at construction; positionAt() interpolates.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "kinect3d/sim/scene.h"

namespace kinect3d::sim {

class BallMotion {
 public:
  // obstacles: the scene's objects (the ball springs off those that are robots); a scene's ball
  // moves among its scene.objects, or the truth and the rendered ball part ways.
  BallMotion(const BallLaunch& launch, const BallPhysics& physics, double duration_s,
             const std::vector<SceneObject>& obstacles);

  Eigen::Vector3d positionAt(double t_s) const;
  Eigen::Vector3d velocityAt(double t_s) const;

 private:
  static constexpr double kStep_s = 0.0005;
  struct State {
    Eigen::Vector3d p;
    Eigen::Vector3d v;
  };
  State stateAt(double t_s) const;
  // Off any robot's hull the ball touches at scene time t.
  static void bounceOffRobots(State& s, double radius_m, double t_s, const std::vector<SceneObject>& obstacles);

  double launch_time_s_;
  std::vector<State> states_;  // from launch, every kStep_s
};

}  // namespace kinect3d::sim
