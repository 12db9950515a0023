// What the sensor can see, learnt from what it returns rather than from constants tuned to one unit:
//  - its view's edge: real Kinect v1 frames carry bands along the image border that never return
//    depth (8-32 columns on the right, 8-20 on the left, about 10 rows at the top, 3-8 at the
//    bottom, varying between units), with ragged inner edges. Per row and per column the outermost
//    pixels that ever returned depth mark where the view ends; beyond them is out of view, as if
//    past the image border. Only bands as wide as real units show are learnt (kMaxBandColumns_px,
//    kMaxBandRows_px): deeper inside, no depth is never the sensor's blindness, and above a field
//    nothing returns depth, which must not hide the top of the view from a lob.
//  - its range: the farthest depth that enough pixels returned. Cards state 4-9.5 m; dark or
//    glancing surfaces return nothing much nearer. No depth nearer than what the sensor has been
//    seen to return means nothing there; no depth farther is unknown.
// Both only grow: what the sensor once returned it can return. Until a frame has been seen, nothing
// is known to be in view or within range (the conservative default).
#pragma once

#include <vector>

#include "kinect3d/depth_frame.h"

namespace kinect3d {

class SensorCoverage {
 public:
  // The widest edge bands learnt, a little over the widest seen (32 columns, 12 rows); at most a
  // quarter of a small image.
  static constexpr int kMaxBandColumns_px = 40;
  static constexpr int kMaxBandRows_px = 16;
  static constexpr int kSampleStride_px = 2;  // the range is learnt from every other pixel and row
  static constexpr int kMinFarSamples = 16;   // a depth is returned when this many samples (~64 pixels) reach it
  static constexpr int kRangeBin_mm = 20;     // resolution of the learnt range
  static constexpr double kRangeBin_m = kRangeBin_mm * 1e-3;
  static constexpr double kMaxRange_m = 20.0;  // no depth sensor of this class returns farther

  // Learns from a frame; a frame of another size starts afresh.
  void update(const DepthFrame& frame);

  // Whether pixel (u, v) lies in the sensor's view: inside the image and not in an edge band.
  bool inView(int u, int v) const;
  // The farthest depth the sensor has returned (0 before any frame).
  double farthestReturn_m() const { return farthest_bin_ * kRangeBin_m; }

 private:
  int width_ = 0, height_ = 0;
  // Per row (v) the first and last column that returned depth; per column (u) the first and last row.
  std::vector<int> row_first_, row_last_, column_first_, column_last_;
  int band_u_ = 0, band_v_ = 0;     // the learnt band's width across columns and rows
  std::vector<int> range_samples_;  // per range bin, a frame's samples that returned a depth in it
  int farthest_bin_ = 0;            // the range bin of the farthest return (0: none yet)
};

}  // namespace kinect3d
