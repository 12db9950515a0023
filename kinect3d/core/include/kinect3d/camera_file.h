// camera.yaml: the cameras of a recorded folder (a TUM sequence, a fakenect recording), as
// `kinect3d simulate` writes it and a team writes it for its own recordings:
//   width, height, fx, fy, cx, cy     the depth camera (pixels)
//   depth_scale                       TUM only: image units per metre
//   rgb_width, rgb_height, rgb_fx, rgb_fy, rgb_cx, rgb_cy
//   rgb_offset_x_m, rgb_offset_y_m, rgb_offset_z_m
//                                     the colour camera, and its origin in the depth camera's
//                                     optical frame (same orientation); all or none of them
// Every key is optional; what is missing keeps the folder type's default.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "kinect3d/depth_frame.h"

namespace kinect3d {

struct ColourCamera {
  Intrinsics intrinsics{640, 480, 525.0, 525.0, 319.5, 239.5};
  Eigen::Vector3d offset_S_m = Eigen::Vector3d::Zero();

  // The Kinect v1's colour camera: VGA, the focal length OpenNI and TUM use, 2.5 cm to the right
  // of the depth camera (openni_launch's default transforms).
  static ColourCamera kinectV1();
  // A colour image from this camera: rgb is width * height * 3 bytes.
  fw::ColourImage image(std::vector<std::uint8_t> rgb, double source_time_s) const;
  // The camera that took an image.
  static ColourCamera of(const fw::ColourImage& image);
};

struct CameraFile {
  Intrinsics depth;
  double depth_scale = 5000.0;
  ColourCamera colour;
};

// Reads dir/camera.yaml over the defaults given; without the file, the defaults. allow_depth_scale:
// whether the folder type stores scaled depth (TUM) or not (fakenect). Throws DepthSourceError
// naming the file, line and key.
CameraFile readCameraFile(const std::string& dir, const CameraFile& defaults, bool allow_depth_scale);
// Writes dir/camera.yaml: the depth camera, depth_scale and the colour camera when given. Throws
// std::runtime_error naming the file.
void writeCameraFile(const std::string& dir, const Intrinsics& depth, const std::optional<ColourCamera>& colour,
                     std::optional<double> depth_scale);

// The pairing rule for a sensor's second stream (colour, accelerometer): of the times given in
// order, the index of the one nearest t (the earlier on a tie); times must not be empty.
std::size_t nearestInTime(const std::vector<double>& times_s, double t_s);

}  // namespace kinect3d
