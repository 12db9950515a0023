// A plugin whose descriptor declares another API version: built twice, with
// TP_API_MAJOR_OFFSET=1 (wrong major) and with TP_API_MINOR_OFFSET=1 (newer minor).
#include "framework_api/plugin.h"

namespace {
void* create(const fw::PluginContext*, char*, std::size_t) noexcept { return nullptr; }
void destroy(void*) noexcept {}
int step(void*, char*, std::size_t) noexcept { return FW_STEP_IDLE; }
}  // namespace

extern "C" FW_PLUGIN_EXPORT const FwPluginDescriptor* fw_plugin_descriptor() {
  static const FwPluginDescriptor descriptor = {FW_PLUGIN_API_MAJOR + TP_API_MAJOR_OFFSET,
                                                FW_PLUGIN_API_MINOR + TP_API_MINOR_OFFSET,
                                                "tp_bad",
                                                "0.0.1",
                                                &create,
                                                &destroy,
                                                &step};
  return &descriptor;
}
