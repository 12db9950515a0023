#include "kinect3d/ball_candidates.h"

#include <algorithm>
#include <stdexcept>

namespace kinect3d {

BallCandidateFinder::BallCandidateFinder(const Config& config, double min_points_at_1m)
    : config_(config), min_points_at_1m_(min_points_at_1m), shell_((config.mask_voxels - config.core_voxels) / 2) {
  if (config.core_voxels < 1 || config.mask_voxels < config.core_voxels + 2 ||
      (config.mask_voxels - config.core_voxels) % 2 != 0) {
    throw std::invalid_argument("mask_voxels must exceed core_voxels by a positive even number");
  }
}

void BallCandidateFinder::find(const OccupancyGrid& grid, std::vector<BallCandidate>& out) const {
  out.clear();
  const std::vector<VoxelIndex>& occupied = grid.occupiedVoxels();
  // Group occupied voxels whose Chebyshev distance is at most the shell thickness. The grid's
  // occupancy flags answer "is there a voxel here", a flag per voxel remembers which are grouped.
  const VoxelIndex& size = grid.size();
  grouped_.resize(static_cast<std::size_t>(size[0]) * size[1] * size[2]);
  neighbours_.clear();
  for (int dz = -shell_; dz <= shell_; ++dz) {
    for (int dy = -shell_; dy <= shell_; ++dy) {
      for (int dx = -shell_; dx <= shell_; ++dx) {
        if (dx == 0 && dy == 0 && dz == 0) continue;
        neighbours_.push_back({{dx, dy, dz}, (std::ptrdiff_t(dz) * size[1] + dy) * size[0] + dx});
      }
    }
  }
  const int core = config_.core_voxels;
  for (const VoxelIndex& start : occupied) {
    std::uint8_t& start_grouped = grouped_[grid.flatIndex(start)];
    if (start_grouped) continue;
    start_grouped = 1;
    BallCandidate group{start, start, 0, 0};
    bool too_big = false;
    stack_.assign(1, start);
    while (!stack_.empty()) {
      const VoxelIndex v = stack_.back();
      stack_.pop_back();
      ++group.voxels;
      group.points += grid.count(v);
      bool interior = true;  // all its neighbours within the shell lie inside the grid
      for (int a = 0; a < 3; ++a) {
        group.min[a] = std::min(group.min[a], v[a]);
        group.max[a] = std::max(group.max[a], v[a]);
        too_big = too_big || group.max[a] - group.min[a] + 1 > core;
        interior = interior && v[a] >= shell_ && v[a] + shell_ < size[a];
      }
      const std::size_t centre = grid.flatIndex(v);
      for (const Neighbour& neighbour : neighbours_) {
        const VoxelIndex n{v[0] + neighbour.step[0], v[1] + neighbour.step[1], v[2] + neighbour.step[2]};
        if (!interior && !grid.occupied(n)) continue;  // at the grid's edge, checked against its bounds
        const std::size_t i = centre + neighbour.offset;
        if (grouped_[i] || !grid.occupiedAt(i)) continue;
        grouped_[i] = 1;
        stack_.push_back(n);
      }
    }
    if (too_big) continue;
    const Eigen::Vector3f middle = 0.5f * (grid.centerOf(group.min) + grid.centerOf(group.max));
    const double range_squared = std::max(0.25, double((middle - grid.sensorPosition()).squaredNorm()));
    if (group.points < min_points_at_1m_ / range_squared) continue;
    if (shellEmpty(grid, group)) out.push_back(group);
  }
  // Every occupied voxel was grouped, and only those.
  for (const VoxelIndex& v : occupied) grouped_[grid.flatIndex(v)] = 0;
}

// Whether some placement of the core around the group leaves the rest of its window (core and
// shell) free of other occupied voxels. Every occupied voxel within the shell distance of the
// group is part of it, so an occupied voxel in the window outside the group's bounding box belongs
// to something else: then the object in the core is not the group alone, or not alone in the air.
bool BallCandidateFinder::shellEmpty(const OccupancyGrid& grid, const BallCandidate& group) const {
  const int core = config_.core_voxels, reach = core + 2 * shell_;  // window size per axis
  VoxelIndex first, count;  // the core's lowest corner over placements containing the group
  for (int a = 0; a < 3; ++a) {
    first[a] = group.max[a] - core + 1;
    count[a] = group.min[a] - first[a] + 1;
  }
  // Each occupied voxel outside the group's box blocks the placements whose window holds it.
  // The union of all windows is scanned block by block (skipping empty blocks), and the group
  // fails as soon as every placement is blocked: for pieces of walls and people, after a few.
  blocked_.assign(static_cast<std::size_t>(count[0]) * count[1] * count[2], 0);
  std::size_t unblocked = blocked_.size();
  auto block = [&](int x, int y, int z) {
    const VoxelIndex f{x, y, z};
    VoxelIndex from, to;  // placements p with p - shell <= f < p - shell + reach
    for (int a = 0; a < 3; ++a) {
      from[a] = std::max(0, f[a] + shell_ - reach + 1 - first[a]);
      to[a] = std::min(count[a] - 1, f[a] + shell_ - first[a]);
      if (from[a] > to[a]) return;
    }
    for (int k = from[2]; k <= to[2]; ++k) {
      for (int j = from[1]; j <= to[1]; ++j) {
        for (int i = from[0]; i <= to[0]; ++i) {
          std::uint8_t& b = blocked_[(static_cast<std::size_t>(k) * count[1] + j) * count[0] + i];
          if (!b) b = 1, --unblocked;
        }
      }
    }
  };
  constexpr int B = OccupancyGrid::kBlock;
  auto blockOf = [](int v) { return v >= 0 ? v / B : -1; };  // voxels below 0 are outside the grid
  VoxelIndex lo, hi;                                         // the union of all windows, inclusive
  for (int a = 0; a < 3; ++a) {
    lo[a] = first[a] - shell_;
    hi[a] = first[a] + count[a] - 1 - shell_ + reach - 1;
  }
  for (int bz = blockOf(lo[2]); bz <= blockOf(hi[2]); ++bz) {
    for (int by = blockOf(lo[1]); by <= blockOf(hi[1]); ++by) {
      for (int bx = blockOf(lo[0]); bx <= blockOf(hi[0]); ++bx) {
        if (!grid.blockOccupied(bx, by, bz)) continue;
        for (int z = std::max(lo[2], bz * B); z <= std::min(hi[2], bz * B + B - 1); ++z) {
          for (int y = std::max(lo[1], by * B); y <= std::min(hi[1], by * B + B - 1); ++y) {
            for (int x = std::max(lo[0], bx * B); x <= std::min(hi[0], bx * B + B - 1); ++x) {
              const bool in_group_box = x >= group.min[0] && x <= group.max[0] && y >= group.min[1] &&
                                        y <= group.max[1] && z >= group.min[2] && z <= group.max[2];
              if (in_group_box || !grid.occupied({x, y, z})) continue;
              block(x, y, z);
              if (unblocked == 0) return false;
            }
          }
        }
      }
    }
  }
  return true;
}

}  // namespace kinect3d
