// The team plugin between hosts over loopback (one 127.0.0.N address per robot, never a multicast
// group): a robot's Kinect balls reach a teammate placed in the field, and packets from outside the
// team are refused and said.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "framework_api/host.h"
#include "kinect3d/sim/ball_motion.h"
#include "kinect3d/sim/scene.h"
#include "published_log.h"
#include "run_command.h"
#include "scoped_temp_dir.h"
#include "team_packet.h"

namespace {

std::string writeKey(const ScopedTempDir& dir, const std::string& name, const team::TeamKey& key) {
  const std::string path = (dir.path() / name).string();
  std::ofstream(path) << key.hex() << "\n";
  return path;
}

// A robot of team 5 on 127.0.0.<address>, talking to the given peers on port.
fw::Config robotConfig(const std::string& name, int robot_id, int address, const std::vector<int>& peers, int port,
                       const std::string& key_file, const std::string& plugins,
                       const std::vector<std::string>& more = {}) {
  std::string peer_list;
  for (const int peer : peers) {
    peer_list += (peer_list.empty() ? "" : ", ") + std::string("127.0.0.") + std::to_string(peer);
  }
  std::vector<std::string> overrides{"host.robot_name=" + name,
                                     "host.plugins=" + plugins,
                                     "team.team_id=5",
                                     "team.robot_id=" + std::to_string(robot_id),
                                     "team.bind_address=127.0.0." + std::to_string(address),
                                     "team.port=" + std::to_string(port),
                                     "team.peers=[" + peer_list + "]",
                                     "team.key_file=" + key_file};
  overrides.insert(overrides.end(), more.begin(), more.end());
  return fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults",
                          std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml", overrides);
}

TEST(TeamPlugin, ARobotWithoutAKinectHoldsTheLobFromItsTeammatesAndOutsidersAreRefused) {
  const ScopedTempDir dir;
  // The team's key as a team makes it; a second run never overwrites it.
  const std::string team_key = (dir.path() / "team.key").string();
  ASSERT_EQ(runCommand(std::string(KINECT3D_EXE) + " team-key --out " + team_key).first, 0);
  const std::string first_key = team::TeamKey::fromFile(team_key).hex();
  EXPECT_NE(runCommand(std::string(KINECT3D_EXE) + " team-key --out " + team_key + " 2>&1").first, 0);
  EXPECT_EQ(team::TeamKey::fromFile(team_key).hex(), first_key);
  const std::string other_key = writeKey(dir, "other.key", team::TeamKey::random());
  constexpr int kPort = 50431;  // this test's own: tests running beside it use other ports
  // The keeper sees the demo's lob with its Kinect; the defender has no Kinect (its omni camera and
  // localisation play the same scene); a stranger with another key sends too.
  fw::Host keeper(robotConfig("keeper", 1, 21, {22}, kPort, team_key, "[localisation, kinect3d, omni, fusion, team]"),
                  PRODUCT_PLUGIN_DIR);
  const std::string logs = (dir.path() / "logs").string();
  fw::Host defender(robotConfig("defender", 2, 22, {21}, kPort, team_key, "[localisation, omni, fusion, team, logger]",
                                {"logger.folder=" + logs}),
                    PRODUCT_PLUGIN_DIR);
  fw::Host stranger(robotConfig("stranger", 3, 23, {22}, kPort, other_key, "[team]"), PRODUCT_PLUGIN_DIR);
  const kinect3d::sim::Scene scene = kinect3d::sim::loadScene("lob_over_robot");
  const kinect3d::sim::BallMotion truth(*scene.ball, scene.physics, scene.duration_s, scene.objects);
  // How far p lies from the true flight within 0.1 s of t (the defender's clock): the two robots'
  // simulated worlds start when their hosts' threads first read them, tens of milliseconds apart.
  const auto offTheFlight_m = [&](const Eigen::Vector3d& p, double t) {
    double off_m = 1e9;
    for (double dt = -0.1; dt <= 0.1; dt += 0.005) {
      off_m = std::min(off_m, (p - truth.positionAt(t - scene.start_time_s + dt)).norm());
    }
    return off_m;
  };
  defender.start();
  stranger.start();
  keeper.start();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(90);
  while (!(keeper.sourcesFinished() && defender.sourcesFinished()) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    keeper.watch();
    defender.watch();
  }
  keeper.stop();
  stranger.stop();
  // Then the defender, once it has taken in everything that reached it: its world state still for a
  // few of its fusion's steps (else its log could hold a message its fusion never read, which its
  // replay would then read).
  std::uint64_t version = defender.world().version();
  for (int still = 0; still < 3 && std::chrono::steady_clock::now() < deadline;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const std::uint64_t now = defender.world().version();
    still = now == version ? still + 1 : 0;
    version = now;
  }
  defender.stop();
  ASSERT_TRUE(keeper.sourcesFinished() && defender.sourcesFinished());

  // What the defender received and made of it, from its match log. Its fusion works on its omni
  // camera's clock (it has no Kinect), the scene's: the keeper's times arrive moved onto it.
  const std::string run = onlySubfolder(logs);
  int messages = 0, kinect_balls = 0, far_off = 0, air_balls_from_keeper = 0, air_far_off = 0;
  bool refused_stranger = false, said_clock = false;
  for (const fw::JournalEntry& entry : kinect3d::MatchLogReader(run).entries()) {
    if (const auto* message = std::get_if<fw::TeamMessage>(&entry.item)) {
      ++messages;
      EXPECT_EQ(message->robot_id, 1) << "only the keeper's messages are taken";
      EXPECT_EQ(message->robot_name, "keeper");
      EXPECT_LE(message->clock_offset_sigma_s, 0.005) << "one machine, kernel arrival times";
      for (const fw::BallObservation& ball : message->kinect_balls) {
        ++kinect_balls;
        EXPECT_EQ(ball.frame, fw::Frame::kField);
        if (offTheFlight_m(ball.position_m, ball.stamp.source_time_s) > 0.15) ++far_off;
      }
    } else if (const auto* ball = std::get_if<fw::FusedBall>(&entry.item)) {
      const bool from_keeper = std::count(ball->sources.begin(), ball->sources.end(), "team:keeper") > 0;
      if (ball->state != fw::BallState::kAir || !from_keeper) continue;
      ++air_balls_from_keeper;
      if (offTheFlight_m(ball->position_F, ball->stamp.source_time_s) > 0.15) ++air_far_off;
    } else if (const auto* event = std::get_if<fw::Event>(&entry.item)) {
      refused_stranger |= event->kind == "team_refused" && event->message.find("127.0.0.23") != std::string::npos &&
                          event->message.find("not signed with the team key") != std::string::npos;
      // One machine, one clock: the offset the exchange finds is within a few milliseconds of none.
      said_clock |=
          event->kind == "teammate_clock" && event->message.find("keeper") != std::string::npos &&
          (event->message.find("+0.00") != std::string::npos || event->message.find("-0.00") != std::string::npos);
    }
  }
  EXPECT_GE(messages, 40) << "20 messages a second for the scene's 3.5 s";
  EXPECT_GE(kinect_balls, 20) << "the lob the keeper's Kinect saw";
  EXPECT_LE(far_off, kinect_balls / 10) << "placed in the field with the keeper's pose at their time";
  EXPECT_GE(air_balls_from_keeper, 20) << "the defender holds the lob in the air from the keeper's Kinect";
  EXPECT_LE(air_far_off, air_balls_from_keeper / 10);
  EXPECT_TRUE(refused_stranger);
  EXPECT_TRUE(said_clock);
  EXPECT_GT(defender.world().droppedFrames("team"), 0u) << "the stranger's packets, counted";

  // The defender's log replays to the same world balls: the teammates' messages are inputs of the
  // log, and the replay's team plugin hands them out in the order they came (and sends nothing).
  const Published live = publishedIn(run);
  ASSERT_GT(live.world_balls.size(), 100u);
  const Published replayed = publishedIn(replayInto(run, dir.path() / "replayed"));
  expectSame(live.world_balls, replayed.world_balls, "world ball");
  expectSame(live.events, replayed.events, "event");
}

TEST(TeamPlugin, ARobotFileWithoutItsIdOrKeyIsRefusedNamingTheKey) {
  const auto error = [](const std::vector<std::string>& overrides) {
    std::vector<std::string> all{"host.plugins=[team]", "team.peers=[127.0.0.2]"};
    all.insert(all.end(), overrides.begin(), overrides.end());
    try {
      fw::Host host(fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults",
                                     std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml", all),
                    PRODUCT_PLUGIN_DIR);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error({}).find("team.robot_id"), std::string::npos) << error({});
  EXPECT_NE(error({"team.robot_id=4"}).find("team.key_file is empty"), std::string::npos);
  EXPECT_NE(error({"team.robot_id=4", "team.key_file=/nonexistent/team.key"}).find("/nonexistent/team.key"),
            std::string::npos);
  const ScopedTempDir dir;
  const std::string key = "team.key_file=" + writeKey(dir, "team.key", team::TeamKey::random());
  EXPECT_NE(error({"team.robot_id=4", key, "team.peers=[]"}).find("team.peers is empty"), std::string::npos);
  EXPECT_NE(error({"team.robot_id=4", key, "team.peers=[robot7]"}).find("'robot7' is not an IPv4 address"),
            std::string::npos);
}

}  // namespace
