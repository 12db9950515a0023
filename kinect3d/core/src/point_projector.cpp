#include "kinect3d/point_projector.h"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace kinect3d {

PointProjector::PointProjector(const Config& config, const Intrinsics& intrinsics)
    : config_(config), intrinsics_(intrinsics) {
  const DepthNoiseModel noise{intrinsics.fx, config_.baseline_m};
  tolerance_per_m2_ = static_cast<float>(config_.edge_tolerance_steps * noise.quantisationStep_m(1.0));
  min_mm_ = static_cast<float>(config_.min_range_m * 1000.0);
  max_mm_ = static_cast<float>(config_.max_range_m * 1000.0);
  column_x_.resize(intrinsics.width);
  for (int u = 0; u < intrinsics.width; ++u) column_x_[u] = static_cast<float>((u - intrinsics.cx) / intrinsics.fx);
  row_y_.resize(intrinsics.height);
  for (int v = 0; v < intrinsics.height; ++v) row_y_[v] = static_cast<float>((v - intrinsics.cy) / intrinsics.fy);
}

void PointProjector::project(const DepthFrame& frame, const Eigen::Isometry3f& T_R_S, PointSet& out) const {
  if (!(frame.intrinsics == intrinsics_)) {
    throw std::invalid_argument("PointProjector: frame " + std::to_string(frame.index) + " of " + frame.sensor_id +
                                " has other intrinsics than the projector was made for");
  }
  const int width = frame.width(), height = frame.height(), stride = config_.pixel_stride;
  const Eigen::Matrix3f R = T_R_S.linear();
  const Eigen::Vector3f t = T_R_S.translation();
  const float floor_margin = static_cast<float>(config_.floor_margin_m);
  // Sample rows and columns offset by half a stride so the grid is centred in the image; border
  // pixels are never surface pixels (isSurface), so the first and last row and column are skipped.
  const int first = std::max(stride / 2, 1);
  // No branch that noise makes unpredictable (most of the frame's time went to mispredicted
  // branches). The largest count is reserved once, so a warm projector allocates nothing.
  out.resize(static_cast<std::size_t>((height - 1 - first + stride - 1) / stride + 1) *
             ((width - 1 - first + stride - 1) / stride + 1));
  std::size_t kept = 0;
  // isSurface per sample of the row, one after another: flags a stride apart in memory were stored
  // a byte at a time, which took about a third of the projection's time.
  std::array<std::uint8_t, Intrinsics::kMaxSide_px> surface;
  for (int v = first; v < height - 1; v += stride) {
    const std::uint16_t* d = &frame.depth_mm[static_cast<std::size_t>(v) * width];
    const std::uint16_t* above = d - width;
    const std::uint16_t* below = d + width;
    // isSurface for the row's samples, written without branches. With the stride known when
    // compiled (the default 2) the compiler vectorises the strided loads; other strides may run scalar.
    const auto surfaceRow = [&](auto sample_step) {
      for (int u = first, sample = 0; u < width - 1; u += sample_step, ++sample) {
        const float z_mm = d[u], left = d[u - 1], right = d[u + 1], up = above[u], down = below[u];
        const float step = std::max(std::max(std::abs(left - z_mm), std::abs(right - z_mm)),
                                    std::max(std::abs(up - z_mm), std::abs(down - z_mm)));
        surface[sample] = (z_mm >= min_mm_) & (z_mm <= max_mm_) & (left > 0.0f) & (right > 0.0f) & (up > 0.0f) &
                          (down > 0.0f) & (step <= toleranceAt_mm(z_mm));
      }
    };
    if (stride == 2) {
      surfaceRow(std::integral_constant<int, 2>());
    } else {
      surfaceRow(stride);
    }
    // The point is t + z R (x, y, 1) for the pixel's normalised coordinates: R (0, y, 1) once per row.
    // Every sample is written and the count moves on only for the kept ones.
    const Eigen::Vector3f row_R = R.col(1) * row_y_[v] + R.col(2);
    for (int u = first, sample = 0; u < width - 1; u += stride, ++sample) {
      const Eigen::Vector3f p_R = t + (d[u] * 0.001f) * (row_R + R.col(0) * column_x_[u]);
      out[kept] = p_R;
      kept += surface[sample] & (p_R.z() >= floor_margin);
    }
  }
  out.resize(kept);
}

}  // namespace kinect3d
