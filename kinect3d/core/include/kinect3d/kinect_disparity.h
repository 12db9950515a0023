// The Kinect v1's raw 11-bit disparity, as libfreenect and datasets such as NYU Depth v2 store it.
#pragma once

#include <cstdint>
#include <string>

#include "kinect3d/depth_frame.h"

namespace kinect3d {

// The raw value meaning "no data".
constexpr std::uint16_t kRawDisparityInvalid = 2047;

// Metres from a raw disparity value with the widely used fit
// z = 1 / (raw * -0.0030711016 + 3.3309495161); 0 for no data or a value outside the fit's range.
double rawDisparityToMetres(std::uint16_t raw);

// Reads a 640x480 frame of raw disparity stored as a PGM with a "P5 W H 65535" header and
// little-endian samples (the NYU toolbox's layout, which breaks PGM's big-endian rule), and converts
// it to millimetres. Throws DepthSourceError naming the file on any problem.
DepthFrame loadRawDisparityPgm(const std::string& path, const Intrinsics& intrinsics = {});

}  // namespace kinect3d
