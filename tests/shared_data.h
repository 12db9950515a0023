// The real frames the project has no right to carry: public datasets and peers' test data kept in
// ../shared/data beside the repository (CI has it there; each folder's README gives the origin and
// the licence). Tests that need one skip, saying where it comes from, when it is not there.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

// The path of ../shared/data/<relative> if it is there.
inline std::optional<std::string> sharedDataFile(const std::string& relative) {
  const std::filesystem::path path = std::filesystem::path(SHARED_DATA_DIR) / relative;
  if (!std::filesystem::exists(path)) return std::nullopt;
  return path.string();
}

// Why a test that needs it did not run.
inline std::string noSharedData(const std::string& relative) {
  return std::string(SHARED_DATA_DIR) + "/" + relative +
         " is not here: the real frames are third-party data (see the README of their folder) kept beside the "
         "repository, as CI has them, never in it";
}
