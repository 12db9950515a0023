// A well-formed plugin: each step processes one frame.
#include "framework_api/plugin.h"

namespace {
class Valid : public fw::Plugin {
 public:
  explicit Valid(const fw::PluginContext&) {}
  fw::StepResult step() override { return fw::StepResult::kProcessed; }
};
}  // namespace

FW_REGISTER_PLUGIN(Valid, "tp_valid", "0.1.0")
