// A robot file, as a team writes it, merged over the shipped defaults and read by every block's
// reader. Any input may be refused with an error; none may crash or trip a sanitizer.
#include <cstddef>
#include <cstdint>
#include <exception>

#include "framework_api/config.h"
#include "fusion/fusion_config.h"
#include "fuzz_input_file.h"
#include "kinect3d/config_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string robot_file = fuzz::writeFile("robot.yaml", fuzz::asText(data, size));
  try {
    const fw::Config config = fw::Config::load(PROJECT_CONFIG_DIR "/defaults", robot_file, {});
    kinect3d::readDetectorConfig(config.block("kinect3d"));
    kinect3d::readTrajectoryConfig(config.block("kinect3d"));
    fusion::readFusionConfig(config.block("fusion"));
  } catch (const std::exception&) {
    // Refused with a message: what bad input should get.
  }
  return 0;
}
