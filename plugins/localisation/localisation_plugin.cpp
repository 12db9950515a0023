// localisation: the robot's pose in the field into the world state, from the simulator
// (sim:<scene>, the scene's robot path with the slow, correlated error of self-localisation) or
// from a file (file:<path>, JSON lines, docs/fusion.md), played at its own pace when realtime.
#include <string>
#include <vector>

#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "framework_api/replay_clock.h"
#include "fusion/json_lines.h"
#include "kinect3d/sim/field_sensors.h"

namespace {

class LocalisationPlugin : public fw::Plugin {
 public:
  explicit LocalisationPlugin(const fw::PluginContext& context)
      : world_(*context.world), clock_(context.config.getBool("realtime")) {
    const std::string source = context.config.getString("source");
    const std::string name = context.config.path();
    try {
      if (source.rfind("sim:", 0) == 0) {
        const fw::ConfigView sim = context.config.child("sim");
        kinect3d::sim::LocalisationModel model;
        model.rate_hz = sim.getDouble("rate_hz", 1.0, 1000.0);
        model.sigma_xy_m = sim.getDouble("sigma_xy_m", 0.0, 5.0);
        model.sigma_theta_rad = fw::degreesToRadians(sim.getDouble("sigma_theta_deg", 0.0, 90.0));
        model.seed = static_cast<std::uint64_t>(sim.getInt("seed", 0, 2147483647));
        const kinect3d::sim::LocalisationSimulator localisation(kinect3d::sim::loadScene(source.substr(4)), model);
        for (int i = 0; i < localisation.frameCount(); ++i) poses_.push_back(localisation.pose(i));
      } else if (source.rfind("file:", 0) == 0) {
        poses_ = fusion::readPoseFile(source.substr(5));
      } else {
        throw std::runtime_error("expected sim:<scene> or file:<path>");
      }
    } catch (const std::runtime_error& e) {
      throw fw::ConfigError(context.config.originOf("source") + ": " + name + ".source = '" + source +
                            "': " + e.what());
    }
    fw::logInfo(name, "playing " + std::to_string(poses_.size()) + " poses from " + source);
  }

  fw::StepResult step() override {
    if (next_ >= poses_.size()) return fw::StepResult::kEndOfStream;
    fw::RobotPose pose = poses_[next_];
    if (!clock_.waitFor(pose.stamp.source_time_s)) return fw::StepResult::kIdle;
    ++next_;
    pose.stamp.receive_time_s = fw::wallClockNow_s();
    world_.publishRobotPose(pose);
    return fw::StepResult::kProcessed;
  }

 private:
  fw::WorldState& world_;
  fw::ReplayClock clock_;
  std::vector<fw::RobotPose> poses_;
  std::size_t next_ = 0;
};

}  // namespace

FW_REGISTER_PLUGIN(LocalisationPlugin, "localisation", "0.1.0")
