#include "kinect3d/point_projector.h"

#include <stdexcept>
#include <string>

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
  out.clear();
  const Eigen::Matrix3f R = T_R_S.linear();
  const Eigen::Vector3f t = T_R_S.translation();
  const float floor_margin = static_cast<float>(config_.floor_margin_m);
  const int stride = config_.pixel_stride;
  // Sample rows and columns offset by half a stride so the grid is centred in the image. The
  // point is t + z R (x, y, 1) for the pixel's normalised coordinates: R (0, y, 1) once per row.
  for (int v = stride / 2; v < frame.height(); v += stride) {
    const Eigen::Vector3f row_R = R.col(1) * row_y_[v] + R.col(2);
    for (int u = stride / 2; u < frame.width(); u += stride) {
      if (!isSurface(frame, u, v)) continue;
      const float z = frame.depth_mm[static_cast<std::size_t>(v) * frame.width() + u] * 0.001f;
      const Eigen::Vector3f p_R = t + z * (row_R + R.col(0) * column_x_[u]);
      if (p_R.z() < floor_margin) continue;
      out.push_back(p_R);
    }
  }
}

}  // namespace kinect3d
