// A shared library that is not a plugin: it exports a function, but no descriptor.
#include "framework_api/plugin_abi.h"

extern "C" FW_PLUGIN_EXPORT int tp_not_a_descriptor() { return 42; }
