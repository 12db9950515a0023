// Fuzz inputs as the product meets them: files. One scratch folder per fuzzing process, in memory
// when /dev/shm exists; each input overwrites the same files.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace fuzz {

inline const std::filesystem::path& scratchDir() {
  static const std::filesystem::path dir = [] {
    const std::filesystem::path base =
        std::filesystem::exists("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
    std::filesystem::path made = base / ("kinect3d_fuzz_" + std::to_string(getpid()));
    std::filesystem::create_directories(made);
    return made;
  }();
  return dir;
}

// Writes text to name in the scratch folder and returns the path.
inline std::string writeFile(const std::string& name, const std::string& text) {
  const std::filesystem::path path = scratchDir() / name;
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

inline std::string asText(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

}  // namespace fuzz
