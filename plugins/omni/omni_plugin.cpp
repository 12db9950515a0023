// omni: the omni camera's balls (bearing and distance on the floor) into the world state, from the
// simulator (sim:<scene>, the ball's ground projection with the camera's noise, latency, misses,
// occlusions and orange false balls) or from a file (file:<path>, JSON lines, docs/fusion.md),
// played at their own pace when realtime.
#include <string>
#include <vector>

#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "framework_api/replay_clock.h"
#include "fusion/json_lines.h"
#include "kinect3d/sim/field_sensors.h"

namespace {

class OmniPlugin : public fw::Plugin {
 public:
  explicit OmniPlugin(const fw::PluginContext& context)
      : world_(*context.world), clock_(context.config.getBool("realtime")) {
    const std::string source = context.config.getString("source");
    const std::string name = context.config.path();
    try {
      if (source.rfind("sim:", 0) == 0) {
        const fw::ConfigView sim = context.config.child("sim");
        kinect3d::sim::OmniCameraModel model;
        model.stamp_late_s = sim.getDouble("stamp_late_s", 0.0, 1.0);
        model.viewpoint_height_m = sim.getDouble("viewpoint_height_m", 0.2, 3.0);
        model.max_height_m = sim.getDouble("max_height_m", 0.0, 3.0);
        model.miss_probability = sim.getDouble("miss_probability", 0.0, 1.0);
        model.false_rate_hz = sim.getDouble("false_rate_hz", 0.0, 100.0);
        model.seed = static_cast<std::uint64_t>(sim.getInt("seed", 0, 2147483647));
        const kinect3d::sim::OmniCameraSimulator camera(kinect3d::sim::loadScene(source.substr(4)), model);
        for (int i = 0; i < camera.frameCount(); ++i) frames_.push_back(camera.frame(i));
      } else if (source.rfind("file:", 0) == 0) {
        frames_ = fusion::readOmniFile(source.substr(5), name);
      } else {
        throw std::runtime_error("expected sim:<scene> or file:<path>");
      }
    } catch (const std::runtime_error& e) {
      throw fw::ConfigError(context.config.originOf("source") + ": " + name + ".source = '" + source +
                            "': " + e.what());
    }
    for (fw::OmniFrame& frame : frames_) {
      for (fw::OmniBallObservation& ball : frame.balls) ball.source = name;
    }
    fw::logInfo(name, "playing " + std::to_string(frames_.size()) + " omni images from " + source);
  }

  fw::StepResult step() override {
    if (next_ >= frames_.size()) return fw::StepResult::kEndOfStream;
    fw::OmniFrame frame = frames_[next_];
    if (!clock_.waitFor(frame.stamp.source_time_s)) return fw::StepResult::kIdle;
    ++next_;
    frame.stamp.receive_time_s = fw::wallClockNow_s();
    for (fw::OmniBallObservation& ball : frame.balls) ball.stamp = frame.stamp;
    world_.publishOmniFrame(frame);
    return fw::StepResult::kProcessed;
  }

 private:
  fw::WorldState& world_;
  fw::ReplayClock clock_;
  std::vector<fw::OmniFrame> frames_;
  std::size_t next_ = 0;
};

}  // namespace

FW_REGISTER_PLUGIN(OmniPlugin, "omni", "0.1.0")
