#include "kinect3d/ball_candidates.h"

#include <algorithm>
#include <stdexcept>

namespace kinect3d {

void BallCandidateFinder::VoxelSet::reset(std::size_t expected) {
  std::size_t capacity = 64;
  while (capacity < 2 * expected) capacity *= 2;
  if (slots_.size() < capacity) slots_.resize(capacity);
  std::fill(slots_.begin(), slots_.begin() + capacity, kEmpty);
  mask_ = capacity - 1;
}

bool BallCandidateFinder::VoxelSet::insert(const VoxelIndex& v) {
  const std::uint64_t key = (std::uint64_t(std::uint32_t(v[2])) << 42) ^
                            (std::uint64_t(std::uint32_t(v[1])) << 21) ^ std::uint32_t(v[0]);
  for (std::size_t i = (key * 0x9E3779B97F4A7C15ULL) >> 40 & mask_;; i = (i + 1) & mask_) {
    if (slots_[i] == key) return false;
    if (slots_[i] == kEmpty) {
      slots_[i] = key;
      return true;
    }
  }
}

BallCandidateFinder::BallCandidateFinder(const Config& config)
    : config_(config), shell_((config.mask_voxels - config.core_voxels) / 2) {
  if (config.core_voxels < 1 || config.mask_voxels < config.core_voxels + 2 ||
      (config.mask_voxels - config.core_voxels) % 2 != 0) {
    throw std::invalid_argument("mask_voxels must exceed core_voxels by a positive even number");
  }
}

void BallCandidateFinder::find(const OccupancyGrid& grid, std::vector<BallCandidate>& out) const {
  out.clear();
  const std::vector<VoxelIndex>& occupied = grid.occupiedVoxels();
  // Group occupied voxels whose Chebyshev distance is at most the shell thickness. The grid's
  // occupancy flags answer "is there a voxel here", a set remembers which are grouped already.
  grouped_.reset(occupied.size());
  const int core = config_.core_voxels;
  for (const VoxelIndex& start : occupied) {
    if (!grouped_.insert(start)) continue;
    BallCandidate group{start, start, 0, 0};
    bool too_big = false;
    stack_.assign(1, start);
    while (!stack_.empty()) {
      const VoxelIndex v = stack_.back();
      stack_.pop_back();
      ++group.voxels;
      group.points += grid.count(v);
      for (int a = 0; a < 3; ++a) {
        group.min[a] = std::min(group.min[a], v[a]);
        group.max[a] = std::max(group.max[a], v[a]);
        too_big = too_big || group.max[a] - group.min[a] + 1 > core;
      }
      for (int dz = -shell_; dz <= shell_; ++dz) {
        for (int dy = -shell_; dy <= shell_; ++dy) {
          for (int dx = -shell_; dx <= shell_; ++dx) {
            const VoxelIndex n{v[0] + dx, v[1] + dy, v[2] + dz};
            if (!grid.occupied(n)) continue;
            if (grouped_.insert(n)) stack_.push_back(n);
          }
        }
      }
    }
    if (too_big) continue;
    const Eigen::Vector3f middle = 0.5f * (grid.centerOf(group.min) + grid.centerOf(group.max));
    const double range_squared = std::max(0.25, double((middle - grid.sensorPosition()).squaredNorm()));
    if (group.points < config_.min_points_at_1m / range_squared) continue;
    if (shellEmpty(grid, group)) out.push_back(group);
  }
}

// Whether some placement of the core around the group leaves the rest of its window (core and
// shell) free of other occupied voxels. Every occupied voxel within the shell distance of the
// group is part of it, so an occupied voxel in the window outside the group's bounding box belongs
// to something else: then the object in the core is not the group alone, or not alone in the air.
bool BallCandidateFinder::shellEmpty(const OccupancyGrid& grid, const BallCandidate& group) const {
  const int core = config_.core_voxels;
  VoxelIndex first, last;  // range of the core's lowest corner over placements containing the group
  for (int a = 0; a < 3; ++a) {
    first[a] = group.max[a] - core + 1;
    last[a] = group.min[a];
  }
  // Occupied voxels outside the group's box anywhere in the union of all windows: with none the
  // group passes at once (the usual case for a ball in the air); otherwise each placement is
  // tested against that short list.
  foreign_.clear();
  for (int z = first[2] - shell_; z < last[2] + core + shell_; ++z) {
    for (int y = first[1] - shell_; y < last[1] + core + shell_; ++y) {
      for (int x = first[0] - shell_; x < last[0] + core + shell_; ++x) {
        const bool in_group_box = x >= group.min[0] && x <= group.max[0] && y >= group.min[1] &&
                                  y <= group.max[1] && z >= group.min[2] && z <= group.max[2];
        if (!in_group_box && grid.occupied({x, y, z})) foreign_.push_back({x, y, z});
      }
    }
  }
  if (foreign_.empty()) return true;
  for (int z0 = first[2]; z0 <= last[2]; ++z0) {
    for (int y0 = first[1]; y0 <= last[1]; ++y0) {
      for (int x0 = first[0]; x0 <= last[0]; ++x0) {
        const VoxelIndex lo{x0 - shell_, y0 - shell_, z0 - shell_};
        const bool clear = std::none_of(foreign_.begin(), foreign_.end(), [&](const VoxelIndex& f) {
          return f[0] >= lo[0] && f[0] < lo[0] + core + 2 * shell_ && f[1] >= lo[1] &&
                 f[1] < lo[1] + core + 2 * shell_ && f[2] >= lo[2] && f[2] < lo[2] + core + 2 * shell_;
        });
        if (clear) return true;
      }
    }
  }
  return false;
}

}  // namespace kinect3d
