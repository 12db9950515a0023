// The product's shipped defaults (config/defaults), as the tests that run the detector or a plugin
// with them read them.
#pragma once

#include <string>
#include <vector>

#include "framework_api/config.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/sim/scene.h"

namespace testing_config {

inline fw::Config shippedConfig(const std::vector<std::string>& overrides = {}) {
  return fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", "", overrides);
}

// The shipped detector, told the scene's sensor pose (as the robot file tells it the calibrated one).
inline kinect3d::DetectorConfig shippedDetector(const kinect3d::sim::Scene& scene) {
  kinect3d::DetectorConfig detector = kinect3d::readDetectorConfig(shippedConfig().block("kinect3d"));
  detector.ground.pose = scene.sensor_pose;
  return detector;
}

}  // namespace testing_config
