#include <gtest/gtest.h>

#include "framework_api/plugin_loader.h"

namespace {

std::string pluginPath(const std::string& name) { return std::string(TEST_PLUGIN_DIR) + "/" + name + ".so"; }

fw::Config emptyConfig() { return fw::Config::load(std::string(TEST_CONFIG_DIR) + "/defaults", "", {}); }
const fw::Config kEmptyConfig = emptyConfig();

// The message of the PluginLoadError that f throws; fails the test if it throws nothing.
template <typename F>
std::string loadError(F f) {
  try {
    f();
  } catch (const fw::PluginLoadError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a PluginLoadError";
  return "";
}

TEST(PluginLoader, LoadsValidPluginAndRunsIt) {
  const auto library = fw::PluginLibrary::open(pluginPath("tp_valid"));
  EXPECT_EQ(library->name(), "tp_valid");
  EXPECT_EQ(library->version(), "0.1.0");
  fw::WorldState world;
  auto instance = library->create({kEmptyConfig.block("tp_valid"), &world, &kEmptyConfig});
  EXPECT_EQ(instance->step(), fw::StepResult::kProcessed);
  EXPECT_EQ(instance->name(), "tp_valid");
}

TEST(PluginLoader, InstanceKeepsLibraryLoaded) {
  fw::WorldState world;
  std::unique_ptr<fw::PluginInstance> instance;
  {
    auto library = fw::PluginLibrary::open(pluginPath("tp_valid"));
    instance = library->create({kEmptyConfig.block("tp_valid"), &world, &kEmptyConfig});
  }
  // The library handle is gone; the instance's code must still be mapped.
  EXPECT_EQ(instance->step(), fw::StepResult::kProcessed);
}

TEST(PluginLoader, RefusesMajorMismatch) {
  const std::string error = loadError([] { fw::PluginLibrary::open(pluginPath("tp_wrong_major")); });
  EXPECT_NE(error.find("tp_wrong_major.so"), std::string::npos) << error;
  EXPECT_NE(error.find("built for plugin API " + std::to_string(FW_PLUGIN_API_MAJOR + 1) + "."), std::string::npos)
      << error;
  EXPECT_NE(error.find("major versions differ"), std::string::npos) << error;
}

TEST(PluginLoader, RefusesNewerMinor) {
  const std::string error = loadError([] { fw::PluginLibrary::open(pluginPath("tp_newer_minor")); });
  EXPECT_NE(error.find("needs plugin API " + std::to_string(FW_PLUGIN_API_MAJOR) + "." +
                       std::to_string(FW_PLUGIN_API_MINOR + 1)),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("newer than this host"), std::string::npos) << error;
}

TEST(PluginLoader, RefusesLibraryWithoutDescriptor) {
  const std::string error = loadError([] { fw::PluginLibrary::open(pluginPath("tp_missing_symbol")); });
  EXPECT_NE(error.find("is not a plugin"), std::string::npos) << error;
  EXPECT_NE(error.find("fw_plugin_descriptor"), std::string::npos) << error;
}

TEST(PluginLoader, ReportsMissingFile) {
  const std::string error = loadError([] { fw::PluginLibrary::open(pluginPath("tp_no_such_plugin")); });
  EXPECT_NE(error.find("cannot load plugin"), std::string::npos) << error;
  EXPECT_NE(error.find("tp_no_such_plugin.so"), std::string::npos) << error;
}

TEST(PluginLoader, ThrowingFactoryBecomesReadableError) {
  const auto library = fw::PluginLibrary::open(pluginPath("tp_throwing"));
  fw::WorldState world;
  const std::string error = loadError([&] { library->create({kEmptyConfig.block("host"), &world, &kEmptyConfig}); });
  EXPECT_NE(error.find("plugin 'tp_throwing'"), std::string::npos) << error;
  EXPECT_NE(error.find("failed to start: depth sensor /dev/tp0 not found"), std::string::npos) << error;
}

TEST(PluginLoader, ThrowingStepBecomesPluginError) {
  const auto library = fw::PluginLibrary::open(pluginPath("tp_faulty"));
  fw::WorldState world;
  auto instance = library->create({kEmptyConfig.block("tp_faulty"), &world, &kEmptyConfig});
  try {
    instance->step();
    FAIL() << "expected a PluginError";
  } catch (const fw::PluginError& e) {
    EXPECT_STREQ(e.what(), "frame checksum mismatch");
  }
}

}  // namespace
