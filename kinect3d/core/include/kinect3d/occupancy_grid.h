// The voxel occupancy grid of the paper: this frame's points counted per voxel, a voxel occupied
// when it holds enough points for its range. It answers "occupied now" for the mask, so it is a dense
// array over the region the sensor can see (one increment per point, one load per query), rebuilt
// every frame. What persists between frames (observed free space, static structure) is the
// SceneMap's job. Voxel boundaries lie on multiples of voxel_m, as OctoMap's keys do, so a grid voxel
// and a SceneMap voxel of the same size are the same cube.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "kinect3d/point_projector.h"

namespace kinect3d {

using VoxelIndex = std::array<int, 3>;  // (ix, iy, iz); iz = 0 is the layer just above the floor

class OccupancyGrid {
 public:
  struct Config {
    double voxel_m = 0.27;  // the paper's grid size
    // A voxel is occupied when it holds at least this share of the points a surface filling one
    // voxel face would give at the voxel's range ((voxel f / (range stride))^2), and at least
    // min_points: a threshold that follows the point density as it falls with range.
    double occupied_fraction = 0.02;
    int min_points = 3;
  };
  // The grid spans this high above the floor: above the highest lob (about 2.1 m apex in MSL).
  static constexpr double kMaxHeight_m = 3.5;

  // focal_px and pixel_stride set the point density; the grid spans max_range_m (the sensor's
  // range) around the sensor.
  OccupancyGrid(const Config& config, double focal_px, int pixel_stride, double max_range_m);
  ~OccupancyGrid();

  // Replaces the counts with this frame's points; sensor_R is the sensor's position (for ranges).
  void update(const PointSet& points, const Eigen::Vector3f& sensor_R);

  bool occupied(const VoxelIndex& v) const { return inside(v) && occupied_[flat(v)] != 0; }
  int count(const VoxelIndex& v) const { return inside(v) ? counts_[flat(v)] : 0; }

  // Occupied voxels are also counted per block of kBlock^3 voxels, so scans of a neighbourhood
  // can skip empty space a block at a time.
  static constexpr int kBlock = 4;
  bool blockOccupied(int bx, int by, int bz) const {
    if (bx < 0 || by < 0 || bz < 0 || bx >= blocks_[0] || by >= blocks_[1] || bz >= blocks_[2]) return false;
    return block_counts_[(static_cast<std::size_t>(bz) * blocks_[1] + by) * blocks_[0] + bx] != 0;
  }
  const std::vector<VoxelIndex>& occupiedVoxels() const { return occupied_list_; }

  // Dense indexing, for scans that visit every neighbour of many voxels: the region's size, a
  // voxel's flat index (the voxel inside it; a neighbour at (dx, dy, dz) lies
  // (dz size[1] + dy) size[0] + dx further on), and occupancy by flat index.
  const VoxelIndex& size() const { return size_; }
  std::size_t flatIndex(const VoxelIndex& v) const { return flat(v); }
  bool occupiedAt(std::size_t flat_index) const { return occupied_[flat_index] != 0; }

  VoxelIndex indexOf(const Eigen::Vector3f& p_R) const;
  Eigen::Vector3f centerOf(const VoxelIndex& v) const;
  double voxel_m() const { return config_.voxel_m; }
  const Eigen::Vector3f& sensorPosition() const { return region_centre_; }

 private:
  bool inside(const VoxelIndex& v) const {
    return v[0] >= 0 && v[1] >= 0 && v[2] >= 0 && v[0] < size_[0] && v[1] < size_[1] && v[2] < size_[2];
  }
  std::size_t flat(const VoxelIndex& v) const {
    return (static_cast<std::size_t>(v[2]) * size_[1] + v[1]) * size_[0] + v[0];
  }
  void recentre(const Eigen::Vector3f& sensor_R);
  VoxelIndex cellOf(const Eigen::Vector3f& p) const;  // floor(p / voxel_m) per axis
  std::uint16_t& blockCount(const VoxelIndex& v) {
    return block_counts_[(static_cast<std::size_t>(v[2] / kBlock) * blocks_[1] + v[1] / kBlock) * blocks_[0] +
                         v[0] / kBlock];
  }

  Config config_;
  double full_face_points_at_1m_;  // (voxel f / stride)^2: points on a full voxel face at 1 m
  VoxelIndex size_{0, 0, 0};
  VoxelIndex origin_{0, 0, 0};  // floor(p / voxel_m) of dense index (0, 0, 0)
  Eigen::Vector3f region_centre_{Eigen::Vector3f::Constant(1e9f)};
  std::vector<std::uint16_t> counts_;  // per voxel this frame's points, and the spare cell's last
  std::vector<std::uint16_t> needed_;  // per voxel the points that make it occupied at its range
  std::vector<std::uint8_t> occupied_;
  VoxelIndex blocks_{0, 0, 0};
  std::vector<std::uint16_t> block_counts_;
  std::vector<std::uint32_t> cells_;  // per point of the frame its voxel's flat index (or the spare cell)
  std::vector<VoxelIndex> occupied_list_;
};

}  // namespace kinect3d
