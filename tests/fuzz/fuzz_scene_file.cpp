// A simulator scene file (sim:path/to/scene.yaml).
#include <cstddef>
#include <cstdint>
#include <exception>

#include "fuzz_input_file.h"
#include "kinect3d/sim/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = fuzz::writeFile("scene.yaml", fuzz::asText(data, size));
  try {
    kinect3d::sim::loadScene(path);
  } catch (const std::exception&) {
  }
  return 0;
}
