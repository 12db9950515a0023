// The ball's flight: gravity, quadratic air drag, bounces with restitution, then rolling with
// friction. Integrated once at construction; positionAt() interpolates.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "kinect3d/sim/scene.h"

namespace kinect3d::sim {

class BallMotion {
 public:
  BallMotion(const BallLaunch& launch, const BallPhysics& physics, double duration_s);

  Eigen::Vector3d positionAt(double t_s) const;
  Eigen::Vector3d velocityAt(double t_s) const;

 private:
  static constexpr double kStep_s = 0.0005;
  struct State {
    Eigen::Vector3d p;
    Eigen::Vector3d v;
  };
  State stateAt(double t_s) const;

  double launch_time_s_;
  std::vector<State> states_;  // from launch, every kStep_s
};

}  // namespace kinect3d::sim
