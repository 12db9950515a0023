// Steps a few times, then blocks in a call that never returns and ignores every stop request, as
// a driver waiting for ever on a corrupt recording would. The host must report it and still stop.
#include <chrono>
#include <thread>

#include "framework_api/plugin.h"

namespace {
class Stuck : public fw::Plugin {
 public:
  explicit Stuck(const fw::PluginContext&) {}
  fw::StepResult step() override {
    if (++steps_ > 3) {
      for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    return fw::StepResult::kProcessed;
  }

 private:
  int steps_ = 0;
};
}  // namespace

FW_REGISTER_PLUGIN(Stuck, "tp_stuck", "0.1.0")
