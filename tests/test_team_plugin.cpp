// The team plugin between hosts over loopback (one 127.0.0.N address per robot, never a multicast
// group): a robot without a Kinect holds a lob from its teammate's messages, through a network that
// loses, delays and duplicates them too; packets from outside the team are refused and said; a
// mislocalised teammate is discounted; three robots, each its own host process, simulating one
// world hold a lob only one of them sees; recorded runs replayed hold the lob (one of them the run
// that once lost it) and a hop two robots' omni cameras place; an omni ray is placed with the pose
// when its image was taken; a robot file without its id or key is refused; the team worlds fly one
// ball in every robot's file, and the team report plays the ones named and shows a mislocalised
// keeper discounted, moving no robot's world ball in most updates.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "framework_api/host.h"
#include "host_process.h"
#include "kinect3d/sim/ball_motion.h"
#include "kinect3d/sim/scene.h"
#include "published_log.h"
#include "run_command.h"
#include "scoped_temp_dir.h"
#include "team_packet.h"
#include "udp_impairment.h"

namespace {

std::string writeKey(const ScopedTempDir& dir, const std::string& name, const team::TeamKey& key) {
  const std::string path = (dir.path() / name).string();
  std::ofstream(path) << key.hex() << "\n";
  return path;
}

// A robot of team 5 on 127.0.0.<address>, talking to the given peers on port: the demo robot's file
// with these values set (as a host's --set gives them).
std::vector<std::string> robotOverrides(const std::string& name, int robot_id, int address,
                                        const std::vector<int>& peers, int port, const std::string& key_file,
                                        const std::string& plugins, const std::vector<std::string>& more = {}) {
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
  return overrides;
}
const std::string kRobotFile = std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml";
const std::string kDefaults = std::string(PROJECT_CONFIG_DIR) + "/defaults";

fw::Config robotConfig(const std::string& name, int robot_id, int address, const std::vector<int>& peers, int port,
                       const std::string& key_file, const std::string& plugins,
                       const std::vector<std::string>& more = {}) {
  return fw::Config::load(kDefaults, kRobotFile,
                          robotOverrides(name, robot_id, address, peers, port, key_file, plugins, more));
}

// A scene's true ball, as the simulator moves it among the scene's objects.
kinect3d::sim::BallMotion trueBallOf(const kinect3d::sim::Scene& scene) {
  return {*scene.ball, scene.physics, scene.duration_s, scene.objects};
}

// The demo's lob, its time 0 at world_start_wall_s in a shared world (host.sim_world_start_wall_s),
// and how far a point lies from its true flight within 0.1 s of t (a receiver's clock): the recorded
// runs' robots, simulated before they shared a world, started theirs when their hosts' threads first
// read them, tens of milliseconds apart.
struct Lob {
  explicit Lob(double world_start_wall_s = 0.0)
      : scene(kinect3d::sim::inSharedWorld(kinect3d::sim::loadScene("lob_over_robot"), world_start_wall_s)),
        truth(trueBallOf(scene)) {}

  kinect3d::sim::Scene scene;
  kinect3d::sim::BallMotion truth;

  double offTheFlight_m(const Eigen::Vector3d& p, double t) const {
    double off_m = 1e9;
    for (double dt = -0.1; dt <= 0.1; dt += 0.005) {
      off_m = std::min(off_m, (p - truth.positionAt(t - scene.start_time_s + dt)).norm());
    }
    return off_m;
  }
};

// Robots simulated side by side in one world whose time 0 is lead_s from now (once their hosts have
// started: hosts in this process take less than one in a process of its own): the --set that gives
// it, and that time.
struct SharedWorld {
  explicit SharedWorld(double lead_s = 2.0) : start_wall_s(fw::wallClockNow_s() + lead_s) {}
  double start_wall_s;
  std::string setting() const { return "host.sim_world_start_wall_s=" + std::to_string(start_wall_s); }
};

// A robot without a Kinect has its omni camera's latency measured and configured: it has no Kinect
// of its own to learn it against, and in the demo's lob its teammate's Kinect and its camera never
// see the ball move at once (the keeper loses the lob before the defender's camera finds its hops).
// Unknown, the 30 ms by which its hops lag the keeper's flight slowed the hops in its fusion
// (0.31-0.40 m p90 off the flight where 0.1 m is usual). Here: what its simulated camera's stamps are late by.
std::string measuredOmniLatency() {
  const double late_s =
      fw::Config::load(kDefaults, kRobotFile, {}).root().child("omni").child("sim").getDouble("stamp_late_s", 0.0, 1.0);
  return "fusion.omni.latency_s=" + std::to_string(late_s);
}

// KINECT3D_KEEP_TEAM_LOGS=<dir>: a live run's logs copied there, to replay (kinect3d replay) or keep.
// Declared right after the run's folder, it copies when the test ends, however it ends: after the
// hosts declared below it have closed their logs, and also when an assertion failed, the run most
// worth replaying.
class KeepLogsIfAsked {
 public:
  explicit KeepLogsIfAsked(const ScopedTempDir& dir) : dir_(dir) {}
  KeepLogsIfAsked(const KeepLogsIfAsked&) = delete;
  KeepLogsIfAsked& operator=(const KeepLogsIfAsked&) = delete;
  ~KeepLogsIfAsked() {
    const char* keep = std::getenv("KINECT3D_KEEP_TEAM_LOGS");
    if (keep == nullptr) return;
    std::error_code error;
    std::filesystem::copy(dir_.path(), keep, std::filesystem::copy_options::recursive, error);
    std::printf("KINECT3D_KEEP_TEAM_LOGS: %s %s %s\n", error ? "could not copy" : "copied", dir_.path().c_str(),
                error ? error.message().c_str() : (std::string("to ") + keep).c_str());
  }

 private:
  const ScopedTempDir& dir_;
};

// Plays the scene on every host (the receiver first), until those with sources have played it; stops
// the others, then the receiver once it has taken in everything that reached it: its world state still
// for a few of its fusion's steps (else its log could hold a message its fusion never read, which its
// replay would then read).
void playTogether(fw::Host& receiver, const std::vector<fw::Host*>& others) {
  receiver.start();
  for (fw::Host* host : others) host->start();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(90);
  const auto played = [&] {
    return receiver.sourcesFinished() && std::all_of(others.begin(), others.end(), [](fw::Host* host) {
             return host->sourcesFinished() || host->summaries().size() == 1;  // a host of the team plugin alone
           });
  };
  while (!played() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    receiver.watch();
    for (fw::Host* host : others) host->watch();
  }
  for (fw::Host* host : others) host->stop();
  std::uint64_t version = receiver.world().version();
  for (int still = 0; still < 3 && std::chrono::steady_clock::now() < deadline;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const std::uint64_t now = receiver.world().version();
    still = now == version ? still + 1 : 0;
    version = now;
  }
  receiver.stop();
}

// What a receiving robot's match log says of the keeper's messages and of its own world ball.
struct Received {
  int messages = 0, kinect_balls = 0, kinect_balls_off = 0;
  // Its world ball in the air with the keeper among its sources: how far off the true flight.
  std::vector<double> air_offs_m;
  std::vector<fw::Event> events;
};
Received receivedIn(const std::string& run, const Lob& lob) {
  Received r;
  for (const fw::JournalEntry& entry : fw::MatchLogReader(run).entries()) {
    if (const auto* message = std::get_if<fw::TeamMessage>(&entry.item)) {
      ++r.messages;
      EXPECT_EQ(message->robot_name, "keeper") << "only the keeper's messages are taken";
      for (const fw::BallObservation& ball : message->kinect_balls) {
        ++r.kinect_balls;
        EXPECT_EQ(ball.frame, fw::Frame::kField);
        if (lob.offTheFlight_m(ball.position_m, ball.stamp.source_time_s) > 0.15) ++r.kinect_balls_off;
      }
    } else if (const auto* ball = std::get_if<fw::FusedBall>(&entry.item)) {
      const bool from_keeper = std::count(ball->sources.begin(), ball->sources.end(), "team:keeper") > 0;
      if (ball->state != fw::BallState::kAir || !from_keeper) continue;
      r.air_offs_m.push_back(lob.offTheFlight_m(ball->position_F, ball->stamp.source_time_s));
    } else if (const auto* event = std::get_if<fw::Event>(&entry.item)) {
      r.events.push_back(*event);
    }
  }
  return r;
}

bool said(const Received& received, const std::string& kind, const std::vector<std::string>& words) {
  return std::any_of(received.events.begin(), received.events.end(), [&](const fw::Event& event) {
    return event.kind == kind && std::all_of(words.begin(), words.end(), [&](const std::string& word) {
             return event.message.find(word) != std::string::npos;
           });
  });
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
  // localisation play the same scene, in the same world); a stranger with another key sends too.
  const SharedWorld world;
  fw::Host keeper(robotConfig("keeper", 1, 21, {22}, kPort, team_key, "[localisation, kinect3d, omni, fusion, team]",
                              {world.setting()}),
                  PRODUCT_PLUGIN_DIR);
  const std::string logs = (dir.path() / "logs").string();
  fw::Host defender(robotConfig("defender", 2, 22, {21}, kPort, team_key, "[localisation, omni, fusion, team, logger]",
                                {"logger.folder=" + logs, world.setting(), measuredOmniLatency()}),
                    PRODUCT_PLUGIN_DIR);
  fw::Host stranger(robotConfig("stranger", 3, 23, {22}, kPort, other_key, "[team]"), PRODUCT_PLUGIN_DIR);
  playTogether(defender, {&keeper, &stranger});
  ASSERT_TRUE(keeper.sourcesFinished() && defender.sourcesFinished());

  // What the defender received and made of it, from its match log. Its fusion works on its omni
  // camera's clock (it has no Kinect), the world's: the keeper's times arrive moved onto it.
  const Lob lob(world.start_wall_s);
  const std::string run = onlySubfolder(logs);
  const Received received = receivedIn(run, lob);
  EXPECT_GE(received.messages, 40) << "20 messages a second for the scene's 3.5 s";
  EXPECT_GE(received.kinect_balls, 20) << "the lob the keeper's Kinect saw";
  EXPECT_LE(received.kinect_balls_off, received.kinect_balls / 10) << "placed with the keeper's pose at their time";
  // The defender holds the lob in the air from the keeper's Kinect: the target is a median of 0.15 m.
  ASSERT_GE(received.air_offs_m.size(), 20u);
  EXPECT_LE(fw::quantile(received.air_offs_m, 0.5), 0.15);
  EXPECT_LE(fw::quantile(received.air_offs_m, 0.9), 0.3);
  EXPECT_TRUE(said(received, "team_refused", {"127.0.0.23", "not signed with the team key"}));
  // One machine, one clock: the offset the exchange finds is within a few milliseconds of none.
  EXPECT_TRUE(said(received, "teammate_clock", {"keeper", "s from ours (+-0.00"}));
  EXPECT_GT(defender.world().droppedFrames("team"), 0u) << "the stranger's packets, counted";
  EXPECT_FALSE(said(received, "teammate_discounted", {}));
  // And the other way: the keeper heard the defender, which shares its world ball though it has no
  // Kinect (on its omni camera's clock).
  const std::map<int, fw::TeamMessage> heard = keeper.world().teamMessages();
  ASSERT_EQ(heard.count(2), 1u);
  EXPECT_EQ(heard.at(2).robot_name, "defender");
  EXPECT_TRUE(heard.at(2).world_ball.has_value());
  EXPECT_TRUE(heard.at(2).pose.has_value());

  // The defender's log replays to the same world balls: the teammates' messages are inputs of the
  // log, and the replay's team plugin hands them out in the order they came (and sends nothing).
  const Published live = publishedIn(run);
  ASSERT_GT(live.world_balls.size(), 100u);
  const Published replayed = publishedIn(replayInto(run, dir.path() / "replayed"));
  expectSame(live.world_balls, replayed.world_balls, "world ball");
  expectSame(live.events, replayed.events, "event");
}

TEST(TeamPlugin, ThroughALossyDelayingDuplicatingNetworkTheDefenderStillHoldsTheLob) {
  const ScopedTempDir dir;
  const KeepLogsIfAsked keep_logs(dir);
  const std::string team_key = writeKey(dir, "team.key", team::TeamKey::random());
  constexpr int kPort = 50432;
  // Each robot sends to its teammate through a link that loses a fifth of the packets, delays each by
  // up to 200 ms (so they overtake each other) and sends one in twenty twice.
  const UdpImpairment network({{"127.0.0.41", "127.0.0.31"}, {"127.0.0.42", "127.0.0.32"}}, kPort, {0.2, 0.2, 0.05});
  const SharedWorld world;
  fw::Host keeper(robotConfig("keeper", 1, 31, {42}, kPort, team_key, "[localisation, kinect3d, omni, fusion, team]",
                              {world.setting()}),
                  PRODUCT_PLUGIN_DIR);
  const std::string logs = (dir.path() / "logs").string();
  fw::Host defender(robotConfig("defender", 2, 32, {41}, kPort, team_key, "[localisation, omni, fusion, team, logger]",
                                {"logger.folder=" + logs, world.setting(), measuredOmniLatency()}),
                    PRODUCT_PLUGIN_DIR);
  const auto started = std::chrono::steady_clock::now();
  playTogether(defender, {&keeper});
  const double played_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  ASSERT_TRUE(keeper.sourcesFinished() && defender.sourcesFinished());

  const Received received = receivedIn(onlySubfolder(logs), Lob(world.start_wall_s));
  const UdpImpairment::Carried from_keeper = network.carried("127.0.0.42");
  EXPECT_GE(received.messages, 30) << "of " << from_keeper.packets_in << " the keeper sent";
  EXPECT_LT(received.messages, static_cast<int>(from_keeper.packets_out)) << "duplicates are refused";
  EXPECT_GT(defender.world().droppedFrames("team"), 0u) << "the duplicates, counted";
  EXPECT_TRUE(said(received, "team_refused", {"replayed"}));
  ASSERT_GE(received.air_offs_m.size(), 15u);
  EXPECT_LE(fw::quantile(received.air_offs_m, 0.5), 0.15) << "the issue's target, with 20 % loss";
  EXPECT_LE(fw::quantile(received.air_offs_m, 0.9), 0.5);
  std::printf("in the air from the keeper's messages: %.3f m median, %.3f m p90 off the true flight\n",
              fw::quantile(received.air_offs_m, 0.5), fw::quantile(received.air_offs_m, 0.9));
  std::printf("the keeper sent %.0f bytes/s in %.1f packets/s (%.0f bytes each)\n", from_keeper.bytes_in / played_s,
              from_keeper.packets_in / played_s,
              static_cast<double>(from_keeper.bytes_in) / static_cast<double>(from_keeper.packets_in));
}

TEST(TeamPlugin, AMislocalisedKeeperIsDiscountedByTheDefenderAndNotUsedThroughALossyNetwork) {
  constexpr double kNever = std::numeric_limits<double>::infinity();
  constexpr int kPort = 50433;
  // The keeper's localisation believes it stands a metre to the right of where it does, or turned by
  // twenty degrees; every packet goes through a link that loses a fifth and delays each by up to 200 ms.
  for (const std::string bias : {"localisation.sim.bias_x_m=1.0", "localisation.sim.bias_theta_deg=20"}) {
    const ScopedTempDir dir;
    const std::string team_key = writeKey(dir, "team.key", team::TeamKey::random());
    const UdpImpairment network({{"127.0.0.53", "127.0.0.51"}, {"127.0.0.54", "127.0.0.52"}}, kPort, {0.2, 0.2, 0.0});
    const SharedWorld world;
    fw::Host keeper(robotConfig("keeper", 1, 51, {54}, kPort, team_key, "[localisation, kinect3d, omni, fusion, team]",
                                {bias, world.setting()}),
                    PRODUCT_PLUGIN_DIR);
    const std::string logs = (dir.path() / "logs").string();
    fw::Host defender(
        robotConfig("defender", 2, 52, {53}, kPort, team_key, "[localisation, omni, fusion, team, logger]",
                    {"logger.folder=" + logs, world.setting(), measuredOmniLatency()}),
        PRODUCT_PLUGIN_DIR);
    playTogether(defender, {&keeper});
    ASSERT_TRUE(keeper.sourcesFinished() && defender.sourcesFinished());

    const std::string run = onlySubfolder(logs);
    ASSERT_TRUE(
        said(receivedIn(run, Lob(world.start_wall_s)), "teammate_discounted", {"keeper", "its localisation is off"}))
        << bias;
    // From a second after it is discounted (a source is listed for a second after its last support), no
    // world ball of the defender rests on the keeper's observations.
    double discounted_at_s = kNever;  // the defender's fusion clock
    int after = 0, with_keeper_after = 0;
    for (const fw::JournalEntry& entry : fw::MatchLogReader(run).entries()) {
      if (const auto* event = std::get_if<fw::Event>(&entry.item)) {
        if (event->kind == "teammate_discounted") discounted_at_s = event->stamp.source_time_s;
        if (event->kind == "teammate_trusted") discounted_at_s = kNever;
      } else if (const auto* ball = std::get_if<fw::FusedBall>(&entry.item);
                 ball && ball->stamp.source_time_s > discounted_at_s + 1.0) {
        ++after;
        with_keeper_after += std::count(ball->sources.begin(), ball->sources.end(), "team:keeper") > 0 ? 1 : 0;
      }
    }
    EXPECT_GT(after, 20) << bias;
    EXPECT_EQ(with_keeper_after, 0) << bias;
  }
}

// The world's time 0 of a team run, on the robots' clock: as the run's configuration recorded it.
double worldStartOf(const std::string& log_folder) {
  return fw::Config::parseDocument(fw::MatchLogReader(log_folder).run().config_yaml, log_folder)
      .root()
      .child("host")
      .getDouble("sim_world_start_wall_s", 1.0, 1e10);
}

// A team world's ball in one robot's match log, while the true ball was at least min_height_m up (the
// log's times on the world's clock from world_start_s): the error of each world ball that `counts`,
// and how many world balls there were then.
struct InTheAir {
  std::vector<double> errors_m;
  int world_balls = 0;
};
InTheAir ballInTheAir(const std::string& log_folder, const kinect3d::sim::BallMotion& truth, double world_start_s,
                      double min_height_m, const std::function<bool(const fw::FusedBall&)>& counts) {
  InTheAir in_the_air;
  for (const fw::JournalEntry& entry : fw::MatchLogReader(log_folder).entries()) {
    const auto* ball = std::get_if<fw::FusedBall>(&entry.item);
    if (ball == nullptr) continue;
    const Eigen::Vector3d true_F = truth.positionAt(ball->stamp.source_time_s - world_start_s);
    if (true_F.z() < min_height_m) continue;
    ++in_the_air.world_balls;
    if (counts(*ball)) in_the_air.errors_m.push_back((ball->position_F - true_F).norm());
  }
  return in_the_air;
}

// The team world's lob, 0.5 m up, in one robot's match log: its world balls in the air, the keeper's
// own or, for a teammate, those that used the keeper's messages.
InTheAir lobInTheAir(const std::string& log_folder, const kinect3d::sim::BallMotion& truth, double world_start_s,
                     bool keeper_itself) {
  return ballInTheAir(log_folder, truth, world_start_s, 0.5, [&](const fw::FusedBall& ball) {
    return ball.state == fw::BallState::kAir &&
           (keeper_itself || std::count(ball.sources.begin(), ball.sources.end(), "team:keeper") > 0);
  });
}

TEST(TeamPlugin, ThreeRobotsInOneWorldHoldTheLobOnlyTheKeepersKinectSees) {
  // Three robots simulate one world (tests/data/scenes/team/: the demo's lob kicked over the defender;
  // the keeper 6 m behind it facing the kick, with a Kinect; the striker 3 m to its right), its time
  // 0 three seconds from now on every robot. Each robot is its own vision_host process, as on the
  // field. Neither the defender nor the striker has a Kinect. Each robot sends to the other two
  // through a link that loses a fifth of the packets and delays each by up to 200 ms.
  const ScopedTempDir dir;
  const KeepLogsIfAsked keep_logs(dir);  // for tests/data/team_run/ (its README says how they were made)
  const std::string team_key = writeKey(dir, "team.key", team::TeamKey::random());
  constexpr int kPort = 50434;
  const UdpImpairment network(
      {{"127.0.0.71", "127.0.0.61"}, {"127.0.0.72", "127.0.0.62"}, {"127.0.0.73", "127.0.0.63"}}, kPort,
      {0.2, 0.2, 0.0});
  const std::string world = std::string(TEST_DATA_DIR) + "/scenes/team/";
  const SharedWorld shared(3.0);
  const auto robot = [&](const std::string& name, int id, const std::vector<int>& peers, const std::string& plugins) {
    const std::string scene = "sim:" + world + name + ".yaml";
    std::vector<std::string> args{"--robot",      kRobotFile,         "--defaults", kDefaults,
                                  "--plugin-dir", PRODUCT_PLUGIN_DIR, "--set"};
    for (const std::string& value :
         robotOverrides(name, id, 60 + id, peers, kPort, team_key, plugins,
                        {"kinect3d.source=" + scene, "omni.source=" + scene, "localisation.source=" + scene,
                         shared.setting(), "logger.folder=" + (dir.path() / name).string()})) {
      args.push_back(value);
    }
    return std::make_unique<HostProcess>(args);
  };
  const std::vector<std::string> names{"keeper", "defender", "striker"};
  std::vector<std::unique_ptr<HostProcess>> hosts;
  hosts.push_back(robot("keeper", 1, {72, 73}, "[localisation, kinect3d, omni, fusion, team, logger]"));
  hosts.push_back(robot("defender", 2, {71, 73}, "[localisation, omni, fusion, team, logger]"));
  hosts.push_back(robot("striker", 3, {71, 72}, "[localisation, omni, fusion, team, logger]"));
  // Each host stops by itself once its simulated sensors have played the scene.
  for (std::size_t i = 0; i < hosts.size(); ++i) {
    ASSERT_EQ(hosts[i]->waitExit(std::chrono::seconds(90)), 0) << names[i] << ":\n" << hosts[i]->readAll();
    const std::string output = hosts[i]->readAll();
    EXPECT_NE(output.find("Summary (every source ended)"), std::string::npos) << names[i] << ":\n" << output;
    EXPECT_NE(output.find("\n  team "), std::string::npos) << names[i] << ":\n" << output;
  }

  // The world's truth, the same in every robot's scene (TeamWorlds.EveryRobotOfAWorldSeesTheSameBall),
  // on the shared clock.
  const kinect3d::sim::Scene scene = kinect3d::sim::loadScene(world + "defender.yaml");
  const kinect3d::sim::BallMotion truth = trueBallOf(scene);
  for (const char* name : {"keeper", "defender", "striker"}) {
    const bool keeper_itself = std::string(name) == "keeper";
    const InTheAir lob = lobInTheAir(onlySubfolder(dir.path() / name), truth, shared.start_wall_s, keeper_itself);
    ASSERT_GE(lob.errors_m.size(), 15u) << name << ": " << lob.world_balls << " world balls while the lob was 0.5 m up";
    // The target is 0.15 m. Here the keeper's own Kinect sees the flight 4-11 m away, and each
    // run draws its own losses and delays (docs/team.md gives the spread over runs): a guard against
    // losing the lob, not the target, which TheDefendersRecordedRunHoldsTheLobFromTheKeepersMessages
    // holds one recorded run to.
    EXPECT_LE(fw::quantile(lob.errors_m, 0.5), 0.35) << name;
    std::printf("%s: the lob in the air %s, %.3f m median, %.3f m p90 (%zu of %d world balls while it was 0.5 m up)\n",
                name, keeper_itself ? "from its own Kinect" : "from the keeper's messages",
                fw::quantile(lob.errors_m, 0.5), fw::quantile(lob.errors_m, 0.9), lob.errors_m.size(), lob.world_balls);
  }
}

TEST(TeamPlugin, TwoRobotsOmniCamerasAlonePlaceAHopInTheAirThroughALossyNetwork) {
  // Two hosts simulate one world (tests/data/scenes/team_hop/): a ball hops up to 0.57 m between the
  // defender and the striker, below both omni cameras' view tops; neither robot has a Kinect. Each
  // sends to the other through a link that loses a fifth of the packets and delays each by up to
  // 200 ms. One camera gives a bearing to a ball in the air; two rays meet at it. The anchor:
  // two robots' omni cameras placed a static ball in the air within 0.13 m (Tech United, Aveiro).
  const ScopedTempDir dir;
  const KeepLogsIfAsked keep_logs(dir);
  const std::string team_key = writeKey(dir, "team.key", team::TeamKey::random());
  constexpr int kPort = 50435;
  const UdpImpairment network({{"127.0.0.92", "127.0.0.82"}, {"127.0.0.93", "127.0.0.83"}}, kPort, {0.2, 0.2, 0.0});
  const std::string world = std::string(TEST_DATA_DIR) + "/scenes/team_hop/";
  const SharedWorld shared(3.0);
  const auto robot = [&](const std::string& name, int id, int peer) {
    const std::string scene = "sim:" + world + name + ".yaml";
    return std::make_unique<fw::Host>(
        robotConfig(name, id, 80 + id, {peer}, kPort, team_key, "[localisation, omni, fusion, team, logger]",
                    {"omni.source=" + scene, "localisation.source=" + scene, shared.setting(),
                     "logger.folder=" + (dir.path() / name).string()}),
        PRODUCT_PLUGIN_DIR);
  };
  const auto defender = robot("defender", 2, 93);
  const auto striker = robot("striker", 3, 92);
  playTogether(*defender, {striker.get()});
  ASSERT_TRUE(defender->sourcesFinished() && striker->sourcesFinished());

  // Every world ball of the defender while the true ball was 10 cm above its resting height, with
  // the striker's rays and, replayed from the same log, without them.
  const kinect3d::sim::Scene scene = kinect3d::sim::loadScene(world + "defender.yaml");
  const kinect3d::sim::BallMotion truth = trueBallOf(scene);
  const double hop_m = scene.physics.radius_m + 0.1;
  const std::string run = onlySubfolder(dir.path() / "defender");
  const auto any = [](const fw::FusedBall&) { return true; };
  const InTheAir two = ballInTheAir(run, truth, shared.start_wall_s, hop_m, any);
  const InTheAir with_striker = ballInTheAir(run, truth, shared.start_wall_s, hop_m, [](const fw::FusedBall& ball) {
    return std::count(ball.sources.begin(), ball.sources.end(), "team:striker") > 0;
  });
  const InTheAir alone = ballInTheAir(replayInto(run, dir.path() / "alone", "--set fusion.team.use=false"), truth,
                                      shared.start_wall_s, hop_m, any);
  ASSERT_GE(two.errors_m.size(), 15u) << two.world_balls << " world balls while it hopped";
  EXPECT_GE(with_striker.errors_m.size(), two.errors_m.size() * 3 / 4) << "the striker's rays place it";
  // The anchor is 0.13 m: 0.048-0.083 m in most runs, with each robot's pose blended with its
  // wheels' odometry (its own camera alone leaves it 0.38-0.46 m off), but about one run in five
  // places the first hop 0.15-0.7 m wide (the first rays after the kick set the flight's velocity
  // while it is still uncertain: TheRecordedHopWhoseFirstHopWentWideIsPlacedByTheStrikersRays), and
  // each run draws its own losses and delays. A guard against losing the hop, not the anchor, which
  // the team report measures over runs (docs/team-report.md).
  EXPECT_LE(fw::quantile(two.errors_m, 0.5), 0.25);
  std::printf(
      "the defender's hop in the air: %.3f m median, %.3f m p90 with the striker's rays (%zu world balls); "
      "%.3f m, %.3f m alone\n",
      fw::quantile(two.errors_m, 0.5), fw::quantile(two.errors_m, 0.9), two.errors_m.size(),
      fw::quantile(alone.errors_m, 0.5), fw::quantile(alone.errors_m, 0.9));
}

TEST(TeamPlugin, TheDefendersRecordedRunHoldsTheLobFromTheKeepersMessages) {
  // tests/data/team_run/defender/: the defender's match log from one run of
  // ThreeRobotsInOneWorldHoldTheLobOnlyTheKeepersKinectSees (a fifth of the packets lost, up to 200 ms
  // late), replayed through its own plugins: the teammates' messages arrive as they did then, so the
  // fusion meets the same network every time, where a live run draws a new one.
  const ScopedTempDir dir;
  const std::string replayed = replayInto(std::string(TEST_DATA_DIR) + "/team_run/defender", dir.path());
  const double world_start_s = worldStartOf(replayed);
  const kinect3d::sim::Scene scene =
      kinect3d::sim::loadScene(std::string(TEST_DATA_DIR) + "/scenes/team/defender.yaml");
  const kinect3d::sim::BallMotion truth = trueBallOf(scene);
  const InTheAir lob = lobInTheAir(replayed, truth, world_start_s, false);
  ASSERT_GE(lob.errors_m.size(), 30u) << lob.world_balls << " world balls while the lob was 0.5 m up";
  // A lob only a teammate's Kinect sees, held within the 0.15 m (median). Until a Kinect ball
  // that finds a lost ball stopped setting the velocity with confidence, this run gave 0.152 m, and
  // 0.39 m at the 90th percentile.
  EXPECT_LE(fw::quantile(lob.errors_m, 0.5), 0.15);
  EXPECT_LE(fw::quantile(lob.errors_m, 0.9), 0.35);
  std::printf("the recorded defender: the lob in the air %.3f m median, %.3f m p90 (%zu world balls)\n",
              fw::quantile(lob.errors_m, 0.5), fw::quantile(lob.errors_m, 0.9), lob.errors_m.size());
}

TEST(TeamPlugin, TheRecordedLossyRunWhoseWorldFlightWentWrongHoldsTheLobFromTheKeepersMessages) {
  // tests/data/team_run/lossy_defender/: the defender's match log from the run of
  // ThroughALossyDelayingDuplicatingNetworkTheDefenderStillHoldsTheLob that lost the lob (about one
  // run in twenty did): the estimate of the keeper's clock moved by 76 ms during the kick, the keeper's
  // balls from either side of the move sent the world's flight up at 16 m/s, and the world's ball
  // stayed on it while the keeper's Kinect located the lob on another track: 3.6 m off (median).
  const ScopedTempDir dir;
  const Received received =
      receivedIn(replayInto(std::string(TEST_DATA_DIR) + "/team_run/lossy_defender", dir.path()), Lob{});
  ASSERT_GE(received.air_offs_m.size(), 15u);
  EXPECT_LE(fw::quantile(received.air_offs_m, 0.5), 0.15);
  EXPECT_LE(fw::quantile(received.air_offs_m, 0.9), 0.5);
  std::printf("the recorded lossy run: the lob in the air %.3f m median, %.3f m p90 (%zu world balls)\n",
              fw::quantile(received.air_offs_m, 0.5), fw::quantile(received.air_offs_m, 0.9),
              received.air_offs_m.size());
}

TEST(TeamPlugin, TheRecordedHopWhoseFirstHopWentWideIsPlacedByTheStrikersRays) {
  // tests/data/team_run/hop_defender/: the defender's match log from one run of
  // TwoRobotsOmniCamerasAlonePlaceAHopInTheAirThroughALossyNetwork that missed the 0.13 m anchor,
  // replayed through its own plugins with the striker's rays as they arrived. The first hop after
  // the kick lies 0.15-0.7 m wide; from the first bounce on, the two robots' rays place the ball
  // within a few centimetres. Its own camera alone leaves it far wider.
  const ScopedTempDir dir;
  const std::string recorded = std::string(TEST_DATA_DIR) + "/team_run/hop_defender";
  const std::string replayed = replayInto(recorded, dir.path() / "with");
  const std::string alone = replayInto(recorded, dir.path() / "alone", "--set fusion.team.use=false");
  const double world_start_s = worldStartOf(replayed);
  const kinect3d::sim::Scene scene =
      kinect3d::sim::loadScene(std::string(TEST_DATA_DIR) + "/scenes/team_hop/defender.yaml");
  const kinect3d::sim::BallMotion truth = trueBallOf(scene);
  const double hop_m = scene.physics.radius_m + 0.1;
  const auto any = [](const fw::FusedBall&) { return true; };
  const InTheAir two = ballInTheAir(replayed, truth, world_start_s, hop_m, any);
  const InTheAir after_first_bounce = ballInTheAir(replayed, truth, world_start_s, hop_m, [&](const fw::FusedBall& b) {
    return b.stamp.source_time_s - world_start_s > 1.1;  // the first hop lands at 1.1 s
  });
  const InTheAir one = ballInTheAir(alone, truth, world_start_s, hop_m, any);
  ASSERT_GE(two.errors_m.size(), 25u);
  ASSERT_GE(after_first_bounce.errors_m.size(), 8u);
  EXPECT_LE(fw::quantile(two.errors_m, 0.5), 0.16) << "0.15 m when it was recorded";
  EXPECT_LE(fw::quantile(after_first_bounce.errors_m, 0.5), 0.10) << "the later hops, placed by two robots' rays";
  EXPECT_GE(fw::quantile(one.errors_m, 0.5), 2.0 * fw::quantile(two.errors_m, 0.5)) << "its own camera alone";
  std::printf("the recorded hop: %.3f m median (%.3f m after the first bounce); %.3f m alone\n",
              fw::quantile(two.errors_m, 0.5), fw::quantile(after_first_bounce.errors_m, 0.5),
              fw::quantile(one.errors_m, 0.5));
}

TEST(TeamPlugin, TheRecordedRunWhoseMislocalisedKeeperSawTheBallFirstHasItFoundOut) {
  // tests/data/team_run/keeper_off_defender/: the defender's match log from a run of the team report's
  // team_rest world, the keeper's localisation a metre off, that a busy machine slowed: the keeper's
  // first ball reached the defender a millisecond before its omni camera's first. The ball's track
  // started from the teammates' balls; judged against it, the keeper agreed with itself, was used,
  // and held the defender's world ball a metre off (1.1 m in the median) until the end. Teammates are
  // now judged against what this robot's own sensors see alone.
  const ScopedTempDir dir;
  const std::string replayed = replayInto(std::string(TEST_DATA_DIR) + "/team_run/keeper_off_defender", dir.path());
  const double world_start_s = worldStartOf(replayed);
  const kinect3d::sim::BallMotion truth =
      trueBallOf(kinect3d::sim::loadScene(std::string(TEST_DATA_DIR) + "/scenes/team_rest/defender.yaml"));
  std::vector<double> errors_m;
  int with_keeper = 0;
  bool discounted = false;
  for (const fw::JournalEntry& entry : fw::MatchLogReader(replayed).entries()) {
    if (const auto* event = std::get_if<fw::Event>(&entry.item)) {
      discounted |= event->kind == "teammate_discounted" && event->message.find("keeper") != std::string::npos;
    }
    const auto* ball = std::get_if<fw::FusedBall>(&entry.item);
    if (ball == nullptr) continue;
    const double t_s = ball->stamp.source_time_s - world_start_s;
    if (t_s < 1.1 || t_s > 1.9) continue;  // a second after the keeper's first ball, and before the kick
    errors_m.push_back((ball->position_F - truth.positionAt(t_s)).norm());
    with_keeper += std::count(ball->sources.begin(), ball->sources.end(), "team:keeper") > 0 ? 1 : 0;
  }
  EXPECT_TRUE(discounted);
  ASSERT_GE(errors_m.size(), 20u);
  EXPECT_LE(fw::quantile(errors_m, 0.9), 0.2);
  EXPECT_EQ(with_keeper, 0);
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

TEST(TeamWorlds, EveryRobotOfAWorldSeesTheSameBall) {
  // The team tests and `kinect3d report team` play a world (a folder of tests/data/scenes) as one
  // scene file per robot, each with the others as obstacles: the ball must fly the same in all of
  // them, or the robots would not share one truth.
  int worlds = 0;
  for (const auto& world : std::filesystem::directory_iterator(std::string(TEST_DATA_DIR) + "/scenes")) {
    if (!world.is_directory()) continue;
    ++worlds;
    const kinect3d::sim::Scene first = kinect3d::sim::loadScene((world.path() / "defender.yaml").string());
    const kinect3d::sim::BallMotion truth = trueBallOf(first);
    int robots = 0;
    for (const auto& robot : std::filesystem::directory_iterator(world.path())) {
      ++robots;
      const std::string name = robot.path().string();
      const kinect3d::sim::Scene scene = kinect3d::sim::loadScene(name);
      EXPECT_EQ(scene.duration_s, first.duration_s) << name;
      EXPECT_EQ(scene.objects.size(), first.objects.size()) << name << ": the others as obstacles";
      const kinect3d::sim::BallMotion same = trueBallOf(scene);
      for (double t = 0.0; t < first.duration_s; t += 0.05) {
        ASSERT_LT((same.positionAt(t) - truth.positionAt(t)).norm(), 0.01) << name << " at " << t;
      }
    }
    EXPECT_GE(robots, 2) << world.path();
  }
  EXPECT_EQ(worlds, 5) << "team, team_rest, team5, team_hop and team_hop3";
}

TEST(TeamWorlds, TheTeamReportNamesAWorldFileItCannotFind) {
  const ScopedTempDir dir;
  const auto [status, output] =
      runCommand(std::string(KINECT3D_EXE) + " report team --out " + (dir.path() / "report.md").string() +
                 " --worlds " + dir.path().string() + " 2>&1");
  EXPECT_NE(status, 0);
  EXPECT_NE(output.find((dir.path() / "team" / "keeper.yaml").string() + " missing"), std::string::npos) << output;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "report.md"));
}

TEST(TeamWorlds, TheTeamReportPlaysOnlyTheWorldsNamedAndRefusesOneItDoesNotHave) {
  const ScopedTempDir dir;
  const std::string command = std::string(KINECT3D_EXE) + " report team --out " + (dir.path() / "report.md").string() +
                              " --worlds " + dir.path().string();
  // Only the hop's files are looked for: the first missing is its own.
  const auto [status, output] = runCommand(command + " --scenes team_hop 2>&1");
  EXPECT_NE(status, 0);
  EXPECT_NE(output.find((dir.path() / "team_hop" / "defender.yaml").string() + " missing"), std::string::npos)
      << output;
  const auto [unknown_status, unknown_output] = runCommand(command + " --scenes team,team7 2>&1");
  EXPECT_NE(unknown_status, 0);
  EXPECT_NE(unknown_output.find("'team7' is not a world of the team report (team,team_rest,team5,team_hop,team_hop3)"),
            std::string::npos)
      << unknown_output;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "report.md"));
}

// How far a ball at ball_F lies beside a ray, in degrees: positive counter-clockwise of it.
double degreesBeside(const fw::BallRay& ray, const Eigen::Vector2d& ball_F) {
  const Eigen::Vector2d along = ray.direction_F.head<2>(), to_ball = ball_F - ray.origin_F.head<2>();
  return std::atan2(along.x() * to_ball.y() - along.y() * to_ball.x(), along.dot(to_ball)) * 180.0 / M_PI;
}

TEST(TeamPlugin, AnOmniRayIsPlacedWithThePoseWhenItsImageWasTakenNotWhenItWasStamped) {
  // The robot turns on the spot at 90 degrees a second, a ball lying 3 m away (turn_at_rest). Its
  // omni camera's stamps are 0.1 s later than its images, as its file says (fusion.omni.latency_s).
  // A ray placed with the pose at its stamp would pass 9 degrees beside the ball; placed with the
  // pose when the image was taken, it passes through it, within the camera's and the localisation's
  // noise (1.5 and 1 degree). Without the wheels' odometry: until the blend has learnt their scale
  // (half a turn), a 2 % scale error bends a steady turn's heading by about 1.5 degrees, which is not
  // what this test is about.
  const ScopedTempDir dir;
  const std::string team_key = writeKey(dir, "team.key", team::TeamKey::random());
  constexpr int kPort = 50436;
  const std::vector<std::string> turning{"localisation.source=sim:turn_at_rest",
                                         "omni.source=sim:turn_at_rest",
                                         "omni.sim.stamp_late_s=0.1",
                                         "omni.sim.false_rate_hz=0",
                                         "fusion.omni.latency_s=0.1",
                                         "localisation.sim.odometry=false"};
  fw::Host turner(robotConfig("turner", 1, 101, {102}, kPort, team_key, "[localisation, omni, team]", turning),
                  PRODUCT_PLUGIN_DIR);
  // The listener records what it hears; it needs sensors of its own to put its teammate's times on
  // their clock.
  const std::string logs = (dir.path() / "logs").string();
  fw::Host listener(
      robotConfig("listener", 2, 102, {101}, kPort, team_key, "[localisation, omni, team, logger]",
                  {"localisation.source=sim:turn_at_rest", "omni.source=sim:turn_at_rest", "logger.folder=" + logs}),
      PRODUCT_PLUGIN_DIR);
  playTogether(listener, {&turner});
  ASSERT_TRUE(turner.sourcesFinished());

  const Eigen::Vector2d ball_F(-0.8, 2.9);
  std::vector<double> beside_deg;  // signed: how far the ball lies counter-clockwise of the ray
  for (const fw::JournalEntry& entry : fw::MatchLogReader(onlySubfolder(logs)).entries()) {
    const auto* message = std::get_if<fw::TeamMessage>(&entry.item);
    if (message == nullptr) continue;
    for (const fw::BallRay& ray : message->omni_rays) beside_deg.push_back(degreesBeside(ray, ball_F));
  }
  ASSERT_GE(beside_deg.size(), 100u) << "the 5 s scene's rays, 30 a second, a few missed or lost";
  double sum = 0.0;
  std::vector<double> apart_deg;
  for (const double b : beside_deg) {
    sum += b;
    apart_deg.push_back(std::abs(b));
  }
  const double mean_deg = sum / static_cast<double>(beside_deg.size());
  std::printf("the ball beside the rays: %.2f degrees on average, %.2f at the 90th percentile (%zu rays)\n", mean_deg,
              fw::quantile(apart_deg, 0.9), beside_deg.size());
  EXPECT_LE(std::abs(mean_deg), 1.0) << "no bias: the turn is not in the rays";
  EXPECT_LE(fw::quantile(apart_deg, 0.9), 3.5);
}

TEST(TeamPlugin, WhatARobotSendsIsPlacedWithTheLatenciesItsFusionLearnt) {
  // The robot swings its heading 20 degrees either way every 2.5 s, facing a ball 3 m away
  // (swing_at_rest); its localisation stamps each pose 50 ms late and its omni camera each image 40 ms
  // late, which its file does not say (fusion.pose.latency_s and fusion.omni.latency_s 0). Its fusion
  // learns both, the pose's from the ball at rest while the robot turns, the omni's from the ball
  // both sensors see (docs/fusion.md, "Time"); from then on the team plugin places the Kinect's ball
  // and the omni camera's rays with them too. With the pose as stamped, the turn (up to 50 deg/s)
  // would put the ball sent to a teammate up to 0.13 m off where it lies; with the omni's image time
  // as stamped, its rays up to 2 degrees beside it. The localisation is exact here, so that what is
  // left is the lateness alone.
  const ScopedTempDir dir;
  const std::string team_key = writeKey(dir, "team.key", team::TeamKey::random());
  constexpr int kPort = 50438;
  constexpr double kPoseLate_s = 0.05, kOmniLate_s = 0.04;
  const std::string turner_logs = (dir.path() / "turner").string(), listener_logs = (dir.path() / "listener").string();
  const std::vector<std::string> swinging{"kinect3d.source=sim:swing_at_rest",
                                          "localisation.source=sim:swing_at_rest",
                                          "omni.source=sim:swing_at_rest",
                                          "localisation.sim.stamp_late_s=" + std::to_string(kPoseLate_s),
                                          "omni.sim.stamp_late_s=" + std::to_string(kOmniLate_s),
                                          "localisation.sim.sigma_xy_m=0",
                                          "localisation.sim.sigma_theta_deg=0",
                                          "localisation.sim.odometry=false",
                                          "omni.sim.false_rate_hz=0",
                                          "logger.folder=" + turner_logs};
  fw::Host turner(robotConfig("turner", 1, 103, {104}, kPort, team_key,
                              "[localisation, kinect3d, omni, fusion, team, logger]", swinging),
                  PRODUCT_PLUGIN_DIR);
  fw::Host listener(robotConfig("listener", 2, 104, {103}, kPort, team_key, "[localisation, omni, team, logger]",
                                {"localisation.source=sim:swing_at_rest", "omni.source=sim:swing_at_rest",
                                 "logger.folder=" + listener_logs}),
                    PRODUCT_PLUGIN_DIR);
  playTogether(listener, {&turner});
  ASSERT_TRUE(turner.sourcesFinished());

  // The fusion's estimates as it said them, by kind (the first comes from a few readings and is
  // mostly its prior): when it first said one, its last, and when it came within 10 ms of that.
  std::map<std::string, std::vector<std::pair<double, double>>> said;  // wall time, latency
  for (const fw::JournalEntry& entry : fw::MatchLogReader(onlySubfolder(turner_logs)).entries()) {
    const auto* event = std::get_if<fw::Event>(&entry.item);
    if (event != nullptr && (event->kind == "pose_latency" || event->kind == "omni_latency") && event->value) {
      said[event->kind].emplace_back(entry.wall_time_s, *event->value);
    }
  }
  ASSERT_EQ(said.size(), 2u) << "the turner's fusion learnt both latencies";
  const auto settled_wall_s = [](const std::vector<std::pair<double, double>>& estimates) {
    return std::find_if(estimates.begin(), estimates.end(),
                        [&](const auto& e) { return std::abs(e.second - estimates.back().second) <= 0.01; })
        ->first;
  };
  const std::vector<std::pair<double, double>>&pose = said["pose_latency"], &omni = said["omni_latency"];
  EXPECT_NEAR(pose.back().second, kPoseLate_s, 0.015);
  EXPECT_NEAR(omni.back().second, kOmniLate_s, 0.015);

  // How far each Kinect ball it sent lies from the ball, before it said any pose latency and from
  // half a second after its estimate settled; how far beside the ball each ray it sent passes, from
  // half a second after both had settled (the omni's is learnt within a second, from the first
  // swing: too few rays before it).
  const Eigen::Vector2d ball_F(0.3, 3.0);
  const double pose_settled_wall_s = settled_wall_s(pose) + 0.5;
  const double both_settled_wall_s = std::max(pose_settled_wall_s, settled_wall_s(omni) + 0.5);
  std::vector<double> balls_before_m, balls_after_m, rays_after_deg;
  for (const fw::JournalEntry& entry : fw::MatchLogReader(onlySubfolder(listener_logs)).entries()) {
    const auto* message = std::get_if<fw::TeamMessage>(&entry.item);
    if (message == nullptr) continue;
    for (const fw::BallObservation& ball : message->kinect_balls) {
      const double off_m = (ball.position_m.head<2>() - ball_F).norm();
      if (entry.wall_time_s < pose.front().first) balls_before_m.push_back(off_m);
      if (entry.wall_time_s > pose_settled_wall_s) balls_after_m.push_back(off_m);
    }
    if (entry.wall_time_s <= both_settled_wall_s) continue;
    for (const fw::BallRay& ray : message->omni_rays) rays_after_deg.push_back(std::abs(degreesBeside(ray, ball_F)));
  }
  ASSERT_GE(balls_before_m.size(), 20u) << "the Kinect's balls sent before the pose latency was learnt";
  ASSERT_GE(balls_after_m.size(), 30u) << "the Kinect's balls sent after";
  ASSERT_GE(rays_after_deg.size(), 30u) << "the omni camera's rays sent after both latencies were learnt";
  std::printf(
      "learnt: pose %.0f ms, omni %.0f ms; p90: the balls %.3f m off before the pose latency, %.3f m after "
      "(%zu, %zu); the rays %.2f degrees beside after both (%zu)\n",
      1000 * pose.back().second, 1000 * omni.back().second, fw::quantile(balls_before_m, 0.9),
      fw::quantile(balls_after_m, 0.9), balls_before_m.size(), balls_after_m.size(), fw::quantile(rays_after_deg, 0.9),
      rays_after_deg.size());
  EXPECT_LE(fw::quantile(balls_after_m, 0.9), 0.05) << "50 ms of a 50 deg/s turn is 0.13 m at 3 m";
  EXPECT_LE(fw::quantile(balls_after_m, 0.9), 0.6 * fw::quantile(balls_before_m, 0.9));
  // The camera's bearing noise (0.6 degrees) alone puts 90 % of the rays within 1 degree; 40 ms of
  // the turn adds up to 2.
  EXPECT_LE(fw::quantile(rays_after_deg, 0.9), 1.5);
}

}  // namespace

TEST(TeamWorlds, AMislocalisedKeeperIsDiscountedAndMovesNoWorldBallEvenWhereItAloneSeesTheLob) {
  // The bound, as the team report measures it (docs/team-report.md), in both worlds of three
  // robots: in team the keeper alone sees the lob and nobody sees a ball it sees before; in team_rest
  // every robot sees the ball it sees. With the keeper a metre off or turned by 20 degrees, through
  // the lossy network, the defender and the striker discount it (by where it sees the robots), and
  // the keeper moves their world ball (against the same log replayed without it) by more than 0.2 m
  // in fewer than a tenth of the updates (the 90th percentile; the report counts every one).
  const ScopedTempDir dir;
  const std::string report = (dir.path() / "report.md").string();
  const auto [status, output] =
      runCommand(std::string(KINECT3D_EXE) + " report team --scenes team,team_rest --runs 1 --out " + report +
                 " --worlds " + TEST_DATA_DIR + "/scenes 2>&1");
  ASSERT_EQ(status, 0) << output;
  std::ifstream in(report);
  int rows = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("| lossy, the keeper's localisation", 0) != 0 || line.find("| keeper") != std::string::npos)
      continue;
    std::vector<std::string> cells;
    for (std::size_t start = 1, bar; (bar = line.find('|', start)) != std::string::npos; start = bar + 1) {
      cells.push_back(line.substr(start + 1, bar - start - 2));
    }
    ASSERT_EQ(cells.size(), 15u) << line;
    ++rows;
    EXPECT_EQ(cells[11], "1 of 1") << line;
    // "median / p90 / max"
    const std::size_t p90_at = cells[12].find(" / ");
    ASSERT_NE(p90_at, std::string::npos) << line;
    EXPECT_LE(std::stod(cells[12].substr(p90_at + 3)), 0.2) << line;
  }
  EXPECT_EQ(rows, 8) << "the defender and the striker, the keeper a metre off and turned, in both worlds";
}
