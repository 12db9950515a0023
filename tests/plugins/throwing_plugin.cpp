// A plugin whose constructor throws, like a driver that cannot find its sensor.
#include <stdexcept>

#include "framework_api/plugin.h"

namespace {
class Throwing : public fw::Plugin {
 public:
  explicit Throwing(const fw::PluginContext&) { throw std::runtime_error("depth sensor /dev/tp0 not found"); }
  fw::StepResult step() override { return fw::StepResult::kIdle; }
};
}  // namespace

FW_REGISTER_PLUGIN(Throwing, "tp_throwing", "0.1.0")
