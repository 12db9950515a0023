// The scene map inside the detector: a ball hung in place is flagged static, a flying one never,
// the map follows the robot's field pose, and the trajectory ignores balls in static space.
#include <gtest/gtest.h>

#include <algorithm>
#include <optional>
#include <vector>

#include "framework_api/config.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/scene_map.h"
#include "kinect3d/sim/kinect_simulator.h"
#include "kinect3d/trajectory.h"
#include "shipped_config.h"

namespace {

using kinect3d::DepthFrame;

using testing_config::shippedDetector;

TEST(SceneMap, FlagsABallHungInPlaceAsStaticButNeverAFlyingOne) {
  const kinect3d::sim::Scene hung = kinect3d::sim::loadScene("hung_3m");  // 3 s, a ball on a wire
  kinect3d::BallDetector detector(shippedDetector(hung), "kinect3d");
  kinect3d::sim::KinectSimulator simulator(hung);
  DepthFrame frame;
  kinect3d::sim::GroundTruth truth;
  kinect3d::Detections detections;
  int early_static = 0, late_static = 0, late_balls = 0;
  for (int i = 0; i < simulator.frameCount(); ++i) {
    simulator.render(i, frame, truth);
    detector.detect(frame, detections);
    ASSERT_EQ(detections.balls.size(), 1u) << "frame " << i;
    const bool is_static = detections.balls.front().is_static;
    // Static after 2 s of rays: those of frame 60, published with the rays of frame 70.
    if (i < 60) early_static += is_static;
    if (i >= 75) late_static += is_static, ++late_balls;
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
