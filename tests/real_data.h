// The real frames the project has no right to carry: public datasets and peers' test data, each
// folder with a README giving its origin and licence. The tests read them from the folder the
// environment variable KINECT3D_REAL_DATA names (CI's entry point, .ci/run, sets it); a test that
// needs one skips, saying where it comes from, when it is not there.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

// $KINECT3D_REAL_DATA/<relative> if the variable is set and the file is there.
inline std::optional<std::string> realDataFile(const std::string& relative) {
  const char* folder = std::getenv("KINECT3D_REAL_DATA");
  if (folder == nullptr || *folder == '\0') return std::nullopt;
  const std::filesystem::path path = std::filesystem::path(folder) / relative;
  if (!std::filesystem::exists(path)) return std::nullopt;
  return path.string();
}

// Why a test that needs it did not run.
inline std::string noRealData(const std::string& relative) {
  const char* folder = std::getenv("KINECT3D_REAL_DATA");
  const std::string where = folder == nullptr || *folder == '\0'
                                ? std::string("KINECT3D_REAL_DATA is not set")
                                : "$KINECT3D_REAL_DATA/" + relative + " (" + folder + ") is not there";
  return where + ": this test needs " + relative +
         ", real third-party frames (see the README of their folder) that the project never carries; set "
         "KINECT3D_REAL_DATA to the folder holding real-depth/ and realdata/ to run it";
}
