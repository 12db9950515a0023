// 'Empty' must be observed: what one ray says about a shell voxel, and the detector on structures
// whose surroundings have no depth (phantoms before) next to balls against an out-of-range
// background (found before, and still).
#include <gtest/gtest.h>

#include <random>

#include "framework_api/config.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/shell_evidence.h"
#include "kinect3d/sim/kinect_simulator.h"
#include "shipped_config.h"

namespace {

using kinect3d::ShellEvidence;
using Ray = ShellEvidence::Ray;
namespace sim = kinect3d::sim;

void setDepth(kinect3d::DepthFrame& frame, int u, int v, std::uint16_t mm) {
  frame.depth_mm[static_cast<std::size_t>(v) * frame.width() + u] = mm;
}

// A VGA frame with no depth anywhere but a block 2 m away in columns 300-319, and a frame of
// far_mm round the view (so that the sensor is seen to return up to there, to the view's edges),
// left_band_px columns in from the left border.
kinect3d::DepthFrame frameWithNearBlock(std::uint16_t far_mm = 9000, int left_band_px = 0) {
  kinect3d::DepthFrame frame;
  frame.resize(kinect3d::Intrinsics{});
  const int w = frame.width(), h = frame.height();
  for (int u = left_band_px; u < w; ++u) setDepth(frame, u, 0, far_mm), setDepth(frame, u, h - 1, far_mm);
  for (int v = 0; v < h; ++v) setDepth(frame, left_band_px, v, far_mm), setDepth(frame, w - 1, v, far_mm);
  for (int v = 200; v < 280; ++v) {
    for (int u = 300; u < 320; ++u) setDepth(frame, u, v, 2000);
  }
  return frame;
}

kinect3d::SensorCoverage coverageOf(const kinect3d::DepthFrame& frame) {
  kinect3d::SensorCoverage coverage;
  coverage.update(frame);
  return coverage;
}

TEST(ShellEvidence, ClassifiesEachRayByWhatItSaw) {
  const kinect3d::PointProjector::Config points;  // range 0.5-9.5 m, 7.5 cm baseline
  const ShellEvidence evidence(kinect3d::Intrinsics{}, 1, points);
  kinect3d::DepthFrame frame = frameWithNearBlock();
  setDepth(frame, 100, 240, 5000);
  const kinect3d::SensorCoverage seen = coverageOf(frame);
  EXPECT_EQ(evidence.classify(frame, seen, 100, 240, 3.8f, 4.2f), Ray::kEmpty) << "depth measured behind the voxel";
  EXPECT_EQ(evidence.classify(frame, seen, 100, 240, 5.8f, 6.2f), Ray::kHidden) << "depth measured in front of it";
  EXPECT_EQ(evidence.classify(frame, seen, 100, 240, 4.8f, 5.2f), Ray::kSurface) << "something inside it";
  EXPECT_EQ(evidence.classify(frame, seen, 100, 100, 3.8f, 4.2f), Ray::kEmpty) << "no depth, well within range";
  EXPECT_EQ(evidence.classify(frame, seen, 100, 100, 8.8f, 9.2f), Ray::kUnknown)
      << "no depth, at the farthest the sensor returned";
  EXPECT_EQ(evidence.classify(frame, seen, -5, 100, 3.8f, 4.2f), Ray::kHidden) << "out of view";
}

TEST(ShellEvidence, NoDepthIsOnlyEmptyWhereTheSensorIsSeenToReturnDepth) {
  const ShellEvidence evidence(kinect3d::Intrinsics{}, 1, kinect3d::PointProjector::Config{});
  // A sensor whose left 20 columns never return anything: no depth there is out of view.
  const kinect3d::DepthFrame banded = frameWithNearBlock(9000, 20);
  const kinect3d::SensorCoverage banded_seen = coverageOf(banded);
  EXPECT_EQ(evidence.classify(banded, banded_seen, 10, 100, 3.8f, 4.2f), Ray::kHidden) << "in the edge band";
  EXPECT_EQ(evidence.classify(banded, banded_seen, 25, 100, 3.8f, 4.2f), Ray::kEmpty) << "inside the view";
  // A sensor seen to return up to 6 m: a voxel at 6 m with no depth may hold a surface it cannot see.
  const kinect3d::DepthFrame short_range = frameWithNearBlock(6000);
  const kinect3d::SensorCoverage short_seen = coverageOf(short_range);
  EXPECT_EQ(evidence.classify(short_range, short_seen, 100, 100, 5.8f, 6.1f), Ray::kUnknown);
  EXPECT_EQ(evidence.classify(short_range, short_seen, 100, 100, 3.8f, 4.2f), Ray::kEmpty);
}

TEST(ShellEvidence, NoDepthInTheProjectorsShadowIsHiddenNotEmpty) {
  // The block at 2 m shadows f b (1/2 - 1/4) = 10.8 px to its left on a surface at 4 m; the
  // projector sits to the right, so nothing on the block's right is shadowed.
  const ShellEvidence evidence(kinect3d::Intrinsics{}, 1, kinect3d::PointProjector::Config{});
  const kinect3d::DepthFrame frame = frameWithNearBlock();
  const kinect3d::SensorCoverage seen = coverageOf(frame);
  EXPECT_EQ(evidence.classify(frame, seen, 295, 240, 3.8f, 4.0f), Ray::kHidden);
  EXPECT_EQ(evidence.classify(frame, seen, 285, 240, 3.8f, 4.0f), Ray::kEmpty) << "beyond the widest shadow at 4 m";
  EXPECT_EQ(evidence.classify(frame, seen, 325, 240, 3.8f, 4.0f), Ray::kEmpty) << "right of the block";
}

using testing_config::shippedDetector;

// Frames of the scene in which the detector reported a ball.
int framesWithABall(const sim::Scene& scene) {
  kinect3d::BallDetector detector(shippedDetector(scene), "kinect3d");
  sim::KinectSimulator simulator(scene);
  kinect3d::DepthFrame frame;
  sim::GroundTruth truth;
  kinect3d::Detections detections;
  int with_ball = 0;
  for (int i = 0; i < simulator.frameCount(); ++i) {
    simulator.render(i, frame, truth);
    detector.detect(frame, detections);
    with_ball += !detections.balls.empty();
  }
  return with_ball;
}

TEST(ShellEvidence, StructuresAtTheRangeLimitAreNotBalls) {
  // A corner, a wall end and a loudspeaker on a wall beyond the range: each is a ball-sized piece
  // of depth with none around it (without the evidence the loudspeaker was a ball in every frame).
  sim::Scene scene = sim::loadScene("range_edge");
  scene.duration_s = 0.5;
  EXPECT_EQ(framesWithABall(scene), 0);
}

TEST(ShellEvidence, StructuresAtTheSensorsOwnRangeAreNotBallsWhateverThatRange) {
  // The same structures for sensors whose range ends sooner (units and surfaces differ: 5-9.5 m),
  // the scene shrunk about the sensor to put them at that range, each surface a random shade
  // (dark ones return less). The detector keeps its shipped 9.5 m: what the sensor returns sets
  // where no depth stops meaning empty.
  for (int seed = 1; seed <= 4; ++seed) {
    std::mt19937 rng(static_cast<unsigned>(seed));
    sim::Scene scene = sim::loadScene("range_edge");
    scene.duration_s = 0.4;
    scene.noise.seed = static_cast<std::uint64_t>(seed);
    scene.noise.max_range_m = std::uniform_real_distribution<double>(5.0, 9.5)(rng);
    const double scale = scene.noise.max_range_m / 9.5;
    for (sim::SceneObject& object : scene.objects) {
      for (sim::Shape& shape : object.shapes) {
        shape.center_m.head<2>() *= scale;
        shape.size_m.head<2>() *= scale;
        shape.dropout = std::uniform_real_distribution<double>(0.0, 0.3)(rng);
      }
    }
    SCOPED_TRACE("sensor range " + std::to_string(scene.noise.max_range_m) + " m");
    EXPECT_EQ(framesWithABall(scene), 0);
  }
}

TEST(ShellEvidence, ABallAgainstAnOutOfRangeBackgroundIsStillFound) {
  // The Table 1 ball at 4 m and 6 m with the wall taken away: nothing behind it returns depth.
  for (const char* name : {"hung_4m", "hung_6m"}) {
    SCOPED_TRACE(name);
    sim::Scene scene = sim::loadScene(name);
    scene.duration_s = 0.5;
    scene.objects.clear();
    sim::KinectSimulator simulator(scene);
    EXPECT_EQ(framesWithABall(scene), simulator.frameCount() - 1);  // from its second frame, being beyond 4 m
  }
}

}  // namespace
