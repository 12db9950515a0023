// The demo robot's run recorded by the logger, for the tests of what a team does with a match log.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "framework_api/host.h"
#include "run_host.h"

// Runs the demo robot (its lob, in real time: 3.5 s) with its log under folder; returns the host's
// summaries.
inline std::vector<fw::PluginSummary> runDemo(const std::string& folder, std::vector<std::string> overrides = {}) {
  overrides.insert(overrides.end(),
                   {"host.plugins=[localisation, kinect3d, omni, fusion, logger]", "logger.folder=" + folder});
  const fw::Config config = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults",
                                             std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml", overrides);
  fw::Host host(config, PRODUCT_PLUGIN_DIR);
  runUntilSourcesEnd(host);
  return host.summaries();
}

// The items of one kind (fw::Event, fw::BallFrame, ...) among a log's entries.
template <typename T>
std::vector<T> itemsOf(const std::vector<fw::JournalEntry>& entries) {
  std::vector<T> items;
  for (const fw::JournalEntry& entry : entries) {
    if (const T* item = std::get_if<T>(&entry.item)) items.push_back(*item);
  }
  return items;
}

// The one run folder the logger made under folder.
inline std::string onlySubfolder(const std::filesystem::path& folder) {
  std::vector<std::filesystem::path> runs;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    if (entry.is_directory()) runs.push_back(entry.path());
  }
  if (runs.size() != 1) throw std::runtime_error("expected one run folder in " + folder.string());
  return runs.front().string();
}
