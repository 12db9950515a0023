#include <gtest/gtest.h>

#include <thread>

#include "framework_api/world_state.h"

namespace {

fw::BallObservation ballAt(double y_m, const std::string& source) {
  return fw::BallObservation::inRobotFrame({0.0, y_m, 0.5}, Eigen::Matrix3d::Identity() * 0.01,
                                           fw::BallState::kAir, source, fw::Stamp{y_m, y_m});
}

TEST(WorldState, KeepsNewestFirstAndCapsHistoryPerSource) {
  fw::WorldState world;
  for (int i = 0; i < 40; ++i) world.publishBall(ballAt(i, "kinect3d"));
  world.publishBall(ballAt(-1, "other"));
  const auto balls = world.recentBalls("kinect3d");
  ASSERT_EQ(balls.size(), fw::WorldState::kHistoryPerSource);
  EXPECT_DOUBLE_EQ(balls.front().position_m.y(), 39.0);
  EXPECT_DOUBLE_EQ(balls.back().position_m.y(), 40.0 - fw::WorldState::kHistoryPerSource);
  EXPECT_EQ(world.ballSources(), (std::vector<std::string>{"kinect3d", "other"}));
  EXPECT_TRUE(world.recentBalls("nobody").empty());
  EXPECT_EQ(world.version(), 41u);
}

TEST(WorldState, ConcurrentWritersAndReadersSeeWholeValues) {
  fw::WorldState world;
  std::thread writer([&] {
    for (int i = 0; i < 20000; ++i) {
      fw::FusedBall ball;
      ball.position_m = Eigen::Vector3d::Constant(i);  // all three coordinates equal
      world.publishFusedBall(ball);
    }
  });
  int torn = 0;
  for (int i = 0; i < 20000; ++i) {
    if (const auto ball = world.fusedBall()) {
      if (ball->position_m.x() != ball->position_m.z()) ++torn;
    }
  }
  writer.join();
  EXPECT_EQ(torn, 0);
  EXPECT_DOUBLE_EQ(world.fusedBall()->position_m.y(), 19999.0);
}

TEST(Types, RobotToFieldAndOmniGroundPoint) {
  fw::RobotPose pose{1.0, 2.0, M_PI / 2, {}};  // robot faces field -x
  const Eigen::Vector3d ahead_F = pose.fieldFromRobot({0.0, 1.0, 0.3});
  EXPECT_TRUE(ahead_F.isApprox(Eigen::Vector3d(0.0, 2.0, 0.3), 1e-12)) << ahead_F.transpose();
  fw::OmniBallObservation omni;
  omni.bearing_rad = M_PI / 2;  // to the robot's left
  omni.distance_m = 2.0;
  EXPECT_TRUE(omni.groundPoint_R().isApprox(Eigen::Vector3d(-2.0, 0.0, 0.0), 1e-12));
}

TEST(Types, ObservationIsApprox) {
  const fw::BallObservation a = ballAt(3.0, "kinect3d");
  fw::BallObservation b = a;
  b.position_m.x() += 0.005;
  EXPECT_TRUE(a.isApprox(b, 0.01));
  EXPECT_FALSE(a.isApprox(b, 0.001));
  b.state = fw::BallState::kGround;
  EXPECT_FALSE(a.isApprox(b, 0.01));
}

}  // namespace
