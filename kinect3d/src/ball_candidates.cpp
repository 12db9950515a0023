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
    if (!too_big && shellEmpty(grid, group)) out.push_back(group);
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
  auto inGroupBox = [&](int x, int y, int z) {
    return x >= group.min[0] && x <= group.max[0] && y >= group.min[1] && y <= group.max[1] &&
           z >= group.min[2] && z <= group.max[2];
  };
  for (int z0 = first[2]; z0 <= last[2]; ++z0) {
    for (int y0 = first[1]; y0 <= last[1]; ++y0) {
      for (int x0 = first[0]; x0 <= last[0]; ++x0) {
        bool clear = true;
        for (int z = z0 - shell_; clear && z < z0 + core + shell_; ++z) {
          for (int y = y0 - shell_; clear && y < y0 + core + shell_; ++y) {
            for (int x = x0 - shell_; x < x0 + core + shell_; ++x) {
              if (!inGroupBox(x, y, z) && grid.occupied({x, y, z})) {
                clear = false;
                break;
              }
            }
          }
        }
        if (clear) return true;
      }
    }
  }
  return false;
}

}  // namespace kinect3d
