#include "kinect3d/occupancy_grid.h"

#include <algorithm>
#include <cmath>

namespace kinect3d {

OccupancyGrid::OccupancyGrid(const Config& config, double focal_px, int pixel_stride, double max_range_m)
    : config_(config) {
  const double per_face = config.voxel_m * focal_px / pixel_stride;
  full_face_points_at_1m_ = per_face * per_face;
  // The dense region: a box around the sensor reaching max_range_m sideways and from the floor to
  // kMaxHeight_m.
  const int across = static_cast<int>(std::ceil(2.0 * max_range_m / config.voxel_m)) + 2;
  size_ = {across, across, static_cast<int>(std::ceil(kMaxHeight_m / config.voxel_m)) + 2};
  const std::size_t cells = static_cast<std::size_t>(size_[0]) * size_[1] * size_[2];
  counts_.assign(cells + 1, 0);  // and the spare cell, where points outside the region are counted
  needed_.assign(cells + 1, 0);  // the spare cell's 0 is never reached: a counted cell holds 1 or more
  occupied_.assign(cells, 0);
  for (int a = 0; a < 3; ++a) blocks_[a] = (size_[a] + kBlock - 1) / kBlock;
  block_counts_.assign(static_cast<std::size_t>(blocks_[0]) * blocks_[1] * blocks_[2], 0);
}

OccupancyGrid::~OccupancyGrid() = default;

void OccupancyGrid::recentre(const Eigen::Vector3f& sensor_R) {
  // The region follows the sensor (it moves only if the extrinsics change); moving it clears it.
  if ((sensor_R - region_centre_).norm() < 1e-3f) return;
  region_centre_ = sensor_R;
  const VoxelIndex centre = cellOf(Eigen::Vector3f(sensor_R.x(), sensor_R.y(), 0.0f));
  origin_ = {centre[0] - size_[0] / 2, centre[1] - size_[1] / 2, centre[2]};
  std::fill(counts_.begin(), counts_.end(), 0);
  std::fill(occupied_.begin(), occupied_.end(), 0);
  std::fill(block_counts_.begin(), block_counts_.end(), 0);
  cells_.clear();
  occupied_list_.clear();
  // Each voxel's threshold at its range, in whole points (a count reaches a fractional threshold
  // when it reaches the next whole number).
  for (int z = 0; z < size_[2]; ++z) {
    for (int y = 0; y < size_[1]; ++y) {
      for (int x = 0; x < size_[0]; ++x) {
        const VoxelIndex v{x, y, z};
        const double range = std::max(0.3, double((centerOf(v) - sensor_R).norm()));
        const double needed =
            std::max<double>(config_.min_points, config_.occupied_fraction * full_face_points_at_1m_ / (range * range));
        needed_[flat(v)] = static_cast<std::uint16_t>(std::clamp<double>(std::ceil(needed), 1, UINT16_MAX));
      }
    }
  }
}

namespace {
// floor() as an int without a library call (x86-64's baseline has no rounding instruction).
int floorToInt(float x) {
  const int truncated = static_cast<int>(x);
  return truncated - (x < static_cast<float>(truncated));
}
}  // namespace

VoxelIndex OccupancyGrid::cellOf(const Eigen::Vector3f& p) const {
  const float scale = static_cast<float>(1.0 / config_.voxel_m);
  return {floorToInt(p.x() * scale), floorToInt(p.y() * scale), floorToInt(p.z() * scale)};
}

VoxelIndex OccupancyGrid::indexOf(const Eigen::Vector3f& p_R) const {
  const VoxelIndex cell = cellOf(p_R);
  return {cell[0] - origin_[0], cell[1] - origin_[1], cell[2] - origin_[2]};
}

Eigen::Vector3f OccupancyGrid::centerOf(const VoxelIndex& v) const {
  const float voxel = static_cast<float>(config_.voxel_m);
  return {(v[0] + origin_[0] + 0.5f) * voxel, (v[1] + origin_[1] + 0.5f) * voxel, (v[2] + origin_[2] + 0.5f) * voxel};
}

void OccupancyGrid::update(const PointSet& points, const Eigen::Vector3f& sensor_R) {
  recentre(sensor_R);
  // Clear last frame's counts: all at once when it had more points than a sixteenth of the voxels
  // (a fill is many times faster per element than scattered writes), else where it had points.
  if (cells_.size() * 16 > counts_.size()) {
    std::fill(counts_.begin(), counts_.end(), 0);
  } else {
    for (const std::uint32_t i : cells_) counts_[i] = 0;
  }
  // And its occupancy.
  for (const VoxelIndex& v : occupied_list_) {
    occupied_[flat(v)] = 0;
    --blockCount(v);
  }
  occupied_list_.clear();

  // 1. Each point's voxel, or the spare cell past the region's end for a point outside it.
  const std::uint32_t spare = static_cast<std::uint32_t>(counts_.size() - 1);
  cells_.resize(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    const VoxelIndex v = indexOf(points[k]);
    cells_[k] = inside(v) ? static_cast<std::uint32_t>(flat(v)) : spare;
  }

  // 2. Count them; a voxel is occupied the moment its count reaches its threshold (the spare cell's
  // is never reached).
  for (const std::uint32_t i : cells_) {
    std::uint16_t& count = counts_[i];
    count += count != UINT16_MAX;
    if (count == needed_[i]) {
      const VoxelIndex v{int(i % size_[0]), int(i / size_[0] % size_[1]), int(i / size_[0] / size_[1])};
      occupied_[i] = 1;
      ++blockCount(v);
      occupied_list_.push_back(v);
    }
  }
}

}  // namespace kinect3d
