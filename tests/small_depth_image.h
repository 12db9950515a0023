// A 64 x 48 depth image of the source "kinect3d", frame `index` of a 30 Hz stream (source time
// 100 s + index / 30, received 1900 s later), for tests that write match logs by hand.
#pragma once

#include <cstdint>

#include "framework_api/types.h"

inline fw::DepthImage smallDepthImage(std::uint64_t index) {
  fw::DepthImage image;
  image.width = 64;
  image.height = 48;
  image.fx = image.fy = 57.5;
  image.cx = 31.5;
  image.cy = 23.5;
  image.depth_mm.resize(64 * 48);
  for (std::size_t i = 0; i < image.depth_mm.size(); ++i) image.depth_mm[i] = static_cast<std::uint16_t>(i * 7 + index);
  image.index = index;
  image.source = "kinect3d";
  image.stamp = {100.0 + index / 30.0, 2000.0 + index / 30.0};
  return image;
}
