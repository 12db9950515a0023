// Publishes a ball at the configured position for `frames` steps, then reports end of stream.
#include <chrono>
#include <thread>

#include "framework_api/plugin.h"

namespace {
class Producer : public fw::Plugin {
 public:
  explicit Producer(const fw::PluginContext& context)
      : world_(*context.world),
        position_(context.config.getDouble("x_m", -10, 10), context.config.getDouble("y_m", -10, 10),
                  context.config.getDouble("z_m", 0, 10)),
        frames_(context.config.getInt("frames", 0, 1000000)) {}

  fw::StepResult step() override {
    if (produced_ >= frames_) return fw::StepResult::kEndOfStream;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));  // a 200 Hz "sensor"
    world_.publishBalls({fw::BallObservation::inRobotFrame(position_, Eigen::Matrix3d::Identity() * 1e-4,
                                                           fw::BallState::kAir, "tp_producer", fw::Stamp::now())});
    ++produced_;
    return fw::StepResult::kProcessed;
  }

 private:
  fw::WorldState& world_;
  const Eigen::Vector3d position_;
  const int frames_;
  int produced_ = 0;
};
}  // namespace

FW_REGISTER_PLUGIN(Producer, "tp_producer", "0.1.0")
