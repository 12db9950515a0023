// The binary contract between the host and a plugin library.
//
// A plugin library exports exactly one C symbol, fw_plugin_descriptor(), returning a pointer to a
// static descriptor. The host refuses a library whose api_major differs from its own or whose
// api_minor is newer than its own. Nothing else is looked up by name, nothing registers itself
// at load time, and no exception crosses this boundary: create and step report failures through
// the error buffer. Bump FW_PLUGIN_API_MINOR for additions that old plugins can ignore, and
// FW_PLUGIN_API_MAJOR for anything that changes the layout below or the types it points to.
#pragma once

#include <cstddef>
#include <cstdint>

#define FW_PLUGIN_API_MAJOR 5
#define FW_PLUGIN_API_MINOR 0

#define FW_PLUGIN_DESCRIPTOR_SYMBOL "fw_plugin_descriptor"
#define FW_PLUGIN_EXPORT __attribute__((visibility("default")))

// Return values of step().
#define FW_STEP_ERROR (-1)
#define FW_STEP_IDLE 0
#define FW_STEP_PROCESSED 1
#define FW_STEP_END_OF_STREAM 2

namespace fw {
struct PluginContext;
}

extern "C" {

struct FwPluginDescriptor {
  // Always the first two fields, in every API version, so any host can read them.
  std::uint32_t api_major;
  std::uint32_t api_minor;
  const char* name;     // the plugin's configuration block and its name in logs
  const char* version;  // the plugin's own version, for logs
  // Returns a new instance, or null with a message in error[0..error_size).
  void* (*create)(const fw::PluginContext* context, char* error, std::size_t error_size);
  void (*destroy)(void* instance);
  // One unit of work; returns an FW_STEP_* value, FW_STEP_ERROR with a message on failure.
  int (*step)(void* instance, char* error, std::size_t error_size);
};

typedef const FwPluginDescriptor* (*fw_plugin_descriptor_fn)();
}
