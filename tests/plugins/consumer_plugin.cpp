// Reads the producer's newest ball from the world state and republishes it as the fused ball, and
// says on which thread it did (an event "stepped_on" naming the thread, when the journal is open).
#include <pthread.h>

#include "framework_api/plugin.h"

namespace {
class Consumer : public fw::Plugin {
 public:
  explicit Consumer(const fw::PluginContext& context) : world_(*context.world) {}

  fw::StepResult step() override {
    const auto balls = world_.recentBalls("tp_producer");
    if (balls.empty()) return fw::StepResult::kIdle;
    fw::FusedBall fused;
    fused.position_R = balls.front().position_m;
    fused.state = balls.front().state;
    fused.stamp = balls.front().stamp;
    fused.sources = {"tp_producer"};
    world_.publishFusedBall(fused);
    char thread[16] = "";
    pthread_getname_np(pthread_self(), thread, sizeof thread);
    world_.publishEvent({"tp_consumer", "stepped_on", thread, fused.stamp});
    return fw::StepResult::kProcessed;
  }

 private:
  fw::WorldState& world_;
};
}  // namespace

FW_REGISTER_PLUGIN(Consumer, "tp_consumer", "0.1.0")
