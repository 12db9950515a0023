#include "offline_fusion.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "framework_api/host.h"
#include "framework_api/install_layout.h"
#include "framework_api/log.h"
#include "fusion/json_lines.h"
#include "kinect3d/sim/sim_sources.h"

namespace kinect3d {

namespace {

// The source times of every frame a recorded depth source delivers (those the kinect3d plugin will get).
std::vector<double> frameTimes(const std::string& uri) {
  const auto source = sim::sourcesWithSimulator().open(uri);
  if (source->frameCount() == 0) {
    throw DepthSourceError(uri + ": a live device; fuse reads recordings (vision_host runs a live robot)");
  }
  std::vector<double> times;
  DepthFrame frame;
  for (ReadResult result; (result = source->read(frame)) != ReadResult::kEnd;) {
    if (result == ReadResult::kFrame) times.push_back(frame.source_time_s);
  }
  return times;
}

template <typename Item>
std::vector<double> stampsOf(const std::vector<Item>& items) {
  std::vector<double> times;
  for (const Item& item : items) times.push_back(item.stamp.source_time_s);
  return times;
}

// The inputs of several plugins merged into one order: by time, at equal times by the plugins'
// order in `inputs`, each plugin's own order kept. An input whose time is not finite has no step:
// its plugin skips it (with a warning) on the way to the next.
std::vector<fw::Host::ReplayStep> inTimeOrder(const std::vector<std::pair<std::string, std::vector<double>>>& inputs) {
  std::vector<std::size_t> next(inputs.size(), 0);
  std::vector<fw::Host::ReplayStep> steps;
  for (;;) {
    std::optional<std::size_t> earliest;
    double earliest_t = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < inputs.size(); ++k) {
      const std::vector<double>& times = inputs[k].second;
      while (next[k] < times.size() && !std::isfinite(times[next[k]])) ++next[k];
      if (next[k] < times.size() && (!earliest || times[next[k]] < earliest_t)) {
        earliest = k;
        earliest_t = times[next[k]];
      }
    }
    if (!earliest) return steps;
    steps.push_back({inputs[*earliest].first, earliest_t});
    ++next[*earliest];
  }
}

}  // namespace

FusionRun fuseRecorded(const fw::Config& config, const RecordedFiles& files) {
  std::vector<std::pair<std::string, std::vector<double>>> inputs;
  std::vector<std::string> overrides;
  std::string plugins;
  const auto add = [&](const std::string& plugin, const std::string& source, std::vector<double> times) {
    inputs.emplace_back(plugin, std::move(times));
    overrides.push_back(plugin + ".source=" + fw::yamlQuoted(source));
    overrides.push_back(plugin + ".realtime=false");
    plugins += plugin + ", ";
  };
  if (!files.pose.empty()) add("localisation", "file:" + files.pose, stampsOf(fusion::readPoseFile(files.pose)));
  if (!files.depth.empty()) add("kinect3d", files.depth, frameTimes(files.depth));
  if (!files.omni.empty()) add("omni", "file:" + files.omni, stampsOf(fusion::readOmniFile(files.omni, "omni")));
  overrides.push_back("host.plugins=[" + plugins + "fusion]");
  const std::vector<fw::Host::ReplayStep> steps = inTimeOrder(inputs);

  FusionRun run;
  fw::Host host(config.with(overrides), fw::defaultPluginDir());
  host.world().openJournal(false);
  std::uint64_t refused = 0;
  host.replay(steps, [&] {
    for (const fw::JournalEntry& entry : host.world().takeJournal(&refused)) {
      if (const auto* ball = std::get_if<fw::FusedBall>(&entry.item)) {
        run.updates.push_back({ball->stamp.source_time_s, *ball});
      } else if (const auto* none = std::get_if<fw::FusedBallCleared>(&entry.item)) {
        run.updates.push_back({none->stamp.source_time_s, std::nullopt});
      } else if (const auto* event = std::get_if<fw::Event>(&entry.item)) {
        if (event->source == "fusion" && event->kind == "omni_latency") run.omni_latency_s = event->value;
        if (event->source == "fusion" && event->kind == "pose_latency") run.pose_latency_s = event->value;
      }
    }
    if (refused > 0)
      throw std::runtime_error("fuse: " + std::to_string(refused) + " world balls did not fit the journal");
  });
  for (const fw::PluginSummary& summary : host.summaries()) {
    if (summary.errors > 0) fw::logWarn("fuse", fw::formatSummary(summary));
  }
  return run;
}

void writeFieldSensorFiles(const sim::Scene& scene, const sim::OmniCameraModel& omni_model,
                           const sim::LocalisationModel& localisation_model, const std::string& dir) {
  const sim::OmniCameraSimulator omni(scene, omni_model);
  std::vector<fw::OmniFrame> frames;
  for (int i = 0; i < omni.frameCount(); ++i) frames.push_back(omni.frame(i));
  fusion::writeOmniFile(dir + "/omni.jsonl", frames);
  const sim::LocalisationSimulator localisation(scene, localisation_model);
  std::vector<fw::RobotPose> poses;
  for (int i = 0; i < localisation.frameCount(); ++i) poses.push_back(localisation.pose(i));
  fusion::writePoseFile(dir + "/pose.jsonl", poses);
}

}  // namespace kinect3d
