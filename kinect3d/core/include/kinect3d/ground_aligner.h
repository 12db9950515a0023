// Where the sensor is relative to the floor: either the configured pose, or found from the floor
// itself by RANSAC on the first frames (the paper's approach), giving height, pitch and roll.
#pragma once

#include <cmath>
#include <memory>
#include <optional>

#include <Eigen/Geometry>

#include "framework_api/sensor_pose.h"
#include "kinect3d/depth_frame.h"

namespace kinect3d {

class GroundAligner {
 public:
  struct Config {
    std::optional<fw::SensorPose> pose;         // known mounting; when absent the floor is searched for
    double max_tilt_rad = 40.0 * M_PI / 180.0;  // the floor's normal is at most this far from the image's up
    double distance_threshold_m = 0.05;         // inlier band around the plane (a depth step at 5 m)
    double max_fit_range_m = 6.0;               // fit on points nearer than this, where depth is precise
    int refit_interval_frames = 30;             // how often the floor fit is checked
    double min_inlier_fraction = 0.05;          // of the sampled points (a floor filling the bottom fifth
                                                // of the view from 3 m on); below it the fit has degraded
    double min_height_m = 0.2;                  // a floor fit that puts the sensor lower or higher than these
    double max_height_m = 2.0;                  // is a plane found in noise or clutter: keep looking
  };

  explicit GroundAligner(const Config& config);
  ~GroundAligner();

  // T_R_S for this frame, or nothing while the floor has not been found. With a configured pose
  // this is that pose; otherwise the floor is fitted on the first frame that shows enough of it,
  // checked every refit_interval_frames and refitted when its inliers fall below the minimum.
  std::optional<Eigen::Isometry3d> update(const DepthFrame& frame);
  // Fits the floor plane in this frame alone; returns the pose it implies (yaw 0, at x = y = 0) or
  // nothing (the calibration check compares it with the configured pose).
  std::optional<Eigen::Isometry3d> fitFloor(const DepthFrame& frame);

 private:
  double inlierFraction(const DepthFrame& frame, const Eigen::Isometry3d& T_R_S) const;

  Config config_;
  std::optional<Eigen::Isometry3d> T_R_S_;
  int frames_since_check_ = 0;
};

}  // namespace kinect3d
