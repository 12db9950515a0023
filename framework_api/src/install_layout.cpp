#include "framework_api/install_layout.h"

#include <filesystem>

namespace fw {

namespace {
// The folder of the running executable.
std::string executableDir() {
  std::error_code error;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  return error ? std::string(".") : self.parent_path().string();
}
}  // namespace

// The sub-folders come from CMake (the top-level CMakeLists.txt), which also builds and installs there.
std::string defaultPluginDir() {
  return (std::filesystem::path(executableDir()) / ".." / KINECT3D_PLUGIN_SUBDIR).lexically_normal().string();
}

std::string defaultConfigDir() {
  return (std::filesystem::path(executableDir()) / ".." / KINECT3D_CONFIG_SUBDIR).lexically_normal().string();
}

}  // namespace fw
