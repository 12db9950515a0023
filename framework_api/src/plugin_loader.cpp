#include "framework_api/plugin_loader.h"

#include <dlfcn.h>

namespace fw {

namespace {
constexpr std::size_t kErrorBufferSize = 1024;

std::string apiVersion(std::uint32_t major, std::uint32_t minor) {
  return std::to_string(major) + "." + std::to_string(minor);
}
}  // namespace

std::shared_ptr<PluginLibrary> PluginLibrary::open(const std::string& path) {
  // RTLD_LOCAL keeps each plugin's symbols to itself, so two plugins can never bind to each
  // other's internals; RTLD_NOW reports unresolved symbols here rather than mid-match.
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* reason = dlerror();
    throw PluginLoadError("cannot load plugin '" + path + "': " + (reason ? reason : "unknown"));
  }
  dlerror();
  auto descriptor_fn = reinterpret_cast<fw_plugin_descriptor_fn>(dlsym(handle, FW_PLUGIN_DESCRIPTOR_SYMBOL));
  const FwPluginDescriptor* descriptor = descriptor_fn ? descriptor_fn() : nullptr;
  if (descriptor == nullptr) {
    dlclose(handle);
    throw PluginLoadError("'" + path + "' is not a plugin: it does not export " + FW_PLUGIN_DESCRIPTOR_SYMBOL +
                          "() (define one with FW_REGISTER_PLUGIN)");
  }
  const std::string host_api = apiVersion(FW_PLUGIN_API_MAJOR, FW_PLUGIN_API_MINOR);
  const std::string plugin_api = apiVersion(descriptor->api_major, descriptor->api_minor);
  if (descriptor->api_major != FW_PLUGIN_API_MAJOR) {
    dlclose(handle);
    throw PluginLoadError("plugin '" + path + "' was built for plugin API " + plugin_api +
                          " but this host provides API " + host_api +
                          " (major versions differ); rebuild the plugin against this framework");
  }
  if (descriptor->api_minor > FW_PLUGIN_API_MINOR) {
    dlclose(handle);
    throw PluginLoadError("plugin '" + path + "' needs plugin API " + plugin_api + ", newer than this host's API " +
                          host_api + "; update the host");
  }
  if (descriptor->name == nullptr || descriptor->create == nullptr || descriptor->destroy == nullptr ||
      descriptor->step == nullptr) {
    dlclose(handle);
    throw PluginLoadError("plugin '" + path + "' has an incomplete descriptor");
  }
  return std::shared_ptr<PluginLibrary>(new PluginLibrary(path, handle, descriptor));
}

PluginLibrary::PluginLibrary(std::string path, void* handle, const FwPluginDescriptor* descriptor)
    : path_(std::move(path)),
      handle_(handle),
      descriptor_(descriptor),
      name_(descriptor->name),
      version_(descriptor->version ? descriptor->version : "unknown") {}

PluginLibrary::~PluginLibrary() { dlclose(handle_); }

std::unique_ptr<PluginInstance> PluginLibrary::create(const PluginContext& context) const {
  char error[kErrorBufferSize] = "";
  void* instance = descriptor_->create(&context, error, sizeof error);
  if (instance == nullptr) {
    throw PluginLoadError("plugin '" + name_ + "' (" + path_ +
                          ") failed to start: " + (error[0] ? error : "no reason given"));
  }
  return std::unique_ptr<PluginInstance>(new PluginInstance(shared_from_this(), instance));
}

PluginInstance::PluginInstance(std::shared_ptr<const PluginLibrary> library, void* instance)
    : library_(std::move(library)), instance_(instance) {}

PluginInstance::~PluginInstance() { library_->descriptor_->destroy(instance_); }

StepResult PluginInstance::step() {
  char error[kErrorBufferSize] = "";
  const int result = library_->descriptor_->step(instance_, error, sizeof error);
  switch (result) {
    case FW_STEP_IDLE:
      return StepResult::kIdle;
    case FW_STEP_PROCESSED:
      return StepResult::kProcessed;
    case FW_STEP_END_OF_STREAM:
      return StepResult::kEndOfStream;
    case FW_STEP_ERROR:
      throw PluginError(error[0] ? error : "step failed without a message");
    default:
      throw PluginError("step returned unknown code " + std::to_string(result));
  }
}

const std::string& PluginInstance::name() const { return library_->name(); }
const std::string& PluginInstance::version() const { return library_->version(); }

}  // namespace fw
