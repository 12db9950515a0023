// The scene map: what OctoMap remembers across frames (free, occupied, unknown, static), how the
// detector flags a ball in static space, and the .bt file octovis opens.
#include <gtest/gtest.h>

#include <octomap/OcTree.h>

#include <algorithm>
#include <optional>
#include <vector>

#include "framework_api/config.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/scene_map.h"
#include "kinect3d/sim/kinect_simulator.h"
#include "kinect3d/trajectory.h"
#include "scoped_temp_dir.h"

namespace {

using kinect3d::DepthFrame;
using kinect3d::SceneMap;
using State = SceneMap::VoxelState;

constexpr double kVoxel_m = 0.27;

// A wall filling the view 5 m ahead of the sensor, whose optical frame is the map frame here.
DepthFrame wallFrame() {
  DepthFrame frame;
  frame.resize(kinect3d::Intrinsics{});
  std::fill(frame.depth_mm.begin(), frame.depth_mm.end(), 5000);
  return frame;
}

SceneMap::Config everyFrame() {
  SceneMap::Config config;
  config.voxel_m = kVoxel_m;
  config.update_interval_frames = 1;
  config.static_after_s = 1.0;
  return config;
}

TEST(SceneMap, KnowsFreeOccupiedAndUnknownFromRays) {
  SceneMap map(everyFrame(), 0.5, 9.5);
  const DepthFrame frame = wallFrame();
  map.update(frame, Eigen::Isometry3d::Identity(), 0.0);
  EXPECT_EQ(map.integrations(), 0) << "rays are in flight until the next ray frame publishes them";
  EXPECT_EQ(map.stateAt({0.0, 0.0, 2.0}), State::kUnknown);
  map.update(frame, Eigen::Isometry3d::Identity(), 0.1);
  EXPECT_EQ(map.integrations(), 1);
  EXPECT_EQ(map.stateAt({0.0, 0.0, 2.0}), State::kFree) << "rays crossed it on their way to the wall";
  EXPECT_EQ(map.stateAt({0.0, 0.0, 5.0}), State::kOccupied);
  EXPECT_EQ(map.stateAt({0.0, 0.0, 7.0}), State::kUnknown) << "behind the wall";
  EXPECT_EQ(map.stateAt({0.0, -5.0, 2.0}), State::kUnknown) << "outside the view";
}

TEST(SceneMap, SpaceOccupiedForSecondsBecomesStaticAndWhatLeavesIsForgotten) {
  SceneMap map(everyFrame(), 0.5, 9.5);
  const DepthFrame wall = wallFrame();
  DepthFrame far = wallFrame();
  std::fill(far.depth_mm.begin(), far.depth_mm.end(), 8000);
  int frame = 0;  // one every 0.1 s
  auto feed = [&](const DepthFrame& depth, int frames) {
    for (int i = 0; i < frames; ++i, ++frame) map.update(depth, Eigen::Isometry3d::Identity(), frame * 0.1);
  };
  feed(wall, 11);  // rays up to t = 1.0 s, published up to t = 0.9 s
  EXPECT_EQ(map.stateAt({0.0, 0.0, 5.0}), State::kOccupied) << "occupied for 0.9 s, static after 1 s";
  feed(wall, 1);
  EXPECT_EQ(map.stateAt({0.0, 0.0, 5.0}), State::kStatic);
  // The wall goes; the rays now reach 8 m and pass through where it stood. Clamped at OctoMap's
  // maximum log-odds (3.5), it takes 9 misses of -0.4 to be free again: forgotten, not for ever.
  feed(far, 5);
  EXPECT_EQ(map.stateAt({0.0, 0.0, 5.0}), State::kStatic) << "four misses do not undo a clamped hit";
  feed(far, 6);
  EXPECT_EQ(map.stateAt({0.0, 0.0, 5.0}), State::kFree);
  EXPECT_EQ(map.stateAt({0.0, 0.0, 8.0}), State::kOccupied);
  map.clear();
  EXPECT_EQ(map.stateAt({0.0, 0.0, 8.0}), State::kUnknown);
}

TEST(SceneMap, WritesABtFileOctoMapReads) {
  SceneMap map(everyFrame(), 0.5, 9.5);
  const DepthFrame frame = wallFrame();
  map.update(frame, Eigen::Isometry3d::Identity(), 0.0);
  const ScopedTempDir temp;
  const std::string path = (temp.path() / "scene.bt").string();
  map.writeBinary(path);  // waits for the rays in flight
  octomap::OcTree tree(path);
  EXPECT_DOUBLE_EQ(tree.getResolution(), kVoxel_m);
  const octomap::OcTreeNode* wall = tree.search(0.0, 0.0, 5.0);
  ASSERT_NE(wall, nullptr);
  EXPECT_TRUE(tree.isNodeOccupied(wall));
  const octomap::OcTreeNode* air = tree.search(0.0, 0.0, 2.0);
  ASSERT_NE(air, nullptr);
  EXPECT_FALSE(tree.isNodeOccupied(air));
  EXPECT_THROW(map.writeBinary("/nonexistent/scene.bt"), std::runtime_error);
}

kinect3d::DetectorConfig shippedDetector(const kinect3d::sim::Scene& scene) {
  const fw::Config config = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", "", {});
  kinect3d::DetectorConfig detector = kinect3d::readDetectorConfig(config.block("kinect3d"));
  detector.ground.pose = scene.sensor_pose;
  return detector;
}

TEST(SceneMap, FlagsABallHungInPlaceAsStaticButNeverAFlyingOne) {
  const kinect3d::sim::Scene hung = kinect3d::sim::loadScene("hung_3m");  // 3 s, a ball on a wire
  kinect3d::BallDetector detector(shippedDetector(hung), "kinect3d");
  kinect3d::sim::KinectSimulator simulator(hung);
  DepthFrame frame;
  kinect3d::sim::GroundTruth truth;
  kinect3d::Detections detections;
  kinect3d::TrajectoryConfig trajectory_config;
  auto trajectory = kinect3d::makeTrajectoryEstimator(trajectory_config);
  int early_static = 0, late_static = 0, late_balls = 0;
  for (int i = 0; i < simulator.frameCount(); ++i) {
    simulator.render(i, frame, truth);
    detector.detect(frame, detections);
    ASSERT_EQ(detections.balls.size(), 1u) << "frame " << i;
    const bool is_static = detections.balls.front().is_static;
    // Static after 2 s of rays: those of frame 60, published with the rays of frame 70.
    if (i < 60) early_static += is_static;
    if (i >= 75) late_static += is_static, ++late_balls;
    trajectory->update(frame.source_time_s, detections.balls);
  }
  EXPECT_EQ(early_static, 0);
  EXPECT_EQ(late_static, late_balls);
  EXPECT_GT(detector.sceneMap()->integrations(), 5);

  const kinect3d::sim::Scene kick = kinect3d::sim::loadScene("kick_away");
  kinect3d::BallDetector kick_detector(shippedDetector(kick), "kinect3d");
  kinect3d::sim::KinectSimulator kick_simulator(kick);
  int flying = 0;
  for (int i = 0; i < kick_simulator.frameCount(); ++i) {
    kick_simulator.render(i, frame, truth);
    kick_detector.detect(frame, detections);
    for (const fw::BallObservation& ball : detections.balls) {
      if (ball.state != fw::BallState::kAir) continue;
      ++flying;
      EXPECT_FALSE(ball.is_static) << "frame " << i;
    }
  }
  EXPECT_GT(flying, 10);
}

// Runs the detector over hung_3m (3 s) with the robot's field pose given from frame
// `pose_from` on; returns which frames flagged the ball static.
std::vector<bool> staticFlagsWithPoseFrom(int pose_from, const fw::RobotPose& pose) {
  const kinect3d::sim::Scene hung = kinect3d::sim::loadScene("hung_3m");
  kinect3d::BallDetector detector(shippedDetector(hung), "kinect3d");
  kinect3d::sim::KinectSimulator simulator(hung);
  DepthFrame frame;
  kinect3d::sim::GroundTruth truth;
  kinect3d::Detections detections;
  std::vector<bool> flags;
  for (int i = 0; i < simulator.frameCount(); ++i) {
    simulator.render(i, frame, truth);
    detector.detect(frame, detections, i >= pose_from ? std::optional<Eigen::Isometry3d>(pose.T_F_R()) : std::nullopt);
    flags.push_back(detections.balls.size() == 1 && detections.balls.front().is_static);
  }
  return flags;
}

TEST(SceneMap, WorksInTheFieldFrameAndStartsAfreshWhenAPoseAppears) {
  fw::RobotPose turned;  // standing off the centre spot, turned 30 degrees
  turned.x_m = 1.5;
  turned.y_m = -2.0;
  turned.theta_rad = 30.0 * M_PI / 180.0;
  const std::vector<bool> field = staticFlagsWithPoseFrom(0, turned);
  EXPECT_TRUE(std::all_of(field.begin() + 75, field.end(), [](bool f) { return f; }))
      << "the map kept in the field frame flags the hung ball as in the robot frame";
  // A pose from 1 s on (at the centre spot, so field and robot voxels would coincide): the
  // robot-frame map is dropped, and 2 s of field-frame rays are not over before the scene ends.
  const std::vector<bool> late = staticFlagsWithPoseFrom(30, fw::RobotPose{});
  EXPECT_TRUE(std::none_of(late.begin(), late.end(), [](bool f) { return f; }));
}

TEST(Trajectory, DoesNotFollowABallInStaticSpaceInTheAir) {
  kinect3d::TrajectoryConfig config;
  auto estimator = kinect3d::makeTrajectoryEstimator(config);
  // A real flight, whose detections are all flagged static: nothing is followed.
  int answers = 0;
  for (int i = 0; i < 20; ++i) {
    const double t = i / 30.0;
    fw::BallObservation ball = fw::BallObservation::inRobotFrame(
        Eigen::Vector3d(0.0, 2.0 + 6.0 * t, 0.5 + 4.0 * t - 4.905 * t * t), Eigen::Matrix3d::Identity() * 1e-4,
        fw::BallState::kAir, "kinect3d", fw::Stamp{t, t});
    ball.is_static = true;
    answers += estimator->update(t, {ball}).has_value();
  }
  EXPECT_EQ(answers, 0);
}

}  // namespace
