// `kinect3d report trajectory`: docs/trajectory.md.
#pragma once

#include <string>

#include "framework_api/config.h"

namespace kinect3d {

void writeTrajectoryReport(const fw::Config& config, const std::string& out_path);

}  // namespace kinect3d
