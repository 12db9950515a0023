// Simulated calibration sessions (docs/calibration.md): the robot at the field origin facing +y,
// its depth sensor at a known pose, a ball resting on each mark in turn, written as a recording and
// the marks.yaml that describes it, as a team would make them on the field.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "framework_api/sensor_pose.h"
#include "kinect3d/sim/scene.h"

namespace kinect3d::sim {

struct CalibrationSession {
  fw::SensorPose pose;  // the truth the calibration should find
  // Where the ball rests, robot frame: by default four marks spread over the view, 2-3.8 m ahead.
  std::vector<Eigen::Vector2d> marks_xy_m = {{0.0, 2.0}, {-0.6, 2.8}, {0.6, 3.0}, {0.1, 3.8}};
  double seconds_per_mark = 1.0;
  std::uint64_t noise_seed = 1;
  std::optional<ColourLook> colour = std::nullopt;  // with colour images: the match ball and the hall's light
};

// dir/depth.txt, dir/depth/, dir/camera.yaml (with colour, dir/rgb.txt and dir/rgb/): the ball on each mark for
// seconds_per_mark, one mark after another; and dir/marks.yaml with each mark's position and its time range (a tenth of
// a second inside each stay, as a person would note them).
void writeCalibrationSession(const CalibrationSession& session, const std::string& dir);

}  // namespace kinect3d::sim
