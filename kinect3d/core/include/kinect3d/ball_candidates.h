// The paper's mask: a ball is a group of occupied voxels that fits inside a core of
// core_voxels^3 voxels whose surrounding shell (out to mask_voxels^3) is empty.
//
// Equivalent formulation used here: occupied voxels are grouped so that two voxels closer than the
// shell is thick belong together (any such neighbour would sit in the shell of a core holding the
// other). A group passes when it fits in the core and some core placement around it has no
// occupied voxel of anything else in its window (core or shell). For a ball on the ground the shell's bottom layer
// lies below the floor, where the floor cut leaves nothing, so the same test finds ground balls.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "kinect3d/occupancy_grid.h"

namespace kinect3d {

struct BallCandidate {
  VoxelIndex min{0, 0, 0};  // bounding box of its occupied voxels, inclusive
  VoxelIndex max{0, 0, 0};
  int voxels = 0;
  int points = 0;  // points counted in its voxels
};

class BallCandidateFinder {
 public:
  struct Config {
    int core_voxels = 3;  // the paper's inner 3 voxels
    int mask_voxels = 5;  // and its mask of 5: a one-voxel empty shell
  };

  // Groups with fewer grid points than min_points_at_1m over their squared range (m^2) cannot be a
  // ball and skip the mask test; BallDetector derives it from the ball's size (0 = test all).
  explicit BallCandidateFinder(const Config& config, double min_points_at_1m = 0.0);

  // Appends every group of occupied voxels that passes the mask to `out` (cleared first).
  void find(const OccupancyGrid& grid, std::vector<BallCandidate>& out) const;

 private:
  bool shellEmpty(const OccupancyGrid& grid, const BallCandidate& group) const;

  Config config_;
  double min_points_at_1m_;
  int shell_;  // voxels of empty shell on each side
  // Scratch for the grouping, reused between frames: per voxel of the grid whether it is grouped
  // (all 0 between calls), and a voxel's neighbours within the shell, as steps and as flat offsets.
  struct Neighbour {
    VoxelIndex step;
    std::ptrdiff_t offset;
  };
  mutable std::vector<std::uint8_t> grouped_;
  mutable std::vector<Neighbour> neighbours_;
  mutable std::vector<VoxelIndex> stack_;
  mutable std::vector<std::uint8_t> blocked_;  // per core placement: holds something else
};

}  // namespace kinect3d
