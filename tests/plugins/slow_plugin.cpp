// Takes step_s over each step, as a logger committing a large batch to a slow disk does, then
// publishes a ball; writes `done_file` when it is destroyed. A stop whose grace is shorter than its
// step leaves it inside that step: the host must wait for it rather than free what the step still
// uses, and destroy it only once the step has ended.
#include <chrono>
#include <fstream>
#include <string>
#include <thread>

#include "framework_api/plugin.h"

namespace {
class Slow : public fw::Plugin {
 public:
  explicit Slow(const fw::PluginContext& context)
      : world_(*context.world),
        step_(std::chrono::duration<double>(context.config.getDouble("step_s", 0.0, 60.0))),
        started_file_(context.config.getString("started_file")),
        done_file_(context.config.getString("done_file")) {}
  ~Slow() override { std::ofstream(done_file_) << steps_ << "\n"; }

  fw::StepResult step() override {
    if (steps_ == 0) std::ofstream(started_file_) << "inside the first step\n";
    std::this_thread::sleep_for(step_);
    world_.publishBalls(
        {fw::BallObservation::inRobotFrame(Eigen::Vector3d(0.0, 2.0, 0.11), Eigen::Matrix3d::Identity() * 1e-4,
                                           fw::BallState::kGround, "tp_slow", fw::Stamp::now())});
    ++steps_;
    return fw::StepResult::kProcessed;
  }

 private:
  fw::WorldState& world_;
  const std::chrono::duration<double> step_;
  const std::string started_file_, done_file_;
  int steps_ = 0;
};
}  // namespace

FW_REGISTER_PLUGIN(Slow, "tp_slow", "0.1.0")
