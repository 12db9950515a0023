// A command line's --set key=value over the shipped defaults, read by every block's reader.
#include <cstddef>
#include <cstdint>
#include <exception>

#include "framework_api/config.h"
#include "fusion/fusion_config.h"
#include "fuzz_input_file.h"
#include "kinect3d/config_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const fw::Config config = fw::Config::load(PROJECT_CONFIG_DIR "/defaults", "", {fuzz::asText(data, size)});
    kinect3d::readDetectorConfig(config.block("kinect3d"));
    kinect3d::readTrajectoryConfig(config.block("kinect3d"));
    fusion::readFusionConfig(config.block("fusion"));
  } catch (const std::exception&) {
  }
  return 0;
}
