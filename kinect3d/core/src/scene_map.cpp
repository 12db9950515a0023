#include "kinect3d/scene_map.h"

#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <future>
#include <stdexcept>
#include <unordered_map>
#include <vector>

namespace kinect3d {

namespace {

// A voxel's OctoMap key in one integer, so the labels are one sorted array (searched by bisection,
// refilled in place: no allocation once warm).
std::uint64_t pack(const octomap::OcTreeKey& key) {
  return std::uint64_t(key[0]) << 32 | std::uint64_t(key[1]) << 16 | key[2];
}

struct Label {
  std::uint64_t key;
  SceneMap::VoxelState state;
  bool operator<(const Label& other) const { return key < other.key; }
};

}  // namespace

// The OcTree belongs to the worker while rays are in flight; the frame thread touches it only after
// waiting for them. The worker fills `labelling`; the frame thread swaps it with `published`, which
// only it reads.
struct SceneMap::Worker {
  explicit Worker(double voxel_m) : tree(voxel_m) {}

  // Casts the rays into the tree, then labels every observed voxel. Leaves stay at full depth:
  // updates are lazy (nothing is pruned), so each leaf is one voxel.
  // Returns the wall time it took.
  double integrate(const octomap::Pointcloud& cloud, const octomap::point3d& origin, double t_s, double max_range_m,
                   double static_after_s) {
    const auto start = std::chrono::steady_clock::now();
    tree.insertPointCloud(cloud, origin, max_range_m, /*lazy_eval=*/true, /*discretize=*/true);
    labelling.clear();
    for (auto leaf = tree.begin_leafs(), end = tree.end_leafs(); leaf != end; ++leaf) {
      const octomap::OcTreeKey key = leaf.getKey();
      VoxelState state = VoxelState::kFree;
      if (tree.isNodeOccupied(*leaf)) {
        const double since_s = occupied_since_s.try_emplace(key, t_s).first->second;
        state = t_s - since_s >= static_after_s ? VoxelState::kStatic : VoxelState::kOccupied;
      } else {
        occupied_since_s.erase(key);
      }
      labelling.push_back({pack(key), state});
    }
    std::sort(labelling.begin(), labelling.end());
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  void waitForRays() const {
    if (in_flight.valid()) in_flight.wait();
  }

  octomap::OcTree tree;
  // When each voxel that is occupied now became occupied (source clock).
  std::unordered_map<octomap::OcTreeKey, double, octomap::OcTreeKey::KeyHash> occupied_since_s;
  std::future<double> in_flight;
  std::vector<Label> labelling, published;
};

SceneMap::SceneMap(const Config& config, double min_range_m, double max_range_m)
    : config_(config),
      min_range_m_(min_range_m),
      max_range_m_(max_range_m),
      worker_(std::make_unique<Worker>(config.voxel_m)) {}

SceneMap::~SceneMap() { worker_->waitForRays(); }

void SceneMap::publish() {
  if (!worker_->in_flight.valid()) return;
  last_integration_s_ = worker_->in_flight.get();
  worker_->published.swap(worker_->labelling);
  ++integrations_;
}

void SceneMap::update(const DepthFrame& frame, const Eigen::Isometry3d& T_M_S, double t_s) {
  if (frames_seen_++ % config_.update_interval_frames != 0) return;
  publish();
  const Intrinsics& in = frame.intrinsics;
  const int stride = config_.ray_stride_px;
  octomap::Pointcloud cloud;
  cloud.reserve(static_cast<std::size_t>(in.width / stride + 1) * (in.height / stride + 1));
  for (int v = stride / 2; v < in.height; v += stride) {
    for (int u = stride / 2; u < in.width; u += stride) {
      const double z_m = frame.at(u, v) * 0.001;
      if (z_m < min_range_m_ || z_m > max_range_m_) continue;
      const Eigen::Vector3d p_M = T_M_S * in.backProject(u, v, z_m);
      cloud.push_back(static_cast<float>(p_M.x()), static_cast<float>(p_M.y()), static_cast<float>(p_M.z()));
    }
  }
  const Eigen::Vector3d origin_M = T_M_S.translation();
  const octomap::point3d origin(static_cast<float>(origin_M.x()), static_cast<float>(origin_M.y()),
                                static_cast<float>(origin_M.z()));
  Worker* worker = worker_.get();
  worker->in_flight =
      std::async(std::launch::async, [worker, cloud = std::move(cloud), origin, t_s, max_range_m = max_range_m_,
                                      static_after_s = config_.static_after_s] {
        return worker->integrate(cloud, origin, t_s, max_range_m, static_after_s);
      });
}

void SceneMap::clear() {
  worker_->waitForRays();
  worker_->in_flight = {};
  worker_->tree.clear();
  worker_->occupied_since_s.clear();
  worker_->published.clear();
  frames_seen_ = 0;
}

SceneMap::VoxelState SceneMap::stateAt(const Eigen::Vector3d& p_M) const {
  octomap::OcTreeKey key;
  if (!worker_->tree.coordToKeyChecked(p_M.x(), p_M.y(), p_M.z(), key)) return VoxelState::kUnknown;
  const std::vector<Label>& labels = worker_->published;
  const auto found = std::lower_bound(labels.begin(), labels.end(), Label{pack(key), VoxelState::kUnknown});
  return found != labels.end() && found->key == pack(key) ? found->state : VoxelState::kUnknown;
}

void SceneMap::writeBinary(const std::string& path) const {
  worker_->waitForRays();
  worker_->tree.updateInnerOccupancy();  // inner nodes summarise their children for octovis
  if (!worker_->tree.writeBinaryConst(path)) {
    throw std::runtime_error("cannot write the scene map to '" + path + "'");
  }
}

const char* toString(SceneMap::VoxelState state) {
  switch (state) {
    case SceneMap::VoxelState::kUnknown:
      return "unknown";
    case SceneMap::VoxelState::kFree:
      return "free";
    case SceneMap::VoxelState::kOccupied:
      return "occupied";
    case SceneMap::VoxelState::kStatic:
      return "static";
  }
  return "?";
}

}  // namespace kinect3d
