// A match log's database (kinect3d replay, export, report match and log:<folder> read it).
#include <cstddef>
#include <cstdint>
#include <exception>
#include <filesystem>

#include "fuzz_input_file.h"
#include "matchlog/match_log.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = fuzz::writeFile("match.sqlite", fuzz::asText(data, size));
  try {
    const fw::MatchLogReader log(std::filesystem::path(path).parent_path().string());
    log.entries();
    for (const auto& [source, count] : log.depthSources()) {
      fw::MatchLogReader::DepthFrames frames(log, source);
      fw::DepthImage image;
      double wall_time_s = 0.0;
      while (frames.next(image, wall_time_s)) {
      }
    }
  } catch (const fw::MatchLogError&) {
  }
  return 0;
}
