#include "kinect3d/kinect_disparity.h"

#include <cmath>
#include <cstring>
#include <fstream>

#include "kinect3d/depth_source.h"

namespace kinect3d {

DisparityModel DisparityModel::fromDeviceConstants(double zero_plane_distance_mm, double zero_plane_pixel_size_mm,
                                                   double emitter_distance_cm, double const_shift) {
  // libfreenect's depth: z_mm = 10 d b / (b - s (raw / 4 - const_shift - 0.375)), with d the zero
  // plane's distance, s its pixel size and b the emitter distance as the device stores them; its
  // inverse is the line below.
  const double d = zero_plane_distance_mm, s = zero_plane_pixel_size_mm, b = emitter_distance_cm;
  DisparityModel model;
  model.inverse_depth_at_zero_per_m = 100.0 / d * (1.0 + s * (const_shift + 0.375) / b);
  model.inverse_depth_per_count_per_m = -100.0 * s / (4.0 * d * b);
  return model;
}

double DisparityModel::metres(std::uint16_t raw) const {
  if (raw >= kRawDisparityInvalid) return 0.0;
  const double inverse_depth = inverse_depth_at_zero_per_m + raw * inverse_depth_per_count_per_m;
  return inverse_depth > 0.0 ? 1.0 / inverse_depth : 0.0;
}

std::uint16_t DisparityModel::raw(double z_m) const {
  if (!(z_m > 0.0)) return kRawDisparityInvalid;
  const double value = std::round((1.0 / z_m - inverse_depth_at_zero_per_m) / inverse_depth_per_count_per_m);
  return value >= 0.0 && value < kRawDisparityInvalid ? static_cast<std::uint16_t>(value) : kRawDisparityInvalid;
}

DisparityTable::DisparityTable(const DisparityModel& model) {
  for (std::size_t raw = 0; raw < table_.size(); ++raw) {
    const long mm = std::lround(model.metres(static_cast<std::uint16_t>(raw)) * 1000.0);
    table_[raw] = static_cast<std::uint16_t>(mm > 0 && mm <= 65535 ? mm : 0);
  }
}

void DisparityTable::convert(const void* raw, DepthFrame& frame) const {
  // Read sample by sample with memcpy: fakenect hands out its buffer right after the PGM header,
  // at an odd address.
  const auto* bytes = static_cast<const unsigned char*>(raw);
  for (std::size_t i = 0; i < frame.depth_mm.size(); ++i) {
    std::uint16_t value;
    std::memcpy(&value, bytes + 2 * i, sizeof value);
    frame.depth_mm[i] = table_[value & 0x7FF];
  }
}

KinectStampClock::Time KinectStampClock::next(std::uint32_t stamp) {
  if (!started_) {
    started_ = true;
    ticks_ = 0;
  } else {
    // The difference modulo 2^32, read as signed: from 2^32 - 1 to 0 is one tick, not minus four billion.
    ticks_ += static_cast<std::int32_t>(stamp - last_);
  }
  last_ = stamp;
  return {static_cast<double>(ticks_) / kTicksPerSecond, std::llround(static_cast<double>(ticks_) / kTicksPerFrame)};
}

Eigen::Vector3d gravityFromAccelerometer(std::int16_t x, std::int16_t y, std::int16_t z) {
  // Read support force in the accelerometer's axes (left, up, forward) -> gravity in the optical
  // frame (right, down, forward): x and y keep their sign (two flips each), z changes it.
  const double scale = kStandardGravity_mps2 / kAccelerometerCountsPerG;
  return Eigen::Vector3d(x, y, -z) * scale;
}

std::array<std::int16_t, 3> accelerometerFromGravity(const Eigen::Vector3d& gravity_S_mps2) {
  const Eigen::Vector3d counts = gravity_S_mps2 * (kAccelerometerCountsPerG / kStandardGravity_mps2);
  const auto count = [](double value) { return static_cast<std::int16_t>(std::lround(value)); };
  return {count(counts.x()), count(counts.y()), count(-counts.z())};
}

DepthFrame loadRawDisparityPgm(const std::string& path, const Intrinsics& intrinsics, const DisparityTable& table) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DepthSourceError("cannot open raw disparity file '" + path + "'");
  std::string magic;
  int width = 0, height = 0, max_value = 0;
  in >> magic >> width >> height >> max_value;
  in.get();  // the single whitespace byte that ends a PGM header
  if (!in || magic != "P5" || max_value != 65535) {
    throw DepthSourceError(path + ": not a 16-bit binary PGM (expected header 'P5 W H 65535')");
  }
  if (width != intrinsics.width || height != intrinsics.height) {
    throw DepthSourceError(path + ": image is " + std::to_string(width) + "x" + std::to_string(height) + ", expected " +
                           std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height));
  }
  std::vector<std::uint16_t> raw(static_cast<std::size_t>(width) * height);
  // Little-endian on disk, the host's order on every machine the product runs on (x86-64, arm64).
  if (!in.read(reinterpret_cast<char*>(raw.data()), static_cast<std::streamsize>(raw.size() * 2))) {
    throw DepthSourceError(path + ": truncated pixel data (" + std::to_string(in.gcount()) + " of " +
                           std::to_string(raw.size() * 2) + " bytes)");
  }
  DepthFrame frame;
  frame.resize(intrinsics);
  frame.sensor_id = path;
  table.convert(raw.data(), frame);
  return frame;
}

}  // namespace kinect3d
