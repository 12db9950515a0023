// A live device's colour images kept for the depth frames they belong to. The two streams arrive
// on their own, and a reader that lags (a busy host) reads depth from the device's queue while the
// colour stream has moved on: the newest colour image is then not the one taken with the depth.
// Pairing is by the device's time stamps, never by arrival.
#pragma once

#include <cmath>
#include <cstddef>
#include <deque>
#include <optional>

#include "framework_api/types.h"

namespace kinect3d {

class ColourPairing {
 public:
  void add(fw::ColourImage image) {
    images_.push_back(std::move(image));
    if (images_.size() > kMaxKept) images_.pop_front();
  }

  // The kept image nearest depth_time_s, if one is within max_mismatch_s of it (1.5 frame periods).
  // Depth is read in time order, so images too old for this frame are too old for every later one
  // and go.
  std::optional<fw::ColourImage> pairWith(double depth_time_s, double max_mismatch_s) {
    while (!images_.empty() && images_.front().source_time_s < depth_time_s - max_mismatch_s) images_.pop_front();
    const fw::ColourImage* nearest = nullptr;
    for (const fw::ColourImage& image : images_) {
      if (nearest == nullptr ||
          std::abs(image.source_time_s - depth_time_s) < std::abs(nearest->source_time_s - depth_time_s)) {
        nearest = &image;
      }
    }
    if (nearest == nullptr || std::abs(nearest->source_time_s - depth_time_s) > max_mismatch_s) return std::nullopt;
    return *nearest;
  }

  void clear() { images_.clear(); }

 private:
  // A second of colour at 30 Hz (28 MB): the most a stalled depth stream can leave waiting.
  static constexpr std::size_t kMaxKept = 30;
  std::deque<fw::ColourImage> images_;
};

}  // namespace kinect3d
