// The Kinect3D plugin inside the real host, and `kinect3d detect` as a user runs it.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cstdio>

#include "framework_api/host.h"
#include "run_command.h"
#include "run_host.h"

namespace {

TEST(Kinect3dPlugin, PublishesTheBallToTheWorldState) {
  const fw::Config config = fw::Config::load(
      std::string(PROJECT_CONFIG_DIR) + "/defaults", std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml",
      {"host.plugins=[kinect3d]", "kinect3d.source=sim:hung_3m", "kinect3d.realtime=false"});
  fw::Host host(config, PRODUCT_PLUGIN_DIR);
  runUntilSourcesEnd(host);
  ASSERT_TRUE(host.sourcesFinished());
  EXPECT_EQ(host.summaries().at(0).frames, 90u);
  const auto balls = host.world().recentBalls("kinect3d");
  ASSERT_EQ(balls.size(), fw::WorldState::kHistoryPerSource);
  for (const fw::BallObservation& ball : balls) {
    EXPECT_EQ(ball.frame, fw::Frame::kRobot);
    EXPECT_EQ(ball.state, fw::BallState::kAir);
    EXPECT_LT((ball.position_m - Eigen::Vector3d(0.0, 3.0, 1.0)).norm(), 0.03);
    EXPECT_GT(ball.covariance_m2(1, 1), 0.0);
    EXPECT_GT(ball.stamp.receive_time_s, 1.0e9);
  }
}

TEST(Kinect3dPlugin, BadSourceIsAStartupErrorNamingTheKey) {
  const fw::Config config = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults",
                                             std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml",
                                             {"host.plugins=[kinect3d]", "kinect3d.source=tum:/nonexistent"});
  try {
    fw::Host host(config, PRODUCT_PLUGIN_DIR);
    FAIL() << "expected an error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("--set kinect3d.source=tum:/nonexistent: kinect3d.source: TUM sequence folder "
                                         "'/nonexistent' does not exist"),
              std::string::npos)
        << e.what();
  }
}

TEST(DetectCommand, WritesOneJsonLinePerFrame) {
  const auto [status, out] = runCommand(std::string(KINECT3D_EXE) + " detect --source sim:hung_2m 2>/dev/null");
  ASSERT_EQ(status, 0);
  std::istringstream lines(out);
  int frames = 0;
  for (std::string line; std::getline(lines, line); ++frames) {
    const auto json = nlohmann::json::parse(line);
    EXPECT_EQ(json.at("frame").get<int>(), frames);
    EXPECT_GT(json.at("t").get<double>(), 1.0e9);
    EXPECT_GE(json.at("process_ms").get<double>(), 0.0);
    ASSERT_EQ(json.at("balls").size(), 1u) << line;
    const auto& ball = json["balls"][0];
    EXPECT_NEAR(ball.at("y").get<double>(), 2.0, 0.03);
    EXPECT_NEAR(ball.at("z").get<double>(), 1.0, 0.03);
    EXPECT_EQ(ball.at("state"), "air");
    EXPECT_GT(ball.at("points").get<int>(), 500);
  }
  EXPECT_EQ(frames, 90);
}

TEST(DetectCommand, ReportsTheTrajectoryAndTouchdownOfAKick) {
  const auto [status, out] = runCommand(std::string(KINECT3D_EXE) + " detect --source sim:kick_away 2>/dev/null");
  ASSERT_EQ(status, 0);
  std::istringstream lines(out);
  int with_touchdown = 0, frames = 0;
  for (std::string line; std::getline(lines, line); ++frames) {
    const auto json = nlohmann::json::parse(line);
    ASSERT_TRUE(json.contains("trajectory")) << line;
    const auto& trajectory = json["trajectory"];
    if (trajectory.is_null()) continue;
    EXPECT_EQ(trajectory.at("p").size(), 3u);
    EXPECT_EQ(trajectory.at("v").size(), 3u);
    EXPECT_GE(trajectory.at("support").get<int>(), 3);
    // Predictions during the first flight (the ball lands about 6 m out and hops on to 7.7 m).
    if (trajectory.at("state") == "air" && !trajectory.at("touchdown").is_null() &&
        trajectory["p"][1].get<double>() < 5.5) {
      ++with_touchdown;
      EXPECT_NEAR(trajectory["touchdown"].at("y").get<double>(), 6.0, 0.5);
      EXPECT_GT(trajectory["touchdown"].at("t").get<double>(), json.at("t").get<double>());
    }
  }
  EXPECT_EQ(frames, 45);
  EXPECT_GE(with_touchdown, 8);
}

TEST(DetectCommand, BadSourceOrConfigExitsNonZeroWithAMessage) {
  const auto [status, out] = runCommand(std::string(KINECT3D_EXE) + " detect --source bogus:thing 2>&1");
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("unknown depth source scheme 'bogus:'"), std::string::npos) << out;
  const auto [config_status, config_out] =
      runCommand(std::string(KINECT3D_EXE) + " detect --source sim:hung_2m --set kinect3d.grid.voxl_m=0.2 2>&1");
  EXPECT_EQ(config_status, 2);
  EXPECT_NE(config_out.find("unknown key 'kinect3d.grid.voxl_m'"), std::string::npos) << config_out;
}

TEST(DetectCommand, OutputIntoAClosedPipeOrAnUnwritableFileExits2) {
  // `true` reads nothing and exits at once: every later write meets a pipe without a reader. The
  // command's message and exit status go to fd 3, the shell's own output.
  const auto [closed_status, closed_out] =
      runCommand("exec 3>&1; { " + std::string(KINECT3D_EXE) +
                 " detect --source sim:hung_2m 2>&3; echo \"exit $?\" >&3; } | true");
  EXPECT_EQ(closed_status, 0);
  EXPECT_NE(closed_out.find("cannot write the detections to standard output"), std::string::npos) << closed_out;
  EXPECT_NE(closed_out.find("exit 2"), std::string::npos) << closed_out;
  const auto [file_status, file_out] =
      runCommand(std::string(KINECT3D_EXE) + " detect --source sim:hung_2m --output /dev/full 2>&1");
  EXPECT_EQ(file_status, 2);
  EXPECT_NE(file_out.find("cannot write the detections to '/dev/full'"), std::string::npos) << file_out;
}

}  // namespace
