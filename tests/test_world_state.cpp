#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <chrono>
#include <random>
#include <thread>
#include <vector>

#include "framework_api/world_state.h"

namespace {

fw::BallObservation ballAt(double y_m, const std::string& source) {
  return fw::BallObservation::inRobotFrame({0.0, y_m, 0.5}, Eigen::Matrix3d::Identity() * 0.01, fw::BallState::kAir,
                                           source, fw::Stamp{y_m, y_m});
}

TEST(WorldState, KeepsNewestFirstAndCapsHistoryPerSource) {
  fw::WorldState world;
  for (int i = 0; i < 40; ++i) world.publishBalls({ballAt(i, "kinect3d")});
  world.publishBalls({ballAt(-1, "other")});
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
      ball.position_F = Eigen::Vector3d::Constant(i);  // all three coordinates equal
      world.publishFusedBall(ball);
    }
  });
  int torn = 0;
  for (int i = 0; i < 20000; ++i) {
    if (const auto ball = world.fusedBall()) {
      if (ball->position_F.x() != ball->position_F.z()) ++torn;
    }
  }
  writer.join();
  EXPECT_EQ(torn, 0);
  EXPECT_DOUBLE_EQ(world.fusedBall()->position_F.y(), 19999.0);
}

TEST(WorldState, HoldsRobotPoseOmniBallsAndTrajectories) {
  fw::WorldState world;
  EXPECT_FALSE(world.robotPose());
  world.publishRobotPose({1.0, -2.0, 0.5, {}, std::nullopt});
  EXPECT_DOUBLE_EQ(world.robotPose()->y_m, -2.0);
  fw::OmniBallObservation omni;
  omni.distance_m = 3.0;
  omni.source = "omni";
  world.publishOmniFrame({omni.stamp, {omni}, "omni"});
  ASSERT_EQ(world.recentOmniBalls("omni").size(), 1u);
  EXPECT_DOUBLE_EQ(world.recentOmniBalls("omni")[0].distance_m, 3.0);
  fw::BallTrajectory trajectory;
  trajectory.source = "kinect3d";
  trajectory.support = 7;
  world.publishTrajectory(trajectory);
  EXPECT_EQ(world.trajectory("kinect3d")->support, 7);
  world.clearTrajectory("kinect3d");
  EXPECT_FALSE(world.trajectory("kinect3d"));
}

TEST(Types, TrajectoryPropagation) {
  fw::BallTrajectory flight;
  flight.time_s = 10.0;
  flight.position_m = {0.0, 2.0, 1.0};
  flight.velocity_mps = {0.0, 5.0, 2.0};
  const Eigen::Vector3d later = flight.positionAt(10.5);
  EXPECT_TRUE(later.isApprox(Eigen::Vector3d(0.0, 4.5, 1.0 + 1.0 - 0.5 * 9.81 * 0.25), 1e-12));
  EXPECT_TRUE(flight.movedTo(10.5).position_m.isApprox(later, 1e-12));
  flight.drag_per_m = 0.024;  // drag shortens the flight
  EXPECT_LT(flight.positionAt(10.5).y(), later.y() - 0.02);
  fw::BallTrajectory roll;
  roll.state = fw::BallState::kGround;
  roll.position_m = {0.0, 1.0, 0.11};
  roll.velocity_mps = {0.0, 2.0, 0.0};
  roll.rolling_decel_mps2 = 0.5;
  EXPECT_NEAR(roll.positionAt(10.0).y(), 1.0 + 2.0 * 2.0 / (2 * 0.5), 1e-9) << "stops after 4 s, 4 m on";
  EXPECT_NEAR(roll.velocityAt(10.0).norm(), 0.0, 1e-12);
}

TEST(Types, RobotToFieldAndOmniGroundPoint) {
  fw::RobotPose pose{1.0, 2.0, M_PI / 2, {}, std::nullopt};  // robot faces field -x
  const Eigen::Vector3d ahead_F = pose.fieldFromRobot({0.0, 1.0, 0.3});
  EXPECT_TRUE(ahead_F.isApprox(Eigen::Vector3d(0.0, 2.0, 0.3), 1e-12)) << ahead_F.transpose();
  fw::OmniBallObservation omni;
  omni.bearing_rad = M_PI / 2;  // to the robot's left
  omni.distance_m = 2.0;
  EXPECT_TRUE(omni.groundPoint_R().isApprox(Eigen::Vector3d(-2.0, 0.0, 0.0), 1e-12));
}

TEST(Types, TheLargestEigenvalueOfASymmetric2x2MatrixIsEigensOwn) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> entry(-2.0, 2.0);
  std::vector<Eigen::Matrix2d> matrices = {Eigen::Matrix2d::Zero(), Eigen::Matrix2d::Identity() * 0.04,
                                           (Eigen::Matrix2d() << 0.01, 0.0, 0.0, 0.09).finished(),
                                           (Eigen::Matrix2d() << 1.0, 1.0, 1.0, 1.0).finished()};  // singular
  for (int i = 0; i < 100; ++i) {
    const Eigen::Matrix2d a = Eigen::Matrix2d::NullaryExpr([&] { return entry(random); });
    matrices.push_back(a * a.transpose());  // a covariance
    matrices.push_back(a + a.transpose());  // symmetric, possibly indefinite
  }
  for (const Eigen::Matrix2d& m : matrices) {
    const double eigen = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(m).eigenvalues().maxCoeff();
    EXPECT_NEAR(fw::largestEigenvalue(m), eigen, 1e-12 * std::max(1.0, m.norm())) << m;
  }
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

TEST(WorldState, JournalHoldsEveryPublicationInOrderOnlyOnceOpened) {
  fw::WorldState world;
  world.publishBalls({ballAt(1.0, "kinect3d")});  // before anyone reads the journal: not kept
  EXPECT_FALSE(world.journalOpen());
  world.openJournal(false);
  world.publishDepthImage(fw::DepthImage{});  // not wanted: not kept
  world.publishBalls({ballAt(2.0, "kinect3d"), ballAt(2.5, "kinect3d")});
  world.publishRobotPose({1.0, -2.0, 0.5, {}, std::nullopt});
  world.publishEvent({"kinect3d", "floor_found", "aligned", {}});
  world.clearTrajectory("kinect3d");  // it had none: nothing happened, nothing journalled
  std::uint64_t refused = 0;
  const std::vector<fw::JournalEntry> entries = world.takeJournal(&refused);
  ASSERT_EQ(entries.size(), 3u);
  const auto& frame = std::get<fw::BallFrame>(entries[0].item);
  ASSERT_EQ(frame.balls.size(), 2u);
  EXPECT_DOUBLE_EQ(frame.balls[1].position_m.y(), 2.5);
  EXPECT_DOUBLE_EQ(std::get<fw::RobotPose>(entries[1].item).y_m, -2.0);
  EXPECT_EQ(std::get<fw::Event>(entries[2].item).kind, "floor_found");
  EXPECT_LE(entries[0].wall_time_s, entries[2].wall_time_s);
  EXPECT_EQ(refused, 0u);
  EXPECT_TRUE(world.takeJournal(&refused).empty());  // taken once

  // Every update of the world ball is kept, one without a ball too, even when there was none before.
  world.clearFusedBall({3.0, 4.0});
  world.clearFusedBall({3.1, 4.1});
  const std::vector<fw::JournalEntry> updates = world.takeJournal(&refused);
  ASSERT_EQ(updates.size(), 2u);
  EXPECT_DOUBLE_EQ(std::get<fw::FusedBallCleared>(updates[1].item).stamp.source_time_s, 3.1);
  EXPECT_FALSE(world.fusedBall());
}

TEST(WorldState, JournalRefusesAndCountsWhatItsReaderCannotKeepUpWith) {
  fw::WorldState world;
  world.openJournal(true);
  for (std::size_t i = 0; i < fw::WorldState::kJournalDepthImages + 5; ++i) world.publishDepthImage({});
  std::uint64_t refused = 0;
  EXPECT_EQ(world.takeJournal(&refused).size(), fw::WorldState::kJournalDepthImages);
  EXPECT_EQ(refused, 5u);
  for (std::size_t i = 0; i < fw::WorldState::kJournalCapacity + 3; ++i) world.publishRobotPose({});
  refused = 0;
  EXPECT_EQ(world.takeJournal(&refused).size(), fw::WorldState::kJournalCapacity);
  EXPECT_EQ(refused, 3u);
  world.closeJournal();
  world.publishRobotPose({});
  EXPECT_TRUE(world.takeJournal(&refused).empty());
}

TEST(WorldState, ADepthFramesBallsComeInTheOrderTheFrameArrivedWhateverCameWhileItWasProcessed) {
  fw::WorldState world;
  std::uint64_t pose_cursor = 0, reader = 0;
  world.publishRobotPose({1.0, 0.0, 0.0, {10.0, 10.0}, std::nullopt});
  const fw::WorldState::DepthArrival arrival = world.arriveDepthFrame(std::nullopt, &pose_cursor);
  ASSERT_EQ(arrival.poses.size(), 1u) << "the detector gets the poses that came before its frame";
  // While the frame is processed, a pose and an omni image come.
  world.publishRobotPose({2.0, 0.0, 0.0, {10.03, 10.03}, std::nullopt});
  world.publishOmniFrame({{10.02, 10.02}, {}, "omni"});
  EXPECT_EQ(world.measurementsSince(&reader).size(), 1u) << "the first pose; the rest waits for the frame's balls";
  world.publishBallFrame(arrival.place, {{10.0, 10.0}, {}, "kinect3d"});
  const std::vector<fw::WorldState::Measurement> after = world.measurementsSince(&reader);
  ASSERT_EQ(after.size(), 3u);
  EXPECT_EQ(std::get<fw::BallFrame>(after[0]).source, "kinect3d") << "a frame without a ball is a measurement too";
  EXPECT_DOUBLE_EQ(std::get<fw::RobotPose>(after[1]).x_m, 2.0);
  EXPECT_EQ(std::get<fw::OmniFrame>(after[2]).source, "omni");
  EXPECT_EQ(world.arriveDepthFrame(std::nullopt, &pose_cursor).poses.size(), 1u) << "each pose once";
}

TEST(WorldState, AReaderGoesPastADepthFrameWhoseBallsNeverCome) {
  fw::WorldState world;
  std::uint64_t pose_cursor = 0, reader = 0;
  const std::uint64_t place = world.arriveDepthFrame(std::nullopt, &pose_cursor).place;  // its plugin sticks
  world.publishOmniFrame({{1.0, 1.0}, {}, "omni"});
  std::size_t seen = world.measurementsSince(&reader).size();
  EXPECT_EQ(seen, 0u);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (seen == 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    seen = world.measurementsSince(&reader).size();
  }
  EXPECT_EQ(seen, 1u) << "the omni image is read after kArrivalPatience_s";
  world.publishBallFrame(place, {{0.9, 0.9}, {}, "kinect3d"});  // the plugin comes back
  const std::vector<fw::WorldState::Measurement> late = world.measurementsSince(&reader);
  ASSERT_EQ(late.size(), 1u) << "its balls are not lost: they come as a late measurement";
  EXPECT_EQ(std::get<fw::BallFrame>(late[0]).source, "kinect3d");
}

TEST(WorldState, ASourcesNewestFrameSaysWhetherItSeesTheBallNow) {
  fw::WorldState world;
  std::uint64_t pose_cursor = 0;
  EXPECT_FALSE(world.newestBallFrame("kinect3d"));
  const auto frame = [&](std::vector<fw::BallObservation> balls) {
    world.publishBallFrame(world.arriveDepthFrame(std::nullopt, &pose_cursor).place,
                           {{1.0, 1.0}, std::move(balls), "kinect3d"});
  };
  frame({ballAt(2.0, "kinect3d")});
  ASSERT_EQ(world.newestBallFrame("kinect3d")->balls.size(), 1u);
  frame({});  // lost it
  EXPECT_TRUE(world.newestBallFrame("kinect3d")->balls.empty()) << "the console prints no ball, not the last one";
  EXPECT_EQ(world.recentBalls("kinect3d").size(), 1u) << "the recent balls are still there for who wants them";
}

}  // namespace
