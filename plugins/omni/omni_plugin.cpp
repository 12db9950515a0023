// omni: the omni camera's balls (bearing and distance on the floor) into the world state, from the
// simulator (sim:<scene>, the ball's ground projection with the camera's noise, latency, misses,
// occlusions and orange false balls) or from a file (file:<path>, JSON lines, docs/fusion.md),
// played at their own pace when realtime.
#include <chrono>

#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "fusion/json_lines.h"
#include "kinect3d/sim/field_sensors.h"
#include "replay.h"

namespace {

std::vector<fw::OmniFrame> simulate(const fw::ConfigView& sim, const std::string& scene, double world_start_wall_s) {
  kinect3d::sim::OmniCameraModel model;
  model.stamp_late_s = sim.getDouble("stamp_late_s", 0.0, 1.0);
  model.viewpoint_height_m = sim.getDouble("viewpoint_height_m", 0.2, 3.0);
  model.max_height_m = sim.getDouble("max_height_m", 0.0, 3.0);
  model.max_distance_m = sim.getDouble("max_distance_m", 0.5, 100.0);
  model.miss_probability = sim.getDouble("miss_probability", 0.0, 1.0);
  model.false_rate_hz = sim.getDouble("false_rate_hz", 0.0, 100.0);
  model.seed = static_cast<std::uint64_t>(sim.getInt("seed", 0, 2147483647));
  const kinect3d::sim::OmniCameraSimulator camera(
      kinect3d::sim::inSharedWorld(kinect3d::sim::loadScene(scene), world_start_wall_s), model);
  std::vector<fw::OmniFrame> frames;
  for (int i = 0; i < camera.frameCount(); ++i) frames.push_back(camera.frame(i));
  return frames;
}

class OmniPlugin : public fw::Plugin {
 public:
  explicit OmniPlugin(const fw::PluginContext& context)
      : world_(*context.world),
        name_(context.config.path()),
        player_(name_,
                replay::load<fw::OmniFrame>(
                    context.config,
                    [&](const std::string& scene) {
                      return simulate(context.config.child("sim"), scene, replay::simWorldStart(context));
                    },
                    [&](const std::string& path) { return fusion::readOmniFile(path, name_); }),
                replay::clockFor(context), [](const fw::OmniFrame& frame) { return frame.stamp.source_time_s; }) {
    fw::logInfo(
        name_, "playing " + std::to_string(player_.size()) + " omni images from " + context.config.getString("source"));
  }

  fw::StepResult step() override {
    if (player_.finished()) return fw::StepResult::kEndOfStream;
    std::optional<fw::OmniFrame> frame = player_.next();
    if (!frame) return fw::StepResult::kIdle;
    const auto started = std::chrono::steady_clock::now();  // its processing, not its wait for the moment
    frame->stamp.receive_time_s = fw::wallClockNow_s();
    for (fw::OmniBallObservation& ball : frame->balls) {
      ball.source = name_;
      ball.stamp = frame->stamp;
    }
    frame->source = name_;
    world_.publishOmniFrame(*frame);
    world_.reportProcessingTime(name_,
                                std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
    return fw::StepResult::kProcessed;
  }

 private:
  fw::WorldState& world_;
  const std::string name_;
  replay::Player<fw::OmniFrame> player_;
};

}  // namespace

FW_REGISTER_PLUGIN(OmniPlugin, "omni", "0.1.0")
