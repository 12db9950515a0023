// `kinect3d calibrate pose`: the depth sensor's pose on the robot from a ball placed on known marks
// (docs/calibration.md), from a recording with a time range per mark or live, one mark per Enter.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "framework_api/config.h"
#include "kinect3d/sensor_calibration.h"

namespace kinect3d {

struct PoseCalibrationOptions {
  std::string source;      // depth source URI
  std::string marks_file;  // marks.yaml
  std::string robot_file;  // the robot file to --write into (empty: none)
  bool use_floor = true;   // constrain height, pitch and roll by the floor when it is in view
  bool write = false;      // put the pose into robot_file, keeping a dated copy of the old file
};

struct PoseCalibration {
  std::vector<CalibrationMark> marks;  // as marks.yaml lists them, with where the sensor saw the ball
  CalibrationResult result;
};

// Finds the ball on every mark and solves the pose (and writes it with options.write). Throws
// CalibrationError, fw::ConfigError or DepthSourceError saying what to fix.
PoseCalibration calibratePose(const PoseCalibrationOptions& options, const fw::Config& config);

// The pose as lines for the robot file, then the uncertainty and each mark's residual as comments.
void printPoseCalibration(const PoseCalibration& calibration, std::ostream& out);

// Rewrites kinect3d.sensor.pose_in_robot in a robot file, leaving every other line as it was, after
// copying the file to <file>.<date>_<time>.bak. Returns the copy's path.
std::string writePoseInRobotFile(const std::string& robot_file, const fw::SensorPose& pose);

// Sets the value at a key path (e.g. kinect3d, colour_check, ball_colours) in a robot file, adding
// the blocks it lacks and leaving every other line as it was, after copying the file to
// <file>.<date>_<time>.bak. Returns the copy's path.
std::string writeRobotFileValue(const std::string& robot_file, const std::vector<std::string>& path,
                                const std::string& value);

}  // namespace kinect3d
