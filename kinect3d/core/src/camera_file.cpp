#include "kinect3d/camera_file.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "framework_api/config.h"
#include "kinect3d/config_io.h"
#include "kinect3d/depth_source.h"

namespace kinect3d {

namespace fs = std::filesystem;

ColourCamera ColourCamera::kinectV1() {
  ColourCamera camera;
  camera.offset_S_m = Eigen::Vector3d(0.025, 0.0, 0.0);
  return camera;
}

fw::ColourImage ColourCamera::image(std::vector<std::uint8_t> rgb, double source_time_s) const {
  fw::ColourImage image;
  image.width = intrinsics.width;
  image.height = intrinsics.height;
  image.fx = intrinsics.fx;
  image.fy = intrinsics.fy;
  image.cx = intrinsics.cx;
  image.cy = intrinsics.cy;
  image.offset_S_m = offset_S_m;
  image.rgb = std::move(rgb);
  image.source_time_s = source_time_s;
  return image;
}

ColourCamera ColourCamera::of(const fw::ColourImage& image) {
  return {Intrinsics{image.width, image.height, image.fx, image.fy, image.cx, image.cy}, image.offset_S_m};
}

CameraFile readCameraFile(const std::string& dir, const CameraFile& defaults, bool allow_depth_scale) {
  CameraFile camera = defaults;
  const fs::path file = fs::path(dir) / "camera.yaml";
  if (!fs::exists(file)) return camera;
  try {
    const fw::ConfigView root = fw::Config::loadDocument(file.string()).root();
    std::vector<std::string> keys = {"width",
                                     "height",
                                     "fx",
                                     "fy",
                                     "cx",
                                     "cy",
                                     "rgb_width",
                                     "rgb_height",
                                     "rgb_fx",
                                     "rgb_fy",
                                     "rgb_cx",
                                     "rgb_cy",
                                     "rgb_offset_x_m",
                                     "rgb_offset_y_m",
                                     "rgb_offset_z_m"};
    if (allow_depth_scale) keys.push_back("depth_scale");
    root.requireOnlyKeys(keys);
    if (root.has("width")) camera.depth = readIntrinsics(root);
    if (allow_depth_scale && root.has("depth_scale")) camera.depth_scale = root.getDouble("depth_scale", 1e-3, 1e7);
    if (root.has("rgb_width")) {
      camera.colour.intrinsics = readIntrinsics(root, "rgb_");
      camera.colour.offset_S_m = {root.getDouble("rgb_offset_x_m", -1.0, 1.0),
                                  root.getDouble("rgb_offset_y_m", -1.0, 1.0),
                                  root.getDouble("rgb_offset_z_m", -1.0, 1.0)};
    }
  } catch (const fw::ConfigError& e) {
    throw DepthSourceError(e.what());
  }
  return camera;
}

void writeCameraFile(const std::string& dir, const Intrinsics& depth, const std::optional<ColourCamera>& colour,
                     std::optional<double> depth_scale) {
  const std::string path = (fs::path(dir) / "camera.yaml").string();
  std::ofstream out(path);
  out.precision(10);
  out << "width: " << depth.width << "\nheight: " << depth.height << "\nfx: " << depth.fx << "\nfy: " << depth.fy
      << "\ncx: " << depth.cx << "\ncy: " << depth.cy << "\n";
  if (depth_scale) out << "depth_scale: " << *depth_scale << "\n";
  if (colour) {
    const Intrinsics& in = colour->intrinsics;
    out << "rgb_width: " << in.width << "\nrgb_height: " << in.height << "\nrgb_fx: " << in.fx << "\nrgb_fy: " << in.fy
        << "\nrgb_cx: " << in.cx << "\nrgb_cy: " << in.cy << "\nrgb_offset_x_m: " << colour->offset_S_m.x()
        << "\nrgb_offset_y_m: " << colour->offset_S_m.y() << "\nrgb_offset_z_m: " << colour->offset_S_m.z() << "\n";
  }
  if (!out) throw std::runtime_error("cannot write '" + path + "'");
}

std::size_t nearestInTime(const std::vector<double>& times_s, double t_s) {
  const auto after = std::lower_bound(times_s.begin(), times_s.end(), t_s);
  if (after == times_s.begin()) return 0;
  if (after == times_s.end()) return times_s.size() - 1;
  const auto before = after - 1;
  return static_cast<std::size_t>((t_s - *before <= *after - t_s ? before : after) - times_s.begin());
}

}  // namespace kinect3d
