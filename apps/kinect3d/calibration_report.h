// `kinect3d report calibration`: the sensor pose that `kinect3d calibrate` recovers on simulated
// sessions with awkward sensor poses, for 3, 4 and 6 marks, with and without the floor, with one
// mark mislabelled by 0.5 m and with the ball picked by hand 5 px off (docs/calibration.md).
#pragma once

#include <string>

#include "framework_api/config.h"

namespace kinect3d {

// keep_dir: where each session (a TUM folder with its marks.yaml and the report's marks files) stays,
// in <keep_dir>/<yawed|rolled|high|low>/ (empty: a temporary folder).
void writeCalibrationReport(const fw::Config& config, const std::string& out_path, const std::string& keep_dir);

}  // namespace kinect3d
