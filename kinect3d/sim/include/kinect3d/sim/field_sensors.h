// The simulated robot's other sensors, from a scene's truth: the omni camera (the ball's ground
// projection, as the real camera reports it) and self-localisation (the robot's pose with the slow,
// correlated error a particle filter has). Deterministic for a scene and seed.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "framework_api/types.h"
#include "kinect3d/sim/ball_motion.h"
#include "kinect3d/sim/scene.h"

namespace kinect3d::sim {

struct OmniCameraModel {
  double rate_hz = 30.0;
  double phase_s = 0.013;            // first image after the Kinect's first frame
  double stamp_late_s = 0.03;        // its stamps are this much later than the image (unknown to fusion)
  double viewpoint_height_m = 0.75;  // the mirror's viewpoint above the floor
  double max_height_m = 0.6;         // a ball centre higher than this is not seen
  double max_distance_m = 9.0;       // nor one whose reported distance is farther (the mirror's edge)
  double bearing_sigma_rad = 0.01;
  double distance_sigma_m = 0.03;         // at the robot ...
  double distance_sigma_fraction = 0.04;  // ... growing with distance
  double distance_scale = 1.0;            // its distance map's scale error (a mirror calibrated a few per cent off)
  double miss_probability = 0.05;         // the ball is not found in an image
  double false_rate_hz = 0.5;             // orange things that look like a ball appear this often ...
  double false_duration_s = 0.3;          // ... for this long, standing still
  std::uint64_t seed = 1;
};

class OmniCameraSimulator {
 public:
  OmniCameraSimulator(const Scene& scene, const OmniCameraModel& model);
  int frameCount() const;
  // Image i: stamp (source clock, late by stamp_late_s), the balls and the other robots seen, with
  // bearing and distance sigmas as the camera's model states them.
  fw::OmniFrame frame(int index) const;
  // When image i was really taken, on the scene's source clock.
  double captureTime_s(int index) const;

 private:
  struct FalseBall {
    double start_s;
    Eigen::Vector2d p_F;
  };
  bool occluded(const Eigen::Vector3d& ball_F, const fw::RobotPose& pose, double t_s) const;

  Scene scene_;
  OmniCameraModel model_;
  std::unique_ptr<BallMotion> ball_;
  std::vector<FalseBall> false_balls_;
};

struct LocalisationModel {
  double rate_hz = 30.0;
  double sigma_xy_m = 0.03;  // error of x and y (1 sigma), ...
  double sigma_theta_rad = 0.017;
  double correlation_s = 1.0;  // ... wandering over about this time
  double stamp_late_s = 0.0;   // its stamps are this much later than the pose they carry (unknown to fusion)
  // A mislocalised robot: where its localisation believes it stands, beyond the noise, shifted by
  // this and turned by this about itself.
  Eigen::Vector2d bias_xy_m = Eigen::Vector2d::Zero();
  double bias_theta_rad = 0.0;
  // The wheels' odometry published with each pose (fw::RobotPose::odometry): the true motion, each
  // step's distance and turn off by a scale error drawn once per run (one sigma odometry_error: a
  // worn wheel, slip) and by noise of the same share of the step.
  bool odometry = true;
  double odometry_error = 0.02;
  std::uint64_t seed = 2;
};

class LocalisationSimulator {
 public:
  LocalisationSimulator(const Scene& scene, const LocalisationModel& model);
  int frameCount() const { return static_cast<int>(errors_.size()); }
  fw::RobotPose pose(int index) const;  // stamped on the scene's source clock

 private:
  Scene scene_;
  LocalisationModel model_;
  std::vector<Eigen::Vector3d> errors_;            // x, y, theta per pose
  std::vector<fw::RobotPose::Odometry> odometry_;  // per pose, when the model has odometry
};

}  // namespace kinect3d::sim
