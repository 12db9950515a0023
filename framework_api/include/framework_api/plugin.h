// Writing a plugin: derive from fw::Plugin, take a fw::PluginContext in the constructor (read all
// configuration there and throw on anything wrong), do one unit of work per step(), and register
// the class once with FW_REGISTER_PLUGIN in one .cpp of the plugin library:
//
//   class Console : public fw::Plugin {
//    public:
//     explicit Console(const fw::PluginContext& context);
//     fw::StepResult step() override;
//   };
//   FW_REGISTER_PLUGIN(Console, "console", "1.0.0")
//
// The macro exports the plugin's C descriptor (see plugin_abi.h) and catches every exception at
// the library boundary, turning it into an error message for the host.
#pragma once

#include <cstdio>
#include <exception>

#include "framework_api/config.h"
#include "framework_api/plugin_abi.h"
#include "framework_api/world_state.h"

namespace fw {

// What a plugin gets from the host: its own configuration block, the shared world state and the
// robot's whole merged configuration (for a plugin that records it, like the match log). All
// outlive the plugin.
struct PluginContext {
  ConfigView config;
  WorldState* world;
  const Config* robot_config;  // since API 1.1
};

enum class StepResult {
  kIdle = FW_STEP_IDLE,                 // nothing to do this time (no new data)
  kProcessed = FW_STEP_PROCESSED,       // one frame or cycle processed
  kEndOfStream = FW_STEP_END_OF_STREAM  // the plugin's source is exhausted; do not call again
};

class Plugin {
 public:
  virtual ~Plugin() = default;
  // One unit of work. A source-driven plugin may block waiting for data, but for at most about
  // 100 ms, so the host can stop it promptly. Throwing counts as an error; the host carries on.
  virtual StepResult step() = 0;
};

namespace detail {
inline void copyMessage(const char* message, char* buffer, std::size_t size) {
  if (buffer != nullptr && size > 0) std::snprintf(buffer, size, "%s", message);
}
}  // namespace detail

}  // namespace fw

// Defines the plugin's descriptor. PluginClass must be constructible from const fw::PluginContext&.
#define FW_REGISTER_PLUGIN(PluginClass, plugin_name, plugin_version)                                          \
  namespace {                                                                                                 \
  void* fwPluginCreate(const fw::PluginContext* context, char* error, std::size_t size) noexcept {            \
    try {                                                                                                     \
      return static_cast<fw::Plugin*>(new PluginClass(*context));                                             \
    } catch (const std::exception& e) {                                                                       \
      fw::detail::copyMessage(e.what(), error, size);                                                         \
    } catch (...) {                                                                                           \
      fw::detail::copyMessage("unknown exception", error, size);                                              \
    }                                                                                                         \
    return nullptr;                                                                                           \
  }                                                                                                           \
  void fwPluginDestroy(void* instance) noexcept { delete static_cast<fw::Plugin*>(instance); }                \
  int fwPluginStep(void* instance, char* error, std::size_t size) noexcept {                                  \
    try {                                                                                                     \
      return static_cast<int>(static_cast<fw::Plugin*>(instance)->step());                                    \
    } catch (const std::exception& e) {                                                                       \
      fw::detail::copyMessage(e.what(), error, size);                                                         \
    } catch (...) {                                                                                           \
      fw::detail::copyMessage("unknown exception", error, size);                                              \
    }                                                                                                         \
    return FW_STEP_ERROR;                                                                                     \
  }                                                                                                           \
  }                                                                                                           \
  extern "C" FW_PLUGIN_EXPORT const FwPluginDescriptor* fw_plugin_descriptor() {                              \
    static const FwPluginDescriptor descriptor = {FW_PLUGIN_API_MAJOR, FW_PLUGIN_API_MINOR, plugin_name,      \
                                                  plugin_version,      &fwPluginCreate,     &fwPluginDestroy, \
                                                  &fwPluginStep};                                             \
    return &descriptor;                                                                                       \
  }
