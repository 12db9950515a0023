// One depth image as every source delivers it: OpenNI2's convention of uint16 millimetres along
// the optical axis, 0 = no data.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "framework_api/types.h"

namespace kinect3d {

// Pinhole intrinsics of the depth camera, in pixels.
struct Intrinsics {
  static constexpr int kMinSide_px = fw::DepthImage::kMinSide_px;
  static constexpr int kMaxSide_px = fw::DepthImage::kMaxSide_px;

  int width = 640;
  int height = 480;
  double fx = 575.8;  // OpenNI's Kinect v1 default; units spread about +-3 %
  double fy = 575.8;
  double cx = 319.5;
  double cy = 239.5;

  // From a horizontal and vertical field of view (as OpenNI2 streams report it).
  static Intrinsics fromFieldOfView(int width, int height, double hfov_rad, double vfov_rad);
  // The pixel a point in the sensor optical frame (x right, y down, z forward; z > 0) falls on.
  Eigen::Vector2d project(const Eigen::Vector3d& p_S) const {
    return {fx * p_S.x() / p_S.z() + cx, fy * p_S.y() / p_S.z() + cy};
  }
  // The point in the sensor optical frame seen at pixel (u, v) with depth z_m along the optical axis.
  Eigen::Vector3d backProject(double u, double v, double z_m) const {
    return {(u - cx) * z_m / fx, (v - cy) * z_m / fy, z_m};
  }
  bool operator==(const Intrinsics& other) const;
};

struct DepthFrame {
  Intrinsics intrinsics;
  std::vector<std::uint16_t> depth_mm;  // row-major, width * height
  double source_time_s = 0.0;           // the sensor's (or the recording's) clock
  double receive_time_s = 0.0;          // host wall clock when the frame arrived
  std::uint64_t index = 0;              // the source's frame counter; gaps are dropped frames
  std::string sensor_id;                // device URI, file or scene name
  // What else the sensor measured with this frame, where it can: gravity in the sensor optical
  // frame, m/s^2 (the Kinect v1's accelerometer), and the colour image nearest in time.
  std::optional<Eigen::Vector3d> gravity_S_mps2;
  std::optional<fw::ColourImage> colour;

  int width() const { return intrinsics.width; }
  int height() const { return intrinsics.height; }
  std::uint16_t at(int u, int v) const { return depth_mm[static_cast<std::size_t>(v) * width() + u]; }
  // Resizes depth_mm to match intrinsics and zeroes it; forgets gravity and colour: a new frame.
  void resize(const Intrinsics& new_intrinsics);
};

// The framework's depth image (what the world state journals and the match log keeps) holds the
// same data: the one conversion each way. The image's source (the plugin) becomes the frame's
// sensor_id and back.
DepthFrame fromDepthImage(fw::DepthImage image);
fw::DepthImage toDepthImage(const DepthFrame& frame, const std::string& source);

// Depth statistics used by `kinect3d info` and the tests.
struct DepthStats {
  double invalid_fraction = 0.0;
  double min_m = 0.0;  // over valid pixels; 0 when none is valid
  double max_m = 0.0;
};
DepthStats computeStats(const DepthFrame& frame);

}  // namespace kinect3d
