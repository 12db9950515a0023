// What the Kinect v1 delivers in its own units, and the one conversion of each into the product's:
// 11-bit raw disparity into millimetres, its 60 MHz frame stamps into seconds, its accelerometer's
// counts into gravity in the sensor optical frame. Used by the freenect: and fakenect: sources, the
// NYU loader and the simulator's fakenect writer (docs/depth-sources.md, "Kinect v1").
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "kinect3d/depth_frame.h"

namespace kinect3d {

// The raw value meaning "no data".
constexpr std::uint16_t kRawDisparityInvalid = 2047;

// Disparity to depth. The Kinect's inverse depth is linear in its raw value:
//   1 / z_m = inverse_depth_at_zero_per_m + raw * inverse_depth_per_count_per_m.
// The default is the widely used fit to Kinect v1 units (NYU Depth v2's toolbox, OpenKinect's
// wiki); fromDeviceConstants gives the unit's own line from the constants libfreenect reads from
// the device.
struct DisparityModel {
  double inverse_depth_at_zero_per_m = 3.3309495161;
  double inverse_depth_per_count_per_m = -0.0030711016;

  // A unit's line from libfreenect's registration constants: the zero plane's distance (mm) and
  // pixel size (mm), the IR camera to projector distance (cm, as the device stores it) and the
  // constant shift (counts / 4).
  static DisparityModel fromDeviceConstants(double zero_plane_distance_mm, double zero_plane_pixel_size_mm,
                                            double emitter_distance_cm, double const_shift);

  // Metres from a raw value; 0 for no data or a value outside the line's range.
  double metres(std::uint16_t raw) const;
  // The raw value nearest a depth (the simulator writes recordings with it); kRawDisparityInvalid
  // for 0 (no data) or a depth the 11 bits cannot hold.
  std::uint16_t raw(double z_m) const;
};

// Raw disparity to millimetres through a table built once per model: a VGA frame is one lookup a pixel.
class DisparityTable {
 public:
  explicit DisparityTable(const DisparityModel& model = {});
  std::uint16_t millimetres(std::uint16_t raw) const { return raw < table_.size() ? table_[raw] : 0; }
  // raw: width * height uint16 values in the host's byte order, at any alignment (the upper five
  // bits ignored); frame.depth_mm must already have that size.
  void convert(const void* raw, DepthFrame& frame) const;

 private:
  std::array<std::uint16_t, 2048> table_{};
};

// The Kinect v1's frame stamps count a 60 MHz clock in 32 bits: they wrap every 71.6 s. Unwrapped
// here into seconds since the first stamp seen, and into a frame index (nominal 30 Hz) whose gaps
// are the frames the device or the USB bus dropped.
class KinectStampClock {
 public:
  static constexpr double kTicksPerSecond = 60e6;
  static constexpr double kTicksPerFrame = kTicksPerSecond / 30.0;

  struct Time {
    double seconds = 0.0;    // since the first stamp, without a jump at the wrap
    std::int64_t index = 0;  // frames of 1/30 s since the first stamp
  };
  // Each stamp is read as the nearest to the last one modulo 2^32: a wrap moves on by a tick, and a
  // colour stamp a little older than the depth stamp before it goes back a little.
  Time next(std::uint32_t stamp);
  void reset() { started_ = false; }

 private:
  bool started_ = false;
  std::uint32_t last_ = 0;
  std::int64_t ticks_ = 0;  // since the first stamp
};

// The accelerometer (a Kionix KXSD9 behind the tilt motor): 819 counts per g on each axis. Its axes
// are x to the sensor's left, y up, z forward (standing level it reads +1 g on y); it reads the
// support force, so gravity is the opposite of what it reads. Gravity, in m/s^2, in the sensor
// optical frame (x right, y down, z forward), from the three raw counts, and back.
constexpr double kAccelerometerCountsPerG = 819.0;
constexpr double kStandardGravity_mps2 = 9.80665;
Eigen::Vector3d gravityFromAccelerometer(std::int16_t x, std::int16_t y, std::int16_t z);
std::array<std::int16_t, 3> accelerometerFromGravity(const Eigen::Vector3d& gravity_S_mps2);

// Reads a 640x480 frame of raw disparity stored as a PGM with a "P5 W H 65535" header and
// little-endian samples (the layout of the NYU toolbox and of fakenect-record, which breaks PGM's
// big-endian rule), and converts it to millimetres. Throws DepthSourceError naming the file on any problem.
DepthFrame loadRawDisparityPgm(const std::string& path, const Intrinsics& intrinsics = {},
                               const DisparityTable& table = DisparityTable());

}  // namespace kinect3d
