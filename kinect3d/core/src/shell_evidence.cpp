#include "kinect3d/shell_evidence.h"

#include <algorithm>
#include <cmath>

namespace kinect3d {

ShellEvidence::ShellEvidence(const Intrinsics& intrinsics, int shell_voxels, const PointProjector::Config& points)
    : intrinsics_(intrinsics),
      shell_(shell_voxels),
      max_range_m_(static_cast<float>(points.max_range_m)),
      noise_{intrinsics.fx, points.baseline_m},
      fb_(static_cast<float>(intrinsics.fx * points.baseline_m)),
      max_shadow_px_(static_cast<int>(std::ceil(intrinsics.fx * points.baseline_m / points.min_range_m))) {}

float ShellEvidence::sureReturn_m(const SensorCoverage& coverage) const {
  // Near the range limit a surface's depth is one quantisation step either side of it.
  const float range_m = std::min(max_range_m_, static_cast<float>(coverage.farthestReturn_m()));
  return range_m - static_cast<float>(noise_.quantisationStep_m(range_m));
}

bool ShellEvidence::inShadow(const DepthFrame& frame, int u, int v, float far_m) const {
  // Pixel u is dark when a point at u + k with disparity d1 reaches the projector's column first:
  // k < d1 - fb / far_m for a surface at far_m.
  const float lit_disparity = fb_ / far_m;
  const std::uint16_t* row = &frame.depth_mm[static_cast<std::size_t>(v) * frame.width()];
  for (int k = 1; k <= max_shadow_px_ && u + k < frame.width(); ++k) {
    const std::uint16_t d_mm = row[u + k];
    if (d_mm != 0 && float(k) < fb_ / (d_mm * 1e-3f) - lit_disparity) return true;
  }
  return false;
}

ShellEvidence::Ray ShellEvidence::classify(const DepthFrame& frame, const SensorCoverage& coverage, int u, int v,
                                           float near_m, float far_m) const {
  if (!coverage.inView(u, v)) return Ray::kHidden;
  const std::uint16_t d_mm = frame.at(u, v);
  if (d_mm != 0) {
    const float d_m = d_mm * 1e-3f;
    if (d_m > far_m) return Ray::kEmpty;
    if (d_m < near_m) return Ray::kHidden;
    return Ray::kSurface;  // something within the voxel, too little of it for the grid
  }
  if (far_m > sureReturn_m(coverage)) return Ray::kUnknown;
  return inShadow(frame, u, v, far_m) ? Ray::kHidden : Ray::kEmpty;
}

bool ShellEvidence::shellObserved(const BallCandidate& candidate, const OccupancyGrid& grid, const DepthFrame& frame,
                                  const SensorCoverage& coverage, const Eigen::Isometry3f& T_S_R) const {
  const float voxel = static_cast<float>(grid.voxel_m());
  const float half_depth = 0.5f * std::sqrt(3.0f) * voxel;  // half the cube's extent along any ray
  // Five rays per voxel: through its centre and a quarter voxel to each side across the view.
  const float q = 0.25f * voxel;
  const Eigen::Vector3f offsets_S[] = {{0, 0, 0}, {q, 0, 0}, {-q, 0, 0}, {0, q, 0}, {0, -q, 0}};
  for (int z = candidate.min[2] - shell_; z <= candidate.max[2] + shell_; ++z) {
    for (int y = candidate.min[1] - shell_; y <= candidate.max[1] + shell_; ++y) {
      for (int x = candidate.min[0] - shell_; x <= candidate.max[0] + shell_; ++x) {
        const bool in_box = x >= candidate.min[0] && x <= candidate.max[0] && y >= candidate.min[1] &&
                            y <= candidate.max[1] && z >= candidate.min[2] && z <= candidate.max[2];
        if (in_box) continue;
        const Eigen::Vector3f centre_S = T_S_R * grid.centerOf({x, y, z});
        if (centre_S.z() - half_depth < 0.1f) continue;  // reaches behind the sensor: not in view
        int empty = 0, unknown = 0;
        for (const Eigen::Vector3f& offset : offsets_S) {
          const Eigen::Vector3f p = centre_S + offset;
          const int u = static_cast<int>(std::lround(intrinsics_.fx * p.x() / p.z() + intrinsics_.cx));
          const int v = static_cast<int>(std::lround(intrinsics_.fy * p.y() / p.z() + intrinsics_.cy));
          const Ray ray = classify(frame, coverage, u, v, centre_S.z() - half_depth, centre_S.z() + half_depth);
          empty += ray == Ray::kEmpty;
          unknown += ray == Ray::kUnknown;
        }
        if (unknown > empty) return false;
      }
    }
  }
  return true;
}

}  // namespace kinect3d
