#include "match_tools.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <set>
#include <thread>

#include "detect_line.h"
#include "framework_api/config.h"
#include "framework_api/host.h"
#include "framework_api/install_layout.h"
#include "framework_api/log.h"
#include "fusion/json_lines.h"
#include "kinect3d/sim/sequence_writer.h"
#include "matchlog/match_log.h"

namespace kinect3d {

namespace {

namespace fs = std::filesystem;

// The log's first depth plugin: the one whose frames are replayed or exported.
std::string depthSource(const fw::MatchLogReader& log) {
  const auto sources = log.depthSources();
  if (sources.empty()) throw fw::MatchLogError(log.folder() + ": the match log holds no depth frames");
  return sources.front().first;
}

// Visits the logged entries and the depth frames of one source together, in the order they were
// logged (by the host's wall clock; a depth frame before anything logged at the same moment).
template <typename OnEntry, typename OnDepth>
void inLoggedOrder(const fw::MatchLogReader& log, const std::string& depth_source, OnEntry on_entry, OnDepth on_depth) {
  const std::vector<fw::JournalEntry> entries = log.entries();
  fw::MatchLogReader::DepthFrames frames(log, depth_source);
  fw::DepthImage image;
  double depth_wall_s = 0.0;
  bool has_depth = frames.next(image, depth_wall_s);
  for (const fw::JournalEntry& entry : entries) {
    while (has_depth && depth_wall_s <= entry.wall_time_s) {
      on_depth(image, depth_wall_s);
      has_depth = frames.next(image, depth_wall_s);
    }
    on_entry(entry);
  }
  while (has_depth) {
    on_depth(image, depth_wall_s);
    has_depth = frames.next(image, depth_wall_s);
  }
}

}  // namespace

void replayMatch(const std::string& log_folder, const std::string& defaults_dir, const std::string& robot_file,
                 const std::vector<std::string>& overrides, const std::string& output) {
  const fw::MatchLogReader log(log_folder);
  std::string robot = robot_file;
  if (robot.empty()) {
    fs::create_directories(output);
    robot = (fs::path(output) / "recorded_config.yaml").string();
    std::ofstream file(robot);
    file << "# The configuration recorded in " << log_folder << " (the run being replayed).\n" << log.run().config_yaml;
    if (!file.flush()) throw std::runtime_error("cannot write '" + robot + "'");
  }

  // Which plugin handed out each input on the robot: a depth frame names its plugin, and the omni
  // images and poses come from the plugins of those names (a plugin's name is its library's).
  std::vector<fw::Host::ReplayStep> steps;
  std::set<std::string> sources;
  for (const fw::MatchLogReader::Input& input : log.inputs()) {
    switch (input.kind) {
      case fw::MatchLogReader::Input::Kind::kDepth:
        steps.push_back({input.depth_source, input.wall_time_s});
        break;
      case fw::MatchLogReader::Input::Kind::kOmni:
        steps.push_back({"omni", input.wall_time_s});
        break;
      case fw::MatchLogReader::Input::Kind::kPose:
        steps.push_back({"localisation", input.wall_time_s});
        break;
      case fw::MatchLogReader::Input::Kind::kTeam:
        steps.push_back({"team", input.wall_time_s});
        break;
    }
    sources.insert(steps.back().plugin);
  }
  if (steps.empty()) throw fw::MatchLogError(log_folder + ": the match log holds no inputs to replay");

  // The robot's plugins as configured, but the sources read the log as fast as they can, the logger
  // records under output, and nothing prints to the console.
  std::vector<std::string> replay_overrides;
  for (const std::string& source : sources) {
    replay_overrides.push_back(source + ".source=" + fw::yamlQuoted("log:" + log_folder));
    replay_overrides.push_back(source + ".realtime=false");
  }
  const fw::Config configured = fw::Config::load(defaults_dir, robot, overrides);
  std::string plugins;
  for (const std::string& plugin : configured.block("host").getStringList("plugins")) {
    if (plugin != "console" && plugin != "logger") plugins += plugin + ", ";
    // The team plugin hands out the teammates' messages the robot received, and never talks to the
    // robot network, whether the robot received any or not.
    if (plugin == "team" && sources.insert(plugin).second) {
      replay_overrides.insert(replay_overrides.end(),
                              {"team.source=" + fw::yamlQuoted("log:" + log_folder), "team.realtime=false"});
    }
  }
  replay_overrides.insert(replay_overrides.end(),
                          {"host.plugins=[" + plugins + "logger]", "logger.folder=" + fw::yamlQuoted(output),
                           "logger.fallback_folder=\"\"", "host.replay_of=" + fw::yamlQuoted(log_folder)});
  replay_overrides.insert(replay_overrides.end(), overrides.begin(), overrides.end());
  const fw::Config config = fw::Config::load(defaults_dir, robot, replay_overrides);

  const std::set<std::string> before = fw::entriesOf(output);
  {
    fw::Host host(config, fw::defaultPluginDir());
    host.replay(steps);
    for (const fw::PluginSummary& summary : host.summaries()) {
      if (summary.errors > 0) fw::logWarn("replay", fw::formatSummary(summary));
    }
  }  // the logger records its last batch as the host unloads it
  const std::optional<std::string> run = fw::newRunIn(output, before);
  if (!run)
    throw fw::MatchLogError(output + ": the replay was not recorded there (the logger's messages above say why)");
  fw::logInfo("replay", log_folder + " -> " + *run + ": " + std::to_string(steps.size()) + " inputs replayed");
}

void exportMatch(const std::string& log_folder, const ExportFiles& files) {
  const fw::MatchLogReader log(log_folder);
  for (const std::string& file : {files.omni, files.pose, files.detections}) {
    if (!file.empty() && fs::path(file).has_parent_path()) fs::create_directories(fs::path(file).parent_path());
  }
  std::vector<fw::OmniFrame> omni;
  std::vector<fw::RobotPose> poses;
  for (const fw::JournalEntry& entry : log.entries()) {
    if (const auto* frame = std::get_if<fw::OmniFrame>(&entry.item)) omni.push_back(*frame);
    if (const auto* pose = std::get_if<fw::RobotPose>(&entry.item)) poses.push_back(*pose);
  }
  if (!files.omni.empty()) fusion::writeOmniFile(files.omni, omni);
  if (!files.pose.empty()) fusion::writePoseFile(files.pose, poses);
  if (files.detections.empty() && files.tum.empty()) return;

  const std::string source = depthSource(log);
  std::ofstream detections;
  if (!files.detections.empty()) {
    detections.open(files.detections);
    if (!detections) throw std::runtime_error("cannot write '" + files.detections + "'");
  }
  std::optional<sim::TumSequenceWriter> tum;
  if (!files.tum.empty()) tum.emplace(files.tum);
  DetectLines lines(source, [&](const std::string& line) {
    detections << line << "\n";
    if (!detections) throw std::runtime_error("cannot write '" + files.detections + "'");
  });
  inLoggedOrder(
      log, source, [&](const fw::JournalEntry& entry) { lines.add(entry.item); },
      [&](const fw::DepthImage& image, double) {
        if (tum) tum->write(fromDepthImage(image));
        if (!files.detections.empty()) lines.add(image);
      });
  if (!files.detections.empty()) lines.flush();
  fw::logInfo("export", log_folder + ": " + std::to_string(omni.size()) + " omni images, " +
                            std::to_string(poses.size()) + " poses" +
                            (files.detections.empty() && files.tum.empty() ? "" : ", the depth of '" + source + "'"));
}

// The run folder the logger of a host started after `before` writes, once it holds a readable log.
std::string newRunFolder(const std::string& base, const std::set<std::string>& before) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    if (const std::optional<std::string> run = fw::newRunIn(base, before)) return *run;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  throw std::runtime_error(base + ": the logger started no run there within 20 s");
}

std::vector<std::string> matchLogsIn(const std::string& folder) {
  std::vector<std::string> runs;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    if (fs::exists(entry.path() / fw::kMatchLogFile)) runs.push_back(entry.path().string());
  }
  return runs;
}

// A match log folder as given, or in a folder of them (the logger's logs/) the newest, said aloud.
std::string newestRun(const std::string& folder) {
  if (fs::exists(fs::path(folder) / fw::kMatchLogFile)) return folder;
  const std::vector<std::string> runs = matchLogsIn(folder);
  if (runs.empty()) throw std::runtime_error(folder + ": neither a match log nor a folder of them");
  const std::string newest = *std::max_element(runs.begin(), runs.end());  // <date>_<time>_<robot>
  fw::logInfo("view", "the newest of " + std::to_string(runs.size()) + " runs in " + folder + ": " + newest);
  return newest;
}

}  // namespace kinect3d
