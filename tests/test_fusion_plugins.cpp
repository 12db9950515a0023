// The fusion as the robot runs it (the demo robot's plugins in the host, in real time) and as a
// user runs it offline (`kinect3d simulate` then `kinect3d fuse`), with its files' errors.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "framework_api/host.h"
#include "kinect3d/sim/ball_motion.h"
#include "kinect3d/sim/scene.h"
#include "run_command.h"
#include "scoped_temp_dir.h"

namespace {

// Runs the host until its sources end (at most a minute) and hands every new world ball to `seen`,
// sampled every 5 ms as behaviour code would.
void runAndSampleWorldBall(fw::Host& host, const std::function<void(const fw::FusedBall&)>& seen) {
  host.start();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  double last_stamp = 0.0;
  while (!host.sourcesFinished() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    const auto ball = host.world().fusedBall();
    if (!ball || ball->stamp.source_time_s == last_stamp) continue;
    last_stamp = ball->stamp.source_time_s;
    seen(*ball);
  }
  host.stop();
}

// The demo robot's field-player plugins on a scene file of tests/data/scenes, with more overrides.
fw::Config demoRobotOn(const std::string& scene_file, std::vector<std::string> overrides = {}) {
  const std::string scene = "sim:" + std::string(TEST_DATA_DIR) + "/scenes/" + scene_file;
  overrides.insert(overrides.end(), {"host.plugins=[localisation, kinect3d, omni, fusion]", "kinect3d.source=" + scene,
                                     "omni.source=" + scene, "localisation.source=" + scene});
  return fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults",
                          std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml", overrides);
}

// Runs the host with its journal open until its sources end; its events of one kind.
std::vector<fw::Event> runAndKeepEvents(fw::Host& host, const std::string& kind) {
  host.world().openJournal(false);
  runAndSampleWorldBall(host, [](const fw::FusedBall&) {});
  EXPECT_TRUE(host.sourcesFinished());
  std::vector<fw::Event> events;
  for (const fw::JournalEntry& entry : host.world().takeJournal(nullptr)) {
    const auto* event = std::get_if<fw::Event>(&entry.item);
    if (event != nullptr && event->kind == kind) events.push_back(*event);
  }
  return events;
}

TEST(FusionPlugins, TheDemoRobotFusesTheLobFlyingOverItWhileItDrives) {
  const fw::Config config = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults",
                                             std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml",
                                             {"host.plugins=[localisation, kinect3d, omni, fusion]"});
  const kinect3d::sim::Scene scene = kinect3d::sim::loadScene("lob_over_robot");
  const kinect3d::sim::BallMotion truth(*scene.ball, scene.physics, scene.duration_s, scene.objects);
  fw::Host host(config, PRODUCT_PLUGIN_DIR);
  // The scene plays in real time (3.5 s).
  int samples = 0, in_air_from_both = 0, far_off_in_air = 0;
  runAndSampleWorldBall(host, [&](const fw::FusedBall& ball) {
    ++samples;
    const Eigen::Vector3d true_F = truth.positionAt(ball.stamp.source_time_s - scene.start_time_s);
    const bool both = ball.sources == std::vector<std::string>{"kinect3d", "omni"};
    if (ball.state == fw::BallState::kAir && both && true_F.z() > 0.3 && true_F.y() > 0.5) {
      ++in_air_from_both;
      if ((ball.position_F - true_F).norm() > 0.25) ++far_off_in_air;
    }
  });
  ASSERT_TRUE(host.sourcesFinished());
  EXPECT_GT(samples, 50);
  EXPECT_GE(in_air_from_both, 10) << "the lob in front of the robot, fused from both sensors";
  // Its sources keep to one pace (fw::SharedPace): each depth frame comes before the omni image of
  // the next moment, so the kick is seen in the air as offline. Each anchoring its own first item,
  // the Kinect's frames came a frame or two behind, and the first two samples in the air were
  // 0.4-0.6 m off; a frame dropped on a busy machine may cost one.
  EXPECT_LE(far_off_in_air, 1) << "of " << in_air_from_both << " samples in the air from both sensors";
}

TEST(FusionPlugins, SaysTheBounceItLearntFromTheBouncesTheKinectSaw) {
  // A ball deader than the configured one bounces before the robot. Rendered to files and fused in
  // the host's deterministic mode (every frame handed out at its stamp): in real time a slow machine
  // (a sanitizer's build) drops the frames a bounce's fits need.
  const ScopedTempDir dir;
  const std::string d = dir.path().string();
  const std::string scene = std::string(TEST_DATA_DIR) + "/scenes/dead_ball_bounces_in_view.yaml";
  ASSERT_EQ(runCommand(std::string(KINECT3D_EXE) + " simulate " + scene + " --out " + d + " 2>/dev/null").first, 0);
  const auto [status, output] = runCommand(std::string(KINECT3D_EXE) + " fuse --depth tum:" + d + " --omni " + d +
                                           "/omni.jsonl --pose " + d + "/pose.jsonl --output " + d + "/out.jsonl 2>&1");
  ASSERT_EQ(status, 0) << output;
  // The configured 0.6 worth two bounces, and one of 0.45; the configured friction 0.2 and one of 0.35.
  EXPECT_NE(output.find("[fusion] the ball bounces with restitution 0.55 +- 0.06 and bounce friction 0.25"),
            std::string::npos)
      << output;
  EXPECT_NE(output.find("learnt from 1 bounce the Kinect saw, from the configured 0.60 and 0.20"), std::string::npos)
      << output;
}

// The fusion plugin's alignment alarms on a ball at rest that crosses the Kinect's view while the
// robot turns (6.5 s in real time), with the Kinect's pose_in_robot as given. A short window (60
// pairs, 2 s) so that the scene holds three fits.
std::vector<fw::Event> alignmentAlarmsWithPose(const std::string& pose) {
  fw::Host host(demoRobotOn("ball_at_rest_robot_turning.yaml",
                            {"kinect3d.sensor.pose_in_robot=" + pose, "fusion.alignment_check.window_pairs=60"}),
                PRODUCT_PLUGIN_DIR);
  return runAndKeepEvents(host, "calibration_alarm");
}

// The yaw_deg of the pose an alarm estimates.
double estimatedYaw_deg(const std::string& message) {
  const std::size_t estimate = message.find("Estimated pose_in_robot: {");
  const std::size_t yaw = message.find("yaw_deg: ", estimate);
  if (estimate == std::string::npos || yaw == std::string::npos) throw std::runtime_error("no estimate: " + message);
  return std::stod(message.substr(yaw + 9));
}

TEST(FusionPlugins, TheAlignmentCheckFindsAKinectTurnedOnTheRobot) {
  // The floor cannot see a turn about the vertical (test_calibration.cpp); the omni camera can.
  EXPECT_TRUE(
      alignmentAlarmsWithPose("{x: 0.05, y: 0.1, z: 0.7, yaw_deg: 0.0, pitch_deg: 0.0, roll_deg: 0.0}").empty());
  const std::vector<fw::Event> turned =
      alignmentAlarmsWithPose("{x: 0.05, y: 0.1, z: 0.7, yaw_deg: 6.0, pitch_deg: 0.0, roll_deg: 0.0}");
  ASSERT_EQ(turned.size(), 1u);  // once per episode
  EXPECT_EQ(turned[0].source, "fusion");
  EXPECT_NE(turned[0].message.find("THE SENSOR HAS MOVED"), std::string::npos) << turned[0].message;
  EXPECT_NEAR(estimatedYaw_deg(turned[0].message), 0.0, 1.5) << turned[0].message;
}

TEST(FusionPlugins, OmniAndPosesReplayedFromFilesReachTheWorldBall) {
  const ScopedTempDir dir;
  const std::string d = dir.path().string();
  ASSERT_EQ(
      runCommand(std::string(KINECT3D_EXE) + " simulate pass_on_ground --frames 45 --out " + d + " 2>/dev/null").first,
      0);
  const fw::Config config = fw::Config::load(
      std::string(PROJECT_CONFIG_DIR) + "/defaults", std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml",
      {"host.plugins=[localisation, omni, fusion]", "omni.source=file:" + d + "/omni.jsonl",
       "localisation.source=file:" + d + "/pose.jsonl"});
  fw::Host host(config, PRODUCT_PLUGIN_DIR);
  int with_omni_ball = 0;
  runAndSampleWorldBall(
      host, [&](const fw::FusedBall& ball) { with_omni_ball += ball.sources == std::vector<std::string>{"omni"}; });
  ASSERT_TRUE(host.sourcesFinished());
  EXPECT_GT(with_omni_ball, 10) << "the omni camera alone carries the world's ball";
  ASSERT_TRUE(host.world().robotPose());
  EXPECT_GT(host.world().robotPose()->y_m, 0.3) << "the replayed robot drove forward";
}

TEST(FusionPlugins, TheFusionPluginNeedsNeitherTheDepthLibraryNorTheSimulator) {
  // It learns where the Kinect sits from the world state, not from the depth plugin's configuration.
  const auto [status, needed] = runCommand("readelf -d " + std::string(PRODUCT_PLUGIN_DIR) + "/fusion.so");
  ASSERT_EQ(status, 0) << needed;
  EXPECT_NE(needed.find("[libfusion.so]"), std::string::npos) << needed;
  EXPECT_EQ(needed.find("libkinect3d"), std::string::npos) << needed;
}

TEST(FuseCommand, FusesFilesDeterministicallyAndFollowsTheChip) {
  const ScopedTempDir dir;
  const std::string exe = KINECT3D_EXE, d = dir.path().string();
  ASSERT_EQ(runCommand(exe + " simulate chip_and_roll --frames 60 --out " + d + " 2>/dev/null").first, 0);
  const std::string fuse = exe + " fuse --depth tum:" + d + " --omni " + d + "/omni.jsonl --pose " + d + "/pose.jsonl";
  ASSERT_EQ(runCommand(fuse + " --output " + d + "/a.jsonl 2>/dev/null").first, 0);
  ASSERT_EQ(runCommand(fuse + " --output " + d + "/b.jsonl 2>/dev/null").first, 0);
  EXPECT_EQ(runCommand("cmp " + d + "/a.jsonl " + d + "/b.jsonl").first, 0) << "same inputs, same output";

  std::ifstream lines(d + "/a.jsonl");
  int updates = 0, air = 0, both = 0;
  double last_t = 0.0;
  for (std::string line; std::getline(lines, line); ++updates) {
    const auto json = nlohmann::json::parse(line);
    EXPECT_GE(json.at("t").get<double>(), last_t) << "in source-time order";
    last_t = json["t"].get<double>();
    if (json.at("ball").is_null()) continue;
    const auto& ball = json["ball"];
    EXPECT_EQ(ball.at("field").size(), 3u);
    EXPECT_EQ(ball.at("robot").size(), 3u);
    EXPECT_EQ(ball.at("v_field").size(), 3u);
    EXPECT_GT(ball.at("sigma_m").get<double>(), 0.0);
    air += ball.at("state") == "air";
    both += ball.at("sources") == nlohmann::json::array({"kinect3d", "omni"});
  }
  EXPECT_GT(updates, 100) << "Kinect and omni frames of 2 s";
  EXPECT_GT(air, 20);
  EXPECT_GT(both, 80);
}

TEST(FuseCommand, ABadInputLineIsNamedWithItsFileAndLine) {
  const ScopedTempDir dir;
  const std::string omni = (dir.path() / "omni.jsonl").string(), pose = (dir.path() / "pose.jsonl").string();
  std::ofstream(omni) << "{\"t\": 1700000000.0, \"balls\": []}\n"
                      << "{\"t\": 1700000000.033, \"balls\": [{\"bearing_rad\": 0.1, \"distance_m\": -3}]}\n";
  std::ofstream(pose) << "{\"t\": 1700000000.0, \"x_m\": 0, \"y_m\": 0, \"theta_rad\": 0}\n\n"
                      << "{\"t\": 1700000000.1, \"x_m\": 0, \"y\": 0, \"theta_rad\": 0}\n";
  const std::string exe = KINECT3D_EXE;
  const auto [omni_status, omni_out] = runCommand(exe + " fuse --omni " + omni + " --output /dev/null 2>&1");
  EXPECT_EQ(omni_status, 2);
  EXPECT_NE(omni_out.find(omni + ":2: balls[0]: \"distance_m\" = -3 is outside"), std::string::npos) << omni_out;
  const std::string robots = (dir.path() / "robots.jsonl").string();
  std::ofstream(robots)
      << "{\"t\": 1700000000.0, \"balls\": [], \"robots\": [{\"bearing_rad\": 0.1, \"distance_m\": 4}]}\n"
      << "{\"t\": 1700000000.033, \"balls\": [], \"robots\": [{\"bearing_rad\": 0.1}]}\n";
  const auto [robots_status, robots_out] = runCommand(exe + " fuse --omni " + robots + " --output /dev/null 2>&1");
  EXPECT_EQ(robots_status, 2);
  EXPECT_NE(robots_out.find(robots + ":2: robots[0]: "), std::string::npos) << robots_out;
  EXPECT_NE(robots_out.find("distance_m"), std::string::npos) << robots_out;
  const std::string no_balls = (dir.path() / "no_balls.jsonl").string();
  std::ofstream(no_balls) << "{\"t\": 1700000000.0, \"balls\": []}\n";
  const auto [pose_status, pose_out] =
      runCommand(exe + " fuse --omni " + no_balls + " --pose " + pose + " --output /dev/null 2>&1");
  EXPECT_EQ(pose_status, 2);
  EXPECT_NE(pose_out.find(pose + ":3: unknown key \"y\""), std::string::npos) << pose_out;
  const auto [none_status, none_out] = runCommand(exe + " fuse --output /dev/null 2>&1");
  EXPECT_EQ(none_status, 2);
  EXPECT_NE(none_out.find("give --depth, --omni or both"), std::string::npos) << none_out;
}

}  // namespace
