// `kinect3d calibrate --plot DIR`: the set-up from above (robot, sensor and its view, the marks, where
// the sensor saw each ball under the found pose) and each mark's residual, as a page (chart_page.h).
#pragma once

#include <string>

#include "calibrate_pose.h"

namespace kinect3d {

void writeCalibrationPlot(const PoseCalibration& calibration, const std::string& out_dir);

}  // namespace kinect3d
