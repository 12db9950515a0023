// The depth sensor's pose on the robot from balls on known marks (the paper's Sec. 5): the ball's
// centre as the sensor saw it on each mark, against where the mark puts it in the robot frame, gives
// T_R_S by a rigid fit without scale. With the floor in view (its fit fixes height, pitch and roll),
// the fit is in the floor's plane only and two marks suffice; without it, three marks off one line.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "framework_api/sensor_pose.h"
#include "kinect3d/depth_frame.h"
#include "kinect3d/ground_aligner.h"

namespace kinect3d {

// A layout of marks that cannot determine the pose, or a mark without a ball: says what to do.
class CalibrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CalibrationMark {
  std::string label;         // how the user knows it, e.g. "mark 2 (marks.yaml:5)"
  Eigen::Vector3d ball_R_m;  // where the ball's centre is on the mark, robot frame
  Eigen::Vector3d ball_S_m;  // where the sensor saw it, sensor optical frame
  double scatter_m = 0.0;    // RMS spread of the detections averaged into ball_S_m
};

struct CalibrationResult {
  fw::SensorPose pose;
  bool used_floor = false;
  std::vector<double> residuals_m;  // per mark, 3D, under the final fit (a dropped mark's too)
  std::vector<bool> used;           // false: dropped as mislabelled
  // 1-sigma of x, y, z (m) and yaw, pitch, roll (rad), from leaving each mark out in turn
  // (jackknife); nothing when there are too few marks to leave one out.
  std::optional<Eigen::Matrix<double, 6, 1>> sigma;
};

struct CalibrationOptions {
  double min_spread_m = 1.0;     // the marks must span at least this much of the floor
  double min_off_line_m = 0.3;   // without the floor: a mark this far off the line through the others
  double reject_above_m = 0.10;  // with four or more marks, one whose residual when left out is
  double reject_factor = 5.0;    // above this and this many times the others' median is dropped
};

// floor_T_R_S: the floor fit's pose (height, pitch and roll; x = y = yaw = 0), or nothing to fit
// all six degrees of freedom from the marks. Throws CalibrationError for a layout that cannot
// determine the pose, saying what to add.
CalibrationResult calibrateSensorPose(const std::vector<CalibrationMark>& marks,
                                      const std::optional<Eigen::Isometry3d>& floor_T_R_S,
                                      const CalibrationOptions& options = {});

// While the robot plays: is the floor still where the calibrated pose puts it? A knocked sensor
// tilts or drops; every interval_frames the floor is fitted in the frame alone and compared with
// the pose, and a disagreement beyond the limits in `confirmations` checks in a row is an alarm.
class FloorCalibrationCheck {
 public:
  struct Config {
    int interval_frames = 30;
    double max_height_error_m = 0.05;
    double max_tilt_error_rad = 2.0 * M_PI / 180.0;
    int confirmations = 3;  // one bad fit (a robot across the floor) is not a moved sensor
  };
  // ground: the floor search's settings (its pose is ignored).
  FloorCalibrationCheck(const Config& config, const fw::SensorPose& calibrated, GroundAligner::Config ground);

  // The pose the floor now implies (the calibrated x, y and yaw; height, pitch and roll from the
  // floor) when this frame confirms that the sensor has moved; reported once per episode.
  std::optional<fw::SensorPose> check(const DepthFrame& frame);

 private:
  Config config_;
  fw::SensorPose calibrated_;
  GroundAligner floor_;
  int frames_ = 0;
  int disagreements_ = 0;
  bool alarmed_ = false;
};

// While the robot plays, from the sensor's accelerometer (Kinect v1): does gravity still fall where
// it did? It needs no floor in view, so a sensor knocked while robots hide the floor is noticed too.
// A unit's accelerometer can sit up to kAccelerometerAccuracy off its depth camera, so the first
// window of readings becomes the reference when it agrees with the calibrated pose within that;
// when it does not, the calibrated pose is the reference (and the sensor was moved before the
// start). The robot's own accelerations tilt single readings (2 m/s^2 of braking: 11 degrees), so
// readings whose magnitude is off g by more than kMaxMagnitudeError are ignored and the check
// compares the median direction of each window_s of readings.
class GravityCalibrationCheck {
 public:
  static constexpr double kAccelerometerAccuracy_rad = 3.0 * M_PI / 180.0;
  static constexpr double kMaxMagnitudeError = 0.05;
  struct Config {
    double window_s = 1.0;
    double max_tilt_error_rad = 2.0 * M_PI / 180.0;
    int confirmations = 3;  // windows in a row
  };
  GravityCalibrationCheck(const Config& config, const fw::SensorPose& calibrated);

  // The pose gravity now implies (the calibrated position and yaw, which gravity cannot see; pitch
  // and roll turned by the tilt measured) when this frame confirms that the sensor has moved;
  // reported once per episode. Frames without gravity are passed over.
  std::optional<fw::SensorPose> check(const DepthFrame& frame);

 private:
  Config config_;
  fw::SensorPose calibrated_;
  Eigen::Vector3d expected_down_S_;  // by the calibrated pose
  std::optional<Eigen::Vector3d> reference_down_S_;
  std::vector<Eigen::Vector3d> window_;  // unit vectors
  double window_start_s_ = 0.0;
  int disagreements_ = 0;
  bool alarmed_ = false;
};

// The centre of a ball of radius_m whose surface the user picked at pixel (u, v): the depth within
// the ball's image around the pixel, fitted with a sphere of that radius. Nothing when the pixel
// has no depth near it.
std::optional<Eigen::Vector3d> ballCentreAtPixel(const DepthFrame& frame, const Eigen::Vector2d& pixel,
                                                 double radius_m);

}  // namespace kinect3d
