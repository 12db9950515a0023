// `kinect3d report fusion`: the world's ball against omni-only and Kinect-only on simulated scenes
// with a driving robot, physics and sensor latency drawn across their ranges per seed.
#pragma once

#include <string>
#include <vector>

#include "framework_api/config.h"

namespace kinect3d {

// keep_dir: where each case's input files and fused output stay (empty: a temporary folder); scenes:
// which of the report's scenes to run (empty: all).
void writeFusionReport(const fw::Config& config, int seeds, const std::string& out_path, const std::string& keep_dir,
                       const std::vector<std::string>& scenes = {});
// The report's scenes, comma-separated.
std::string fusionReportScenes();

}  // namespace kinect3d
