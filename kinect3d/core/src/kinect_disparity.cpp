#include "kinect3d/kinect_disparity.h"

#include <cmath>
#include <fstream>

#include "kinect3d/depth_source.h"

namespace kinect3d {

double rawDisparityToMetres(std::uint16_t raw) {
  if (raw >= kRawDisparityInvalid) return 0.0;
  const double inverse_depth = raw * -0.0030711016 + 3.3309495161;
  return inverse_depth > 0.0 ? 1.0 / inverse_depth : 0.0;
}

DepthFrame loadRawDisparityPgm(const std::string& path, const Intrinsics& intrinsics) {
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
  DepthFrame frame;
  frame.resize(intrinsics);
  frame.sensor_id = path;
  for (std::uint16_t& depth : frame.depth_mm) {
    unsigned char bytes[2];
    if (!in.read(reinterpret_cast<char*>(bytes), 2)) {
      throw DepthSourceError(path + ": truncated pixel data");
    }
    const double z_m = rawDisparityToMetres(static_cast<std::uint16_t>(bytes[0] | bytes[1] << 8));
    depth = static_cast<std::uint16_t>(std::lround(z_m * 1000.0));
  }
  return frame;
}

}  // namespace kinect3d
