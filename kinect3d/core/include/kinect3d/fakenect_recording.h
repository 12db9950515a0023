// Folders recorded with libfreenect's fakenect-record (0.5.3), read and written without the library:
//   INDEX.txt            one file name per line, in playback order
//   <t>-<host s>-<stamp>.<ext>
//                        t: d depth, r colour, a accelerometer; host s: the recording host's clock
//                        ("%f"); stamp: the device's 60 MHz frame stamp ("%u")
//   d-*.pgm              "P5 640 480 65535\n" + 640x480 uint16 raw disparity, host byte order
//                        (little-endian, against PGM's rule); 2047 = no data
//   r-*.ppm              "P6 640 480 255\n" + 640x480 RGB
//   a-*.dump             libfreenect's raw tilt state, 12 bytes: int16 x, y, z (819 counts per g),
//                        int8 tilt (half degrees), a pad byte, int32 motor status
// The product may add camera.yaml (kinect3d/camera_file.h); fakenect itself ignores it.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace kinect3d {

constexpr int kFakenectWidth = 640;
constexpr int kFakenectHeight = 480;

struct FakenectEntry {
  char type = 'd';  // 'd', 'r' or 'a'
  double host_time_s = 0.0;
  std::uint32_t stamp = 0;
  std::string file;  // as INDEX.txt names it
  int line = 0;      // in INDEX.txt
};

// INDEX.txt of a folder; every listed file must exist (fakenect's library exits when one is
// missing). Throws DepthSourceError naming the folder, line and file.
std::vector<FakenectEntry> readFakenectIndex(const std::string& dir);

// The payloads (depth: loadRawDisparityPgm, kinect3d/kinect_disparity.h). Each throws
// DepthSourceError naming the file when it is not what its type says.
std::vector<std::uint8_t> readFakenectColour(const std::string& path);  // 640x480x3 RGB
std::array<std::int16_t, 3> readFakenectAccelerometer(const std::string& path);

// Writes a recording as fakenect-record does, file by file. Throws std::runtime_error naming the path.
class FakenectWriter {
 public:
  explicit FakenectWriter(std::string dir);
  void depth(double host_time_s, std::uint32_t stamp, const std::vector<std::uint16_t>& raw);
  void colour(double host_time_s, std::uint32_t stamp, const std::vector<std::uint8_t>& rgb);
  void accelerometer(double host_time_s, std::uint32_t stamp, const std::array<std::int16_t, 3>& counts);

 private:
  void write(char type, double host_time_s, std::uint32_t stamp, const char* extension, const std::string& header,
             const void* data, std::size_t bytes);
  std::string dir_;
};

}  // namespace kinect3d
