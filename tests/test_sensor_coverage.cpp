// What the sensor can see, learnt from what it returned: the edge bands real Kinect frames carry,
// and the farthest depth the unit returns.
#include <gtest/gtest.h>

#include "kinect3d/sensor_coverage.h"

namespace {

using kinect3d::DepthFrame;
using kinect3d::SensorCoverage;

// A VGA frame returning depth_mm everywhere but left_px columns on the left, right_px on the right
// and top_px rows at the top.
DepthFrame bandedFrame(int left_px, int right_px, int top_px, std::uint16_t depth_mm) {
  DepthFrame frame;
  frame.resize(kinect3d::Intrinsics{});
  for (int v = top_px; v < frame.height(); ++v) {
    for (int u = left_px; u < frame.width() - right_px; ++u) {
      frame.depth_mm[static_cast<std::size_t>(v) * frame.width() + u] = depth_mm;
    }
  }
  return frame;
}

TEST(SensorCoverage, NothingIsInViewOrInRangeBeforeAFrame) {
  const SensorCoverage coverage;
  EXPECT_FALSE(coverage.inView(320, 240));
  EXPECT_EQ(coverage.farthestReturn_m(), 0.0);
}

TEST(SensorCoverage, TheEdgeBandsAreWhereNoPixelEverReturned) {
  SensorCoverage coverage;
  coverage.update(bandedFrame(12, 30, 10, 3000));
  EXPECT_FALSE(coverage.inView(11, 200));
  EXPECT_TRUE(coverage.inView(12, 200));
  EXPECT_TRUE(coverage.inView(609, 200));
  EXPECT_FALSE(coverage.inView(610, 200));
  EXPECT_FALSE(coverage.inView(320, 9));
  EXPECT_TRUE(coverage.inView(320, 10));
  EXPECT_TRUE(coverage.inView(320, 479)) << "no band at the bottom";
  EXPECT_FALSE(coverage.inView(-1, 200));
  EXPECT_FALSE(coverage.inView(640, 200));

  // A later frame returning nearer the border widens the view there, and nothing narrows it again.
  DepthFrame later = bandedFrame(12, 30, 10, 3000);
  later.depth_mm[200 * 640 + 5] = 3000;
  coverage.update(later);
  EXPECT_TRUE(coverage.inView(5, 200));
  EXPECT_FALSE(coverage.inView(5, 201));
  coverage.update(bandedFrame(30, 30, 14, 3000));
  EXPECT_TRUE(coverage.inView(12, 100));
}

TEST(SensorCoverage, DeepInsideTheImageNoDepthIsNeverTheSensorsBlindness) {
  SensorCoverage coverage;
  coverage.update(bandedFrame(0, 0, 0, 0));  // nothing returned at all
  EXPECT_FALSE(coverage.inView(SensorCoverage::kMaxBandColumns_px - 1, 240));
  EXPECT_TRUE(coverage.inView(SensorCoverage::kMaxBandColumns_px, 240));
  EXPECT_FALSE(coverage.inView(320, SensorCoverage::kMaxBandRows_px - 1));
  EXPECT_TRUE(coverage.inView(320, SensorCoverage::kMaxBandRows_px));
}

TEST(SensorCoverage, TheRangeIsTheFarthestDepthEnoughPixelsReturned) {
  SensorCoverage coverage;
  DepthFrame frame = bandedFrame(0, 0, 0, 3000);
  // A wall at 7.9 m over 40 x 20 pixels, and a handful of stray returns at 12 m.
  for (int v = 100; v < 120; ++v) {
    for (int u = 100; u < 140; ++u) frame.depth_mm[static_cast<std::size_t>(v) * 640 + u] = 7900;
  }
  for (int u = 300; u < 310; ++u) frame.depth_mm[300 * 640 + u] = 12000;
  coverage.update(frame);
  EXPECT_NEAR(coverage.farthestReturn_m(), 7.9, SensorCoverage::kRangeBin_m);
  // The sensor keeps what it was seen to return when it looks at nearer things.
  coverage.update(bandedFrame(0, 0, 0, 2000));
  EXPECT_NEAR(coverage.farthestReturn_m(), 7.9, SensorCoverage::kRangeBin_m);
}

TEST(SensorCoverage, AnotherImageSizeStartsAfresh) {
  SensorCoverage coverage;
  coverage.update(bandedFrame(0, 0, 0, 7000));
  DepthFrame small;
  small.resize(kinect3d::Intrinsics{320, 240, 285.0, 285.0, 159.5, 119.5});
  for (auto& d : small.depth_mm) d = 2000;
  coverage.update(small);
  EXPECT_NEAR(coverage.farthestReturn_m(), 2.0, SensorCoverage::kRangeBin_m);
  EXPECT_FALSE(coverage.inView(320, 100)) << "outside the smaller image";
}

}  // namespace
