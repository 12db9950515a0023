#include "kinect3d/sensor_coverage.h"

#include <algorithm>

namespace kinect3d {

void SensorCoverage::update(const DepthFrame& frame) {
  const int w = frame.width(), h = frame.height();
  if (w != width_ || h != height_) {
    width_ = w, height_ = h;
    band_u_ = std::min(kMaxBandColumns_px, w / 4), band_v_ = std::min(kMaxBandRows_px, h / 4);
    // Nothing returned yet: the whole band is out of view.
    row_first_.assign(h, band_u_), row_last_.assign(h, w - 1 - band_u_);
    column_first_.assign(w, band_v_), column_last_.assign(w, h - 1 - band_v_);
    range_samples_.assign(static_cast<std::size_t>(kMaxRange_m / kRangeBin_m) + 1, 0);
    farthest_bin_ = 0;
  }
  // The bands: from each side inwards, up to what is already known to be in view. at(i, j) reads
  // pixel j of line i (a row, or a column); first and last are the line's outermost returns.
  auto learn = [&](int lines, int length, auto at, std::vector<int>& first, std::vector<int>& last) {
    for (int i = 0; i < lines; ++i) {
      for (int j = 0; j < first[i]; ++j) {
        if (at(i, j) != 0) {
          first[i] = j;
          break;
        }
      }
      for (int j = length - 1; j > last[i]; --j) {
        if (at(i, j) != 0) {
          last[i] = j;
          break;
        }
      }
    }
  };
  const auto in_row = [&](int v, int u) { return frame.at(u, v); };
  const auto in_column = [&](int u, int v) { return frame.at(u, v); };
  learn(h, w, in_row, row_first_, row_last_);
  learn(w, h, in_column, column_first_, column_last_);
  // The range: the farthest bin that, with everything beyond it, enough samples returned. It only
  // grows, so a frame can move it only if enough samples lie beyond it: counting those (a compare,
  // no memory write) is all most frames need; the histogram is built only when the range grows.
  const int last_bin = static_cast<int>(range_samples_.size()) - 1;
  const int beyond_mm = (farthest_bin_ + 1) * kRangeBin_mm;
  int samples_beyond = 0;
  for (int v = 0; v < h; v += kSampleStride_px) {
    const std::uint16_t* row = &frame.depth_mm[static_cast<std::size_t>(v) * w];
    for (int u = 0; u < w; u += kSampleStride_px) samples_beyond += row[u] >= beyond_mm;
  }
  if (samples_beyond < kMinFarSamples) return;
  std::fill(range_samples_.begin(), range_samples_.end(), 0);
  for (int v = 0; v < h; v += kSampleStride_px) {
    const std::uint16_t* row = &frame.depth_mm[static_cast<std::size_t>(v) * w];
    // In whole millimetres (a division by a constant integer is a multiplication, by a double not),
    // and without a branch: pixels without depth land in bin 0, which no sensor reaches and which
    // is emptied below.
    for (int u = 0; u < w; u += kSampleStride_px) ++range_samples_[std::min(last_bin, row[u] / kRangeBin_mm)];
  }
  range_samples_[0] = 0;
  int beyond = 0;
  for (int bin = last_bin; bin > farthest_bin_; --bin) {
    beyond += range_samples_[bin];
    if (beyond >= kMinFarSamples) {
      farthest_bin_ = bin;
      break;
    }
  }
}

bool SensorCoverage::inView(int u, int v) const {
  if (u < 0 || v < 0 || u >= width_ || v >= height_) return false;
  return u >= row_first_[v] && u <= row_last_[v] && v >= column_first_[u] && v <= column_last_[u];
}

}  // namespace kinect3d
