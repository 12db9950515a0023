// localisation: the robot's pose in the field into the world state, from the simulator
// (sim:<scene>, the scene's robot path with the slow, correlated error of self-localisation) or
// from a file (file:<path>, JSON lines, docs/fusion.md), played at its own pace when realtime.
#include <chrono>

#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "fusion/json_lines.h"
#include "kinect3d/sim/field_sensors.h"
#include "replay.h"

namespace {

std::vector<fw::RobotPose> simulate(const fw::ConfigView& sim, const std::string& scene, double world_start_wall_s) {
  kinect3d::sim::LocalisationModel model;
  model.rate_hz = sim.getDouble("rate_hz", 1.0, 1000.0);
  model.sigma_xy_m = sim.getDouble("sigma_xy_m", 0.0, 5.0);
  model.sigma_theta_rad = fw::degreesToRadians(sim.getDouble("sigma_theta_deg", 0.0, 90.0));
  model.bias_xy_m = {sim.getDouble("bias_x_m", -20.0, 20.0), sim.getDouble("bias_y_m", -20.0, 20.0)};
  model.bias_theta_rad = fw::degreesToRadians(sim.getDouble("bias_theta_deg", -180.0, 180.0));
  model.odometry = sim.getBool("odometry");
  model.odometry_error = sim.getDouble("odometry_error", 0.0, 0.5);
  model.stamp_late_s = sim.getDouble("stamp_late_s", 0.0, 1.0);
  model.seed = static_cast<std::uint64_t>(sim.getInt("seed", 0, 2147483647));
  const kinect3d::sim::LocalisationSimulator localisation(
      kinect3d::sim::inSharedWorld(kinect3d::sim::loadScene(scene), world_start_wall_s), model);
  std::vector<fw::RobotPose> poses;
  for (int i = 0; i < localisation.frameCount(); ++i) poses.push_back(localisation.pose(i));
  return poses;
}

class LocalisationPlugin : public fw::Plugin {
 public:
  explicit LocalisationPlugin(const fw::PluginContext& context)
      : world_(*context.world),
        name_(context.config.path()),
        player_(name_,
                replay::load<fw::RobotPose>(
                    context.config,
                    [&](const std::string& scene) {
                      return simulate(context.config.child("sim"), scene, replay::simWorldStart(context));
                    },
                    fusion::readPoseFile),
                replay::clockFor(context), [](const fw::RobotPose& pose) { return pose.stamp.source_time_s; }) {
    fw::logInfo(context.config.path(),
                "playing " + std::to_string(player_.size()) + " poses from " + context.config.getString("source"));
  }

  fw::StepResult step() override {
    if (player_.finished()) return fw::StepResult::kEndOfStream;
    std::optional<fw::RobotPose> pose = player_.next();
    if (!pose) return fw::StepResult::kIdle;
    const auto started = std::chrono::steady_clock::now();  // its processing, not its wait for the moment
    pose->stamp.receive_time_s = fw::wallClockNow_s();
    world_.publishRobotPose(*pose);
    world_.reportProcessingTime(name_,
                                std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
    return fw::StepResult::kProcessed;
  }

 private:
  fw::WorldState& world_;
  const std::string name_;
  replay::Player<fw::RobotPose> player_;
};

}  // namespace

FW_REGISTER_PLUGIN(LocalisationPlugin, "localisation", "0.1.0")
