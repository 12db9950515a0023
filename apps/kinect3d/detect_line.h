// The JSON line `kinect3d detect` writes per depth frame (docs/cli.md), also what `kinect3d export`
// writes from a match log.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "framework_api/types.h"

namespace kinect3d {

// {"frame", "t", "balls": [{"x", "y", "z", "state", "points", "static", "colour"}], "process_ms" (null when
// not known), "trajectory": null or {"p", "v", "state", "support", "rms_m", "touchdown", "crossing"}};
// positions to 0.1 mm, times to 1 us.
std::string detectLine(std::uint64_t frame_index, double t_s, const std::vector<fw::BallObservation>& balls,
                       std::optional<double> process_s, const std::optional<fw::BallTrajectory>& trajectory);

}  // namespace kinect3d
