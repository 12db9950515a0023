#include "kinect3d/occupancy_grid.h"

#include <octomap/CountingOcTree.h>

#include <algorithm>
#include <cmath>

namespace kinect3d {

// A counting tree whose leaf counts can be changed by any amount: every node on the path to a
// leaf holds the sum of the counts below it, as in octomap::CountingOcTree. Leaves that drop to
// zero stay in place (OctoMap's node deletion assumes occupancy nodes); OccupancyGrid rebuilds the
// tree from the live counts when such leaves pile up.
class OccupancyGrid::Tree : public octomap::CountingOcTree {
 public:
  using octomap::CountingOcTree::CountingOcTree;

  void addCount(const octomap::OcTreeKey& key, int delta) {
    if (root == nullptr) {
      root = new octomap::CountingOcTreeNode();
      ++tree_size;
    }
    octomap::CountingOcTreeNode* node = root;
    node->setCount(node->getCount() + delta);
    for (int depth = static_cast<int>(tree_depth) - 1; depth >= 0; --depth) {
      const unsigned child = octomap::computeChildIdx(key, depth);
      if (!nodeChildExists(node, child)) createNodeChild(node, child);
      node = getNodeChild(node, child);
      node->setCount(node->getCount() + delta);
    }
  }
};

OccupancyGrid::OccupancyGrid(const Config& config, double focal_px, int pixel_stride)
    : config_(config), tree_(std::make_unique<Tree>(config.voxel_m)) {
  const double per_face = config.voxel_m * focal_px / pixel_stride;
  full_face_points_at_1m_ = per_face * per_face;
  // The dense region: a box around the sensor reaching max_range_m sideways and from just under
  // the floor to max_height_m.
  const int across = static_cast<int>(std::ceil(2.0 * config.max_range_m / config.voxel_m)) + 2;
  size_ = {across, across, static_cast<int>(std::ceil(config.max_height_m / config.voxel_m)) + 2};
  const std::size_t cells = static_cast<std::size_t>(size_[0]) * size_[1] * size_[2];
  counts_.assign(cells, 0);
  previous_counts_.assign(cells, 0);
  occupied_.assign(cells, 0);
  for (int a = 0; a < 3; ++a) blocks_[a] = (size_[a] + kBlock - 1) / kBlock;
  block_counts_.assign(static_cast<std::size_t>(blocks_[0]) * blocks_[1] * blocks_[2], 0);
}

OccupancyGrid::~OccupancyGrid() = default;

void OccupancyGrid::recentre(const Eigen::Vector3f& sensor_R) {
  // The region follows the sensor (it moves only if the extrinsics change); moving it clears it.
  if ((sensor_R - region_centre_).norm() < 1e-3f) return;
  region_centre_ = sensor_R;
  const octomap::OcTreeKey centre = tree_->coordToKey(sensor_R.x(), sensor_R.y(), 0.0);
  origin_key_ = {int(centre[0]) - size_[0] / 2, int(centre[1]) - size_[1] / 2, int(centre[2])};
  std::fill(counts_.begin(), counts_.end(), 0);
  std::fill(previous_counts_.begin(), previous_counts_.end(), 0);
  std::fill(occupied_.begin(), occupied_.end(), 0);
  std::fill(block_counts_.begin(), block_counts_.end(), 0);
  touched_.clear();
  previous_touched_.clear();
  occupied_list_.clear();
  tree_->clear();
}

VoxelIndex OccupancyGrid::indexOf(const Eigen::Vector3f& p_R) const {
  const octomap::OcTreeKey key = tree_->coordToKey(p_R.x(), p_R.y(), p_R.z());
  return {int(key[0]) - origin_key_[0], int(key[1]) - origin_key_[1], int(key[2]) - origin_key_[2]};
}

Eigen::Vector3f OccupancyGrid::centerOf(const VoxelIndex& v) const {
  const octomap::OcTreeKey key(static_cast<octomap::key_type>(v[0] + origin_key_[0]),
                               static_cast<octomap::key_type>(v[1] + origin_key_[1]),
                               static_cast<octomap::key_type>(v[2] + origin_key_[2]));
  const octomap::point3d c = tree_->keyToCoord(key);
  return {c.x(), c.y(), c.z()};
}

void OccupancyGrid::update(const PointSet& points, const Eigen::Vector3f& sensor_R) {
  recentre(sensor_R);
  // Last frame's counts become the previous ones; the buffer two frames old is cleared and reused.
  counts_.swap(previous_counts_);
  touched_.swap(previous_touched_);
  for (const std::uint32_t i : touched_) counts_[i] = 0;
  touched_.clear();
  for (const VoxelIndex& v : occupied_list_) {
    occupied_[flat(v)] = 0;
    --blockCount(v);
  }
  occupied_list_.clear();

  // 1. Aggregate by key.
  for (const Eigen::Vector3f& p : points) {
    const VoxelIndex v = indexOf(p);
    if (!inside(v)) continue;
    std::uint16_t& count = counts_[flat(v)];
    if (count == 0) touched_.push_back(static_cast<std::uint32_t>(flat(v)));
    if (count < UINT16_MAX) ++count;
  }

  // 2. Occupancy, with the threshold at each voxel's range.
  for (const std::uint32_t i : touched_) {
    const VoxelIndex v{int(i % size_[0]), int(i / size_[0] % size_[1]), int(i / size_[0] / size_[1])};
    const double range = std::max(0.3, double((centerOf(v) - sensor_R).norm()));
    const double needed = std::max<double>(config_.min_points,
                                           config_.occupied_fraction * full_face_points_at_1m_ / (range * range));
    if (counts_[i] >= needed) {
      occupied_[i] = 1;
      ++blockCount(v);
      occupied_list_.push_back(v);
    }
  }

  // 3. The tree: only voxels whose count changed.
  auto keyOf = [&](std::uint32_t i) {
    return octomap::OcTreeKey(static_cast<octomap::key_type>(i % size_[0] + origin_key_[0]),
                              static_cast<octomap::key_type>(i / size_[0] % size_[1] + origin_key_[1]),
                              static_cast<octomap::key_type>(i / size_[0] / size_[1] + origin_key_[2]));
  };
  for (const std::uint32_t i : touched_) {
    const int delta = int(counts_[i]) - int(previous_counts_[i]);
    if (delta != 0) tree_->addCount(keyOf(i), delta);
  }
  for (const std::uint32_t i : previous_touched_) {
    if (counts_[i] == 0) tree_->addCount(keyOf(i), -int(previous_counts_[i]));
  }
  // Empty leaves left by voxels that emptied: rebuild once they outnumber the live ones 4:1
  // (a path of 16 nodes per leaf at most, so this bounds the tree at a few times what is live).
  if (tree_->size() > 16 * (5 * touched_.size() + 1000)) {
    tree_->clear();
    for (const std::uint32_t i : touched_) tree_->addCount(keyOf(i), counts_[i]);
  }
}

unsigned OccupancyGrid::treeCount(const Eigen::Vector3f& p_R) const {
  const octomap::CountingOcTreeNode* node = tree_->search(p_R.x(), p_R.y(), p_R.z());
  return node ? node->getCount() : 0;
}

}  // namespace kinect3d
