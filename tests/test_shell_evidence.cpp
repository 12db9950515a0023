// 'Empty' must be observed: what one ray says about a shell voxel, and the detector on structures
// whose surroundings have no depth (phantoms before) next to balls against an out-of-range
// background (found before, and still).
#include <gtest/gtest.h>

#include "framework_api/config.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/shell_evidence.h"
#include "kinect3d/sim/kinect_simulator.h"

namespace {

using kinect3d::ShellEvidence;
using Ray = ShellEvidence::Ray;
namespace sim = kinect3d::sim;

// A VGA frame with no depth anywhere but a block 2 m away in columns 300-319.
kinect3d::DepthFrame frameWithNearBlock() {
  kinect3d::DepthFrame frame;
  frame.resize(kinect3d::Intrinsics{});
  for (int v = 200; v < 280; ++v) {
    for (int u = 300; u < 320; ++u) frame.depth_mm[static_cast<std::size_t>(v) * frame.width() + u] = 2000;
  }
  return frame;
}

void setDepth(kinect3d::DepthFrame& frame, int u, int v, std::uint16_t mm) {
  frame.depth_mm[static_cast<std::size_t>(v) * frame.width() + u] = mm;
}

TEST(ShellEvidence, ClassifiesEachRayByWhatItSaw) {
  const kinect3d::PointProjector::Config points;  // range 0.5-9.5 m, 7.5 cm baseline
  const ShellEvidence evidence(kinect3d::Intrinsics{}, 1, points);
  kinect3d::DepthFrame frame = frameWithNearBlock();
  setDepth(frame, 100, 240, 5000);
  EXPECT_EQ(evidence.classify(frame, 100, 240, 3.8f, 4.2f), Ray::kEmpty) << "depth measured behind the voxel";
  EXPECT_EQ(evidence.classify(frame, 100, 240, 5.8f, 6.2f), Ray::kHidden) << "depth measured in front of it";
  EXPECT_EQ(evidence.classify(frame, 100, 240, 4.8f, 5.2f), Ray::kSurface) << "something inside it";
  EXPECT_EQ(evidence.classify(frame, 100, 100, 3.8f, 4.2f), Ray::kEmpty) << "no depth, well within range";
  EXPECT_EQ(evidence.classify(frame, 100, 100, 9.0f, 9.4f), Ray::kUnknown) << "no depth, at the range limit";
  EXPECT_EQ(evidence.classify(frame, 3, 100, 3.8f, 4.2f), Ray::kHidden) << "no depth in the edge band";
  EXPECT_EQ(evidence.classify(frame, -5, 100, 3.8f, 4.2f), Ray::kHidden) << "out of view";
}

TEST(ShellEvidence, NoDepthInTheProjectorsShadowIsHiddenNotEmpty) {
  // The block at 2 m shadows f b (1/2 - 1/4) = 10.8 px to its left on a surface at 4 m; the
  // projector sits to the right, so nothing on the block's right is shadowed.
  const ShellEvidence evidence(kinect3d::Intrinsics{}, 1, kinect3d::PointProjector::Config{});
  const kinect3d::DepthFrame frame = frameWithNearBlock();
  EXPECT_EQ(evidence.classify(frame, 295, 240, 3.8f, 4.0f), Ray::kHidden);
  EXPECT_EQ(evidence.classify(frame, 285, 240, 3.8f, 4.0f), Ray::kEmpty) << "beyond the widest shadow at 4 m";
  EXPECT_EQ(evidence.classify(frame, 325, 240, 3.8f, 4.0f), Ray::kEmpty) << "right of the block";
}

kinect3d::DetectorConfig shippedDetector(const sim::Scene& scene) {
  const fw::Config config = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", "", {});
  kinect3d::DetectorConfig detector = kinect3d::readDetectorConfig(config.block("kinect3d"));
  detector.ground.pose = scene.sensor_pose;
  return detector;
}

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

TEST(ShellEvidence, ABallAgainstAnOutOfRangeBackgroundIsStillFound) {
  // The Table 1 ball at 4 m and 6 m with the wall taken away: nothing behind it returns depth.
  for (const char* name : {"hung_4m", "hung_6m"}) {
    SCOPED_TRACE(name);
    sim::Scene scene = sim::loadScene(name);
    scene.duration_s = 0.5;
    scene.objects.clear();
    sim::KinectSimulator simulator(scene);
    EXPECT_EQ(framesWithABall(scene), simulator.frameCount());
  }
}

}  // namespace
