#include "kinect3d/depth_frame.h"

#include <algorithm>
#include <cmath>

namespace kinect3d {

Intrinsics Intrinsics::fromFieldOfView(int width, int height, double hfov_rad, double vfov_rad) {
  Intrinsics in;
  in.width = width;
  in.height = height;
  in.fx = width / (2.0 * std::tan(hfov_rad / 2.0));
  in.fy = height / (2.0 * std::tan(vfov_rad / 2.0));
  in.cx = (width - 1) / 2.0;
  in.cy = (height - 1) / 2.0;
  return in;
}

bool Intrinsics::operator==(const Intrinsics& other) const {
  return width == other.width && height == other.height && fx == other.fx && fy == other.fy && cx == other.cx &&
         cy == other.cy;
}

void DepthFrame::resize(const Intrinsics& new_intrinsics) {
  intrinsics = new_intrinsics;
  depth_mm.assign(static_cast<std::size_t>(intrinsics.width) * intrinsics.height, 0);
  gravity_S_mps2.reset();
  colour.reset();
}

DepthStats computeStats(const DepthFrame& frame) {
  DepthStats stats;
  std::size_t invalid = 0;
  std::uint16_t lo = UINT16_MAX, hi = 0;
  for (const std::uint16_t d : frame.depth_mm) {
    if (d == 0) {
      ++invalid;
      continue;
    }
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  if (!frame.depth_mm.empty()) stats.invalid_fraction = double(invalid) / frame.depth_mm.size();
  if (hi > 0) {
    stats.min_m = lo / 1000.0;
    stats.max_m = hi / 1000.0;
  }
  return stats;
}

DepthFrame fromDepthImage(fw::DepthImage image) {
  DepthFrame frame;
  frame.intrinsics = {image.width, image.height, image.fx, image.fy, image.cx, image.cy};
  frame.depth_mm = std::move(image.depth_mm);
  frame.source_time_s = image.stamp.source_time_s;
  frame.receive_time_s = image.stamp.receive_time_s;
  frame.index = image.index;
  frame.sensor_id = std::move(image.source);
  frame.gravity_S_mps2 = image.gravity_S_mps2;
  frame.colour = std::move(image.colour);
  return frame;
}

fw::DepthImage toDepthImage(const DepthFrame& frame, const std::string& source) {
  fw::DepthImage image;
  const Intrinsics& k = frame.intrinsics;
  image.width = k.width;
  image.height = k.height;
  image.fx = k.fx;
  image.fy = k.fy;
  image.cx = k.cx;
  image.cy = k.cy;
  image.depth_mm = frame.depth_mm;
  image.index = frame.index;
  image.source = source;
  image.stamp = {frame.source_time_s, frame.receive_time_s};
  image.gravity_S_mps2 = frame.gravity_S_mps2;
  image.colour = frame.colour;
  return image;
}

}  // namespace kinect3d
