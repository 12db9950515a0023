// The fusion's files, JSON lines (docs/fusion.md): omni camera balls and robot poses as inputs,
// fused balls as output. Readers throw std::runtime_error naming the file and line.
#pragma once

#include <string>
#include <vector>

#include "framework_api/types.h"
#include "fusion/ball_fusion.h"

namespace fusion {

// {"t": 1700000000.033, "balls": [{"bearing_rad": 0.12, "distance_m": 3.4}]}, optional
// sigma_bearing_rad and sigma_distance_m per ball. Frames in file order; source is set to `source`.
std::vector<fw::OmniFrame> readOmniFile(const std::string& path, const std::string& source);
void writeOmniFile(const std::string& path, const std::vector<fw::OmniFrame>& frames);

// One line per frame of `kinect3d detect` (docs/cli.md): {"frame": 12, "t": 1700000000.4, "balls":
// [{"x": .., "y": .., "z": .., "state": "air", "points": 310, "static": false, "colour": "confirmed"}], "process_ms":
// .., "trajectory": ..}. Read: the time and each ball's position (robot frame) and state; the detector's report
// (points, static, process_ms, trajectory) is checked for its keys only. The file holds no covariance: each ball gets 1
// cm in every direction.
std::vector<fw::BallFrame> readDetectionsFile(const std::string& path, const std::string& source);

// {"t": 1700000000.010, "x_m": -1.2, "y_m": 0.4, "theta_rad": 0.3}, field frame.
std::vector<fw::RobotPose> readPoseFile(const std::string& path);
void writePoseFile(const std::string& path, const std::vector<fw::RobotPose>& poses);

// {"t": .., "ball": null | {"field": [x, y, z], "robot": [..], "v_field": [..], "state": "air",
//  "sigma_m": .., "sources": [..]}}
void writeFusedFile(const std::string& path, const std::vector<FusionUpdate>& updates);

}  // namespace fusion
