// Every step throws: the host must count the errors and keep the other plugins running.
#include <chrono>
#include <stdexcept>
#include <thread>

#include "framework_api/plugin.h"

namespace {
class Faulty : public fw::Plugin {
 public:
  explicit Faulty(const fw::PluginContext&) {}
  fw::StepResult step() override {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    throw std::runtime_error("frame checksum mismatch");
  }
};
}  // namespace

FW_REGISTER_PLUGIN(Faulty, "tp_faulty", "0.1.0")
