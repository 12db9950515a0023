#include "team_report.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <thread>
#include <vector>

#include "framework_api/config.h"
#include "framework_api/host.h"
#include "framework_api/install_layout.h"
#include "framework_api/sensor_pose.h"
#include "kinect3d/sim/ball_motion.h"
#include "kinect3d/sim/scene.h"
#include "match_tools.h"
#include "matchlog/match_log.h"
#include "report_text.h"
#include "team_packet.h"
#include "udp_impairment.h"

namespace kinect3d {

namespace {

namespace fs = std::filesystem;

constexpr double kInTheAirAbove_m = 0.1;      // truth: in the air when the centre is this far above rest ...
constexpr double kOnTheGroundBelow_m = 0.01;  // ... on the ground below this; the 10 cm between are not scored
constexpr double kHeldWithin_m = 0.5;         // a world ball this close to the truth holds the ball
constexpr double kMovedBeyond_m = 0.2;        // the bound on what a mislocalised teammate may move
constexpr double kWorldStartsAfter_s = 2.0;   // time for every host to load its plugins before the world's time 0
constexpr int kPort = 50470;                  // the report's own (the tests use 50431-50436)

struct Robot {
  std::string name;
  bool kinect = false;
};
// A world is a folder of scene files, one per robot, the same ball in each (docs/team-report.md).
// Its first robot is the one a network case may mislocalise.
struct World {
  std::string folder;
  std::string what;
  std::vector<Robot> robots;
};
const std::vector<World> kWorlds = {
    {"team",
     "three robots: a lob kicked high over the defender, which only the keeper's Kinect sees",
     {{"keeper", true}, {"defender", false}, {"striker", false}}},
    {"team_rest",
     "three robots: the ball lies still for 2 s where the keeper's Kinect and every omni camera see it, then a lob "
     "past the defender",
     {{"keeper", true}, {"defender", false}, {"striker", false}}},
    {"team5",
     "five robots: the same lob, seen by the keeper's Kinect and the wing's",
     {{"keeper", true}, {"wing", true}, {"defender", false}, {"striker", false}, {"midfielder", false}}},
    {"team_hop",
     "two robots, omni cameras only: a hop up to 0.57 m between them",
     {{"defender", false}, {"striker", false}}},
    {"team_hop3",
     "three robots, omni cameras only: the same hop",
     {{"defender", false}, {"striker", false}, {"midfielder", false}}},
};

struct Network {
  std::string name;
  UdpImpairment::Faults faults;
  std::vector<std::string> first_robot_overrides;  // its localisation made wrong
};
std::vector<Network> networksOf(const World& world) {
  const UdpImpairment::Faults lossy{0.2, 0.2, 0.05};
  // The lob only the keeper sees through every fault; the keeper mislocalised there, and where the
  // others can judge it before the lob (team_rest, whose lossy network is the reference).
  const bool every_fault = world.folder == "team", judged = world.folder == "team_rest";
  std::vector<Network> networks;
  if (!judged) networks.push_back({"perfect", {0.0, 0.0, 0.0}, {}});
  if (every_fault) {
    networks.push_back({"20 % lost", {0.2, 0.0, 0.0}, {}});
    networks.push_back({"up to 200 ms late", {0.0, 0.2, 0.0}, {}});
  }
  networks.push_back({"lossy (20 % lost, up to 200 ms late, 5 % twice)", lossy, {}});
  if (every_fault || judged) {
    networks.push_back({"lossy, the keeper's localisation 1 m off", lossy, {"localisation.sim.bias_x_m=1.0"}});
    networks.push_back(
        {"lossy, the keeper's localisation turned 20 deg", lossy, {"localisation.sim.bias_theta_deg=20"}});
  }
  return networks;
}

// One robot's world balls against the truth, pooled over runs.
struct Score {
  std::vector<double> air_m, ground_m;  // the error of each world ball there was
  int air_updates = 0, air_held = 0, ground_updates = 0, ground_held = 0;
  std::vector<double> air_medians_m;  // one per run
  int discounted_first = 0;           // runs in which it said the world's first robot was mislocalised
  // What the world's first robot changed: how far each world ball lay from the one without its
  // observations, and the updates in which only one of the two had a world ball.
  std::vector<double> moved_m;
  int moved_updates = 0, held_by_one = 0;
  double last_moved_beyond_s = -1.0;  // world time of the last update moved beyond kMovedBeyond_m (-1: none)

  void add(const Score& run) {
    air_m.insert(air_m.end(), run.air_m.begin(), run.air_m.end());
    ground_m.insert(ground_m.end(), run.ground_m.begin(), run.ground_m.end());
    air_updates += run.air_updates;
    air_held += run.air_held;
    ground_updates += run.ground_updates;
    ground_held += run.ground_held;
    air_medians_m.insert(air_medians_m.end(), run.air_medians_m.begin(), run.air_medians_m.end());
    discounted_first += run.discounted_first;
    moved_m.insert(moved_m.end(), run.moved_m.begin(), run.moved_m.end());
    moved_updates += run.moved_updates;
    held_by_one += run.held_by_one;
    last_moved_beyond_s = std::max(last_moved_beyond_s, run.last_moved_beyond_s);
  }
};

// Every world ball (or none) the robot published in the scene, on the world's clock; and whether it
// discounted the world's first robot (first_robot, its name).
Score scoreLog(const std::string& run, const sim::Scene& scene, double world_start_s, const std::string& first_robot) {
  const sim::BallMotion truth(*scene.ball, scene.physics, scene.duration_s, scene.objects);
  Score s;
  for (const fw::JournalEntry& entry : fw::MatchLogReader(run).entries()) {
    std::optional<Eigen::Vector3d> ball_F;
    double time_s = 0.0;
    if (const auto* ball = std::get_if<fw::FusedBall>(&entry.item)) {
      ball_F = ball->position_F;
      time_s = ball->stamp.source_time_s;
    } else if (const auto* none = std::get_if<fw::FusedBallCleared>(&entry.item)) {
      time_s = none->stamp.source_time_s;
    } else if (const auto* event = std::get_if<fw::Event>(&entry.item)) {
      if (event->kind == "teammate_discounted" && event->message.rfind("teammate " + first_robot + " ", 0) == 0) {
        s.discounted_first = 1;
      }
      continue;
    } else {
      continue;
    }
    const double t = time_s - world_start_s;
    if (t < 0.0 || t > scene.duration_s) continue;
    const Eigen::Vector3d true_F = truth.positionAt(t);
    const double above_m = true_F.z() - scene.physics.radius_m;
    const bool air = above_m > kInTheAirAbove_m;
    if (!air && above_m > kOnTheGroundBelow_m) continue;
    const double error_m = ball_F ? (*ball_F - true_F).norm() : std::numeric_limits<double>::infinity();
    (air ? s.air_updates : s.ground_updates) += 1;
    if (ball_F) (air ? s.air_m : s.ground_m).push_back(error_m);
    if (error_m < kHeldWithin_m) (air ? s.air_held : s.ground_held) += 1;
  }
  if (!s.air_m.empty()) s.air_medians_m.push_back(fw::quantile(s.air_m, 0.5));
  return s;
}

// What a teammate changed in a robot's world ball: the robot's log against the same log replayed
// without that teammate's observations (fusion.team.ignore: its messages still step the fusion), at
// each time both have a world-state update, the last update of each time, over the world's time.
void addMoved(const std::string& with_log, const std::string& without_log, double world_start_s, double duration_s,
              Score& s) {
  const auto updatesOf = [](const std::string& log) {
    std::map<double, std::optional<Eigen::Vector3d>> updates;
    for (const fw::JournalEntry& entry : fw::MatchLogReader(log).entries()) {
      if (const auto* ball = std::get_if<fw::FusedBall>(&entry.item)) {
        updates[ball->stamp.source_time_s] = ball->position_F;
      } else if (const auto* none = std::get_if<fw::FusedBallCleared>(&entry.item)) {
        updates[none->stamp.source_time_s] = std::nullopt;
      }
    }
    return updates;
  };
  const auto with = updatesOf(with_log), without = updatesOf(without_log);
  for (const auto& [time_s, ball_F] : with) {
    const double t = time_s - world_start_s;
    const auto other = without.find(time_s);
    if (t < 0.0 || t > duration_s || other == without.end()) continue;
    ++s.moved_updates;
    if (ball_F && other->second) {
      s.moved_m.push_back((*ball_F - *other->second).norm());
      if (s.moved_m.back() > kMovedBeyond_m) s.last_moved_beyond_s = std::max(s.last_moved_beyond_s, t);
    } else if (ball_F || other->second) {
      ++s.held_by_one;
    }
  }
}

// The one run folder a robot's logger made in folder.
std::string theRunIn(const fs::path& folder) {
  const std::vector<std::string> runs = matchLogsIn(folder.string());
  if (runs.size() != 1)
    throw std::runtime_error(folder.string() + ": expected one match log, found " + std::to_string(runs.size()));
  return runs.front();
}

struct Played {
  std::vector<std::string> logs;  // per robot, in the world's order
  double world_start_s = 0.0;     // the world's time 0 on every robot's clock (its source times count from it)
  double bytes_per_robot_s = 0.0, bytes_per_packet = 0.0;
};

// Every robot of the world a live host in this process (as on the field, each with its own
// sensors, fusion and team plugin), its team packets through the network's faults on loopback:
// robot i on 127.0.0.(140+i), its teammates sending to it through a link on 127.0.0.(150+i).
Played playWorld(const TeamReportOptions& options, const World& world, const Network& network, unsigned seed,
                 const fs::path& dir) {
  fs::create_directories(dir);
  const std::string key_file = (dir / "team.key").string();
  std::ofstream(key_file) << team::TeamKey::random().hex() << "\n";
  const auto robot_address = [](std::size_t i) { return "127.0.0." + std::to_string(140 + i); };
  const auto link_address = [](std::size_t i) { return "127.0.0." + std::to_string(150 + i); };
  const std::size_t n = world.robots.size();
  std::vector<UdpImpairment::Link> links;
  for (std::size_t i = 0; i < n; ++i) links.push_back({link_address(i), robot_address(i)});
  const UdpImpairment link(links, kPort, network.faults, seed);

  const double world_start_s = fw::wallClockNow_s() + kWorldStartsAfter_s;
  std::vector<std::unique_ptr<fw::Host>> hosts;
  for (std::size_t i = 0; i < n; ++i) {
    const Robot& robot = world.robots[i];
    const std::string scene_file = (fs::path(options.worlds_dir) / world.folder / (robot.name + ".yaml")).string();
    const std::string source = fw::yamlQuoted("sim:" + scene_file);
    std::string peers;
    for (std::size_t j = 0; j < n; ++j) {
      if (j != i) peers += (peers.empty() ? "" : ", ") + link_address(j);
    }
    std::vector<std::string> overrides{
        "host.robot_name=" + robot.name,
        "host.log_level=warn",  // five robots' progress is thousands of lines; their warnings are few
        "host.plugins=[localisation, " + std::string(robot.kinect ? "kinect3d, " : "") + "omni, fusion, team, logger]",
        "host.sim_world_start_wall_s=" + std::to_string(world_start_s),
        "localisation.source=" + source,
        "omni.source=" + source,
        "team.team_id=5",
        "team.robot_id=" + std::to_string(i + 1),
        "team.bind_address=" + robot_address(i),
        "team.port=" + std::to_string(kPort),
        "team.peers=[" + peers + "]",
        "team.key_file=" + fw::yamlQuoted(key_file),
        "logger.folder=" + fw::yamlQuoted((dir / robot.name).string())};
    if (robot.kinect) {
      overrides.push_back("kinect3d.source=" + source);
      overrides.push_back("kinect3d.sensor.pose_in_robot=" +
                          fw::poseInRobotYaml(sim::loadScene(scene_file).sensor_pose));
    }
    if (i == 0) {
      overrides.insert(overrides.end(), network.first_robot_overrides.begin(), network.first_robot_overrides.end());
    }
    hosts.push_back(
        std::make_unique<fw::Host>(fw::Config::load(options.defaults_dir, "", overrides), fw::defaultPluginDir()));
  }
  const auto started = std::chrono::steady_clock::now();
  for (const auto& host : hosts) host->start();
  const auto deadline = started + std::chrono::seconds(120);
  const auto all_played = [&] {
    return std::all_of(hosts.begin(), hosts.end(), [](const auto& host) { return host->sourcesFinished(); });
  };
  while (!all_played()) {
    if (std::chrono::steady_clock::now() > deadline) {
      throw std::runtime_error("report team: " + world.folder + ": the robots had not played their scenes after 120 s");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    for (const auto& host : hosts) host->watch();
  }
  // Offline nothing must stop within a second: every robot's logger finishes its last commit,
  // however loaded the machine (a logger still inside it is waited for when its host goes).
  for (const auto& host : hosts) host->stop(std::chrono::seconds(30));
  const double played_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  hosts.clear();  // every logger closes its log

  Played played;
  played.world_start_s = world_start_s;
  UdpImpairment::Carried carried;
  for (std::size_t i = 0; i < n; ++i) {
    const UdpImpairment::Carried to_robot = link.carried(link_address(i));
    carried.packets_in += to_robot.packets_in;
    carried.bytes_in += to_robot.bytes_in;
    played.logs.push_back(theRunIn(dir / world.robots[i].name));
  }
  played.bytes_per_robot_s = static_cast<double>(carried.bytes_in) / static_cast<double>(n) / played_s;
  played.bytes_per_packet =
      carried.packets_in ? static_cast<double>(carried.bytes_in) / static_cast<double>(carried.packets_in) : 0.0;
  return played;
}

std::string share(int part, int whole) {
  if (whole == 0) return "-";
  char text[32];
  std::snprintf(text, sizeof text, "%.0f %%", 100.0 * part / whole);
  return text;
}

std::string range(std::vector<double> values) {
  if (values.empty()) return "-";
  std::sort(values.begin(), values.end());
  return metres(values.front()) + "-" + metres(values.back());
}

// mislocalising: the network mislocalises the world's first robot; first: this is that robot.
std::string row(const std::string& network, const Robot& robot, const Score& with, const Score& alone, int runs,
                bool mislocalising, bool first) {
  std::string text = "| " + network + " | " + robot.name + (robot.kinect ? " (Kinect)" : "") + " | " +
                     metres(fw::quantile(with.air_m, 0.5)) + " / " + metres(fw::quantile(with.air_m, 0.9)) + " | " +
                     range(with.air_medians_m) + " | " + share(with.air_held, with.air_updates) + " | " +
                     metres(fw::quantile(alone.air_m, 0.5)) + " / " + metres(fw::quantile(alone.air_m, 0.9)) + " | " +
                     share(alone.air_held, alone.air_updates) + " | " + metres(fw::quantile(with.ground_m, 0.5)) +
                     " | " + share(with.ground_held, with.ground_updates) + " | " +
                     metres(fw::quantile(alone.ground_m, 0.5)) + " | " + share(alone.ground_held, alone.ground_updates);
  if (mislocalising && first) text += " |  |  |  |";
  if (mislocalising && !first) {
    text += " | " + std::to_string(with.discounted_first) + " of " + std::to_string(runs) + " | ";
    if (with.moved_m.empty()) {
      text += "- | - | -";
    } else {
      const int beyond = static_cast<int>(
          std::count_if(with.moved_m.begin(), with.moved_m.end(), [](double m) { return m > kMovedBeyond_m; }));
      char last[32];
      std::snprintf(last, sizeof last, " (the last at %.2f s)", with.last_moved_beyond_s);
      text += metres(fw::quantile(with.moved_m, 0.5)) + " / " + metres(fw::quantile(with.moved_m, 0.9)) + " / " +
              metres(fw::quantile(with.moved_m, 1.0)) + " | " + share(beyond, with.moved_updates) +
              (beyond > 0 ? last : "") + " | " + share(with.held_by_one, with.moved_updates);
    }
  }
  return text + " |\n";
}

}  // namespace

std::string teamReportWorlds() {
  std::vector<std::string> names;
  for (const World& world : kWorlds) names.push_back(world.folder);
  return joined(names);
}

void writeTeamReport(const TeamReportOptions& options, const std::string& out_path) {
  if (options.runs < 1) throw std::runtime_error("report team: --runs must be at least 1");
  for (const std::string& name : options.worlds) {
    if (std::none_of(kWorlds.begin(), kWorlds.end(), [&](const World& world) { return world.folder == name; })) {
      throw std::runtime_error("--scenes: '" + name + "' is not a world of the team report (" + teamReportWorlds() +
                               ")");
    }
  }
  const auto chosen = [&](const World& world) {
    return options.worlds.empty() ||
           std::find(options.worlds.begin(), options.worlds.end(), world.folder) != options.worlds.end();
  };
  for (const World& world : kWorlds) {
    if (!chosen(world)) continue;
    for (const Robot& robot : world.robots) {
      const fs::path file = fs::path(options.worlds_dir) / world.folder / (robot.name + ".yaml");
      if (!fs::exists(file)) {
        throw std::runtime_error(
            "report team: " + file.string() +
            " missing (--worlds is the folder holding team/, team_rest/, team5/, team_hop/ and team_hop3/, "
            "tests/data/scenes in the repository)");
      }
    }
  }
  const fs::path logs_dir = options.keep_dir.empty()
                                ? fs::temp_directory_path() / ("kinect3d-team-report-" + std::to_string(::getpid()))
                                : fs::path(options.keep_dir);
  std::string sections, bandwidth;
  for (std::size_t w = 0; w < kWorlds.size(); ++w) {
    const World& world = kWorlds[w];
    if (!chosen(world)) continue;
    const sim::Scene scene = sim::loadScene((fs::path(options.worlds_dir) / world.folder / "defender.yaml").string());
    const std::vector<Network> networks = networksOf(world);
    const bool mislocalising = std::any_of(networks.begin(), networks.end(),
                                           [](const Network& n) { return !n.first_robot_overrides.empty(); });
    std::string table;
    double bytes_per_robot_s = 0.0, bytes_per_packet = 0.0;
    for (std::size_t c = 0; c < networks.size(); ++c) {
      const Network& network = networks[c];
      std::vector<Score> with(world.robots.size()), alone(world.robots.size());
      for (int run = 1; run <= options.runs; ++run) {
        const fs::path dir = logs_dir / world.folder / (std::to_string(c) + "-" + std::to_string(run));
        std::printf("report team: %s, %s, run %d of %d\n", world.folder.c_str(), network.name.c_str(), run,
                    options.runs);
        std::fflush(stdout);
        // Seeded by world, network and run: one world played alone plays as in the whole report.
        const unsigned seed = static_cast<unsigned>(1000 * w + 100 * c + run);
        const Played played = playWorld(options, world, network, seed, dir);
        if (c == 0) {
          bytes_per_robot_s += played.bytes_per_robot_s / options.runs;
          bytes_per_packet += played.bytes_per_packet / options.runs;
        }
        for (std::size_t i = 0; i < world.robots.size(); ++i) {
          const std::string& log = played.logs[i];
          const fs::path alone_dir = dir / "alone" / world.robots[i].name;
          replayMatch(log, options.defaults_dir, "", {"fusion.team.use=false"}, alone_dir.string());
          with[i].add(scoreLog(log, scene, played.world_start_s, world.robots.front().name));
          alone[i].add(scoreLog(theRunIn(alone_dir), scene, played.world_start_s, world.robots.front().name));
          if (!network.first_robot_overrides.empty() && i > 0) {
            // The same log without the mislocalised robot's messages: what it moved.
            const std::string& first = world.robots.front().name;
            const fs::path without_dir = dir / ("without_" + first) / world.robots[i].name;
            replayMatch(log, options.defaults_dir, "", {"fusion.team.ignore=[" + first + "]"}, without_dir.string());
            Score moved;
            addMoved(log, theRunIn(without_dir), played.world_start_s, scene.duration_s, moved);
            with[i].add(moved);
          }
        }
      }
      for (std::size_t i = 0; i < world.robots.size(); ++i) {
        table += row(network.name, world.robots[i], with[i], alone[i], options.runs, mislocalising, i == 0);
      }
    }
    sections += "\n## " + world.folder + ": " + world.what + "\n\n" +
                "| network | robot | in the air, with teammates: median / p90 (m) | per run: median (m) | held | "
                "alone: median / p90 (m) | held | on the ground, with teammates: median (m) | held | alone: median (m) "
                "| held |" +
                (mislocalising ? " discounted the keeper | moved by the keeper: median / p90 / max (m) | moved more "
                                 "than 0.2 m | held by one "
                                 "only |"
                               : "") +
                "\n|---|---|---|---|---|---|---|---|---|---|---|" + (mislocalising ? "---|---|---|---|" : "") + "\n" +
                table;
    char line[256];
    std::snprintf(line, sizeof line, "| %s | %zu | %.0f | %.1f |\n", world.folder.c_str(), world.robots.size(),
                  bytes_per_packet, bytes_per_robot_s / 1000.0);
    bandwidth += line;
  }

  std::ofstream out(out_path);
  if (!out) throw std::runtime_error(out_path + ": cannot open for writing");
  out << "# The team: each robot's world ball, alone and with its teammates\n\n"
      << "Generated by `kinect3d report team --out " << out_path << " --runs " << options.runs
      << (options.worlds.empty() ? "" : " --scenes " + joined(options.worlds))
      << "`, run from the repository's root (the worlds are read from `--worlds`, tests/data/scenes: "
         "team/, team_rest/, team5/, team_hop/ and team_hop3/; docs/team.md explains the plugin and what the fusion "
         "does with "
         "teammates). Each world is played "
      << options.runs
      << " times per network, live: every robot is a host with its own simulated sensors (localisation 3 cm and 1 "
         "degree, with the wheels' odometry; the omni camera with its misses, orange false balls and 30 ms late "
         "stamps; the Kinect where it has one), its fusion and its team plugin, all on one world clock, each robot "
         "sending to the others over loopback (robots on 127.0.0.140-144, the links into them on 127.0.0.150-154) "
         "through a link that loses, delays and duplicates as "
         "the network says. The robots' messages arrive as they happen to, so each run differs; *per run* gives the "
         "spread of the runs' medians.\n\n"
         "*With teammates* scores each robot's own match log; *alone* the same log replayed with "
         "`fusion.team.use=false` (`kinect3d replay`: the same sensor data, the teammates' messages ignored). "
         "Errors are 3D distances in the field frame between the robot's world ball and the true ball at its time, "
         "*in the air* while the true ball is more than 0.1 m above its resting height, *on the ground* while it is "
         "less than 0.01 m above (the frames between are not scored). *Held*: the share of the robot's world-state "
         "updates then whose world ball lies within 0.5 m of the ball (an update without a world ball, or with one "
         "elsewhere, does not hold it); the errors are those of the world balls there were. In the mislocalised "
         "networks the keeper's localisation is off (`localisation.sim.bias_x_m`, `bias_theta_deg`): its own "
         "rows are its own view, and *discounted the keeper* counts the runs in which the robot said so (a "
         "`teammate_discounted` event). *Moved by the keeper*: how far each of the robot's world balls over the "
         "world's time lay from the one it gives when its log is replayed with `fusion.team.ignore=[keeper]` (the "
         "same data, the keeper's observations not used; the striker's world ball, a weak prior, may still carry the "
         "keeper's), over the updates in which both had one; *moved more than 0.2 m* (the issue's bound): the share "
         "of updates in which it did, and the world's time of the last (a robot judges the keeper on its first "
         "observations of a ball it "
         "sees too, and the sensors start at the world's time 0); *held by one only*: the share of updates in "
         "which only one of the two had a world ball.\n"
      << sections
      << "\n## Bandwidth\n\nWhat the links carried on the perfect network, over the whole run (the robots send "
         "from the moment they start, 2 s before the world's time 0): each robot sends every message to each "
         "teammate, so what one robot sends grows with the team.\n\n"
         "| world | robots | bytes per packet | sent per robot (kB/s) |\n|---|---|---|---|\n"
      << bandwidth;
  if (!out.flush()) throw std::runtime_error(out_path + ": write failed");
  if (options.keep_dir.empty()) fs::remove_all(logs_dir);
}

}  // namespace kinect3d
