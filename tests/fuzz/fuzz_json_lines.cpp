// The JSON-lines files other programs hand us: the omni camera's balls, robot poses, and
// `kinect3d detect` output (for `kinect3d fuse` and `kinect3d calibrate drag`, which also runs).
#include <cstddef>
#include <cstdint>
#include <exception>

#include "fusion/json_lines.h"
#include "fuzz_input_file.h"
#include "kinect3d/ball_physics_fit.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = fuzz::writeFile("lines.jsonl", fuzz::asText(data, size));
  try {
    fusion::readOmniFile(path, "omni");
  } catch (const std::exception&) {
  }
  try {
    fusion::readPoseFile(path);
  } catch (const std::exception&) {
  }
  try {
    kinect3d::calibrateBallPhysics(fusion::readDetectionsFile(path, "kinect3d"), 0.11);
  } catch (const std::exception&) {
  }
  return 0;
}
