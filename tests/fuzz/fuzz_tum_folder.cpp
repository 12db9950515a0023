// A TUM folder: depth.txt (the frame list) and camera.yaml, split in the input at the first line
// "---"; the list may name depth.png, a valid 4 x 4 16-bit image in the folder, or anything else.
// Every frame the source delivers is read.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstddef>
#include <cstdint>
#include <exception>

#include "fuzz_input_file.h"
#include "kinect3d/depth_source.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool image_written = [] {
    cv::Mat depth(4, 4, CV_16UC1, cv::Scalar(5000 * 5));  // TUM: 5000 units per metre
    return cv::imwrite((fuzz::scratchDir() / "depth.png").string(), depth);
  }();
  if (!image_written) return 0;
  const std::string text = fuzz::asText(data, size);
  const std::size_t split = text.find("\n---\n");
  fuzz::writeFile("depth.txt", text.substr(0, split));
  const std::string camera = fuzz::scratchDir() / "camera.yaml";
  if (split == std::string::npos) {
    std::filesystem::remove(camera);
  } else {
    fuzz::writeFile("camera.yaml", text.substr(split + 5));
  }
  try {
    auto source = kinect3d::DepthSourceTable::core().open("tum:" + fuzz::scratchDir().string());
    kinect3d::DepthFrame frame;
    for (int i = 0; i < 16 && source->read(frame) != kinect3d::ReadResult::kEnd; ++i) {
    }
  } catch (const std::exception&) {
  }
  return 0;
}
