// Loads plugin libraries and creates their instances. The library stays loaded while any
// instance created from it lives.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>

#include "framework_api/plugin.h"

namespace fw {

class PluginLoadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class PluginError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class PluginLibrary;

// One live plugin object. Destroying it destroys the object, then releases the library.
class PluginInstance {
 public:
  ~PluginInstance();
  PluginInstance(const PluginInstance&) = delete;
  PluginInstance& operator=(const PluginInstance&) = delete;

  // Throws PluginError with the plugin's message when its step fails.
  StepResult step();
  const std::string& name() const;
  const std::string& version() const;

 private:
  friend class PluginLibrary;
  PluginInstance(std::shared_ptr<const PluginLibrary> library, void* instance);
  std::shared_ptr<const PluginLibrary> library_;
  void* instance_;
};

class PluginLibrary : public std::enable_shared_from_this<PluginLibrary> {
 public:
  // Opens the library and checks its descriptor. Throws PluginLoadError naming the path and the
  // problem: cannot open, missing descriptor, API major mismatch, newer minor.
  static std::shared_ptr<PluginLibrary> open(const std::string& path);
  ~PluginLibrary();
  PluginLibrary(const PluginLibrary&) = delete;
  PluginLibrary& operator=(const PluginLibrary&) = delete;

  // Throws PluginLoadError with the plugin's own message when its constructor fails.
  std::unique_ptr<PluginInstance> create(const PluginContext& context) const;

  const std::string& name() const { return name_; }
  const std::string& version() const { return version_; }
  const std::string& path() const { return path_; }

 private:
  friend class PluginInstance;
  PluginLibrary(std::string path, void* handle, const FwPluginDescriptor* descriptor);
  std::string path_;
  void* handle_;
  const FwPluginDescriptor* descriptor_;
  std::string name_;
  std::string version_;
};

}  // namespace fw
