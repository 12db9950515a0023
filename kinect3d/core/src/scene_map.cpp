#include "kinect3d/scene_map.h"

#include <octomap/OcTree.h>
#include <pthread.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <thread>
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

// One thread, for the map's lifetime, that casts the rays it is handed. The OcTree, the cloud and
// `labelling` belong to it while rays are in flight; the frame thread touches them only after
// waitForRays(). The frame thread swaps `labelling` with `published`, which only it reads. Buffers
// are kept between integrations, so handing rays over allocates nothing once warm.
struct SceneMap::Worker {
  Worker(double voxel_m, double max_range_m, double static_after_s)
      : tree(voxel_m), max_range_m(max_range_m), static_after_s(static_after_s), thread([this] { run(); }) {}

  ~Worker() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      quit = true;
    }
    wake.notify_all();
    thread.join();
  }

  // Starts casting `cloud` from `origin`, taken at t_s; new_time_line: t_s is on another clock than
  // the frames before (fw::TimeLine), so how long a voxel has been occupied starts again.
  void castRays(const octomap::point3d& ray_origin, double ray_time_s, bool new_time_line) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      origin = ray_origin;
      t_s = ray_time_s;
      forget_times = forget_times || new_time_line;
      in_flight = true;
    }
    wake.notify_all();
  }

  void waitForRays() {
    std::unique_lock<std::mutex> lock(mutex);
    wake.wait(lock, [this] { return !in_flight; });
  }

  void run() {
    pthread_setname_np(pthread_self(), "scene_map");  // beside the host's plugin threads in top -H
    std::unique_lock<std::mutex> lock(mutex);
    for (;;) {
      wake.wait(lock, [this] { return quit || (in_flight && !integrated); });
      if (quit) return;
      lock.unlock();
      const double seconds = integrate();
      lock.lock();
      last_integration_s = seconds;
      integrated = true;
      in_flight = false;
      wake.notify_all();
    }
  }

  // Casts the rays into the tree, then labels every observed voxel. Leaves stay at full depth:
  // updates are lazy (nothing is pruned), so each leaf is one voxel. Returns the wall time it took.
  double integrate() {
    const auto start = std::chrono::steady_clock::now();
    if (forget_times) occupied_since_s.clear();
    forget_times = false;
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

  octomap::OcTree tree;
  const double max_range_m, static_after_s;
  // When each voxel that is occupied now became occupied (source clock).
  std::unordered_map<octomap::OcTreeKey, double, octomap::OcTreeKey::KeyHash> occupied_since_s;
  octomap::Pointcloud cloud;  // the rays' ends, in the map frame
  octomap::point3d origin;
  double t_s = 0.0;
  bool forget_times = false;
  std::vector<Label> labelling, published;

  std::mutex mutex;  // guards the flags below and the hand-over of the fields above
  std::condition_variable wake;
  bool in_flight = false;   // rays handed over, not yet cast
  bool integrated = false;  // cast, not yet published
  bool quit = false;
  double last_integration_s = 0.0;
  std::thread thread;  // last: starts once everything it reads exists
};

SceneMap::SceneMap(const Config& config, double min_range_m, double max_range_m)
    : config_(config),
      min_range_m_(min_range_m),
      max_range_m_(max_range_m),
      worker_(std::make_unique<Worker>(config.voxel_m, max_range_m, config.static_after_s)) {}

SceneMap::~SceneMap() = default;

void SceneMap::publish() {
  worker_->waitForRays();
  if (!worker_->integrated) return;
  worker_->integrated = false;
  last_integration_s_ = worker_->last_integration_s;
  worker_->published.swap(worker_->labelling);
  ++integrations_;
}

void SceneMap::update(const DepthFrame& frame, const Eigen::Isometry3d& T_M_S, double t_s) {
  const fw::TimeLine::Step step = time_line_.next(t_s);
  if (step == fw::TimeLine::Step::kNotFinite || !T_M_S.matrix().allFinite()) return;  // cannot be placed
  if (step == fw::TimeLine::Step::kJump) new_time_line_ = true;
  if (frames_seen_++ % config_.update_interval_frames != 0) return;
  publish();
  const Intrinsics& in = frame.intrinsics;
  const int stride = config_.ray_stride_px;
  octomap::Pointcloud& cloud = worker_->cloud;
  cloud.clear();
  for (int v = stride / 2; v < in.height; v += stride) {
    for (int u = stride / 2; u < in.width; u += stride) {
      const double z_m = frame.at(u, v) * 0.001;
      if (z_m < min_range_m_ || z_m > max_range_m_) continue;
      const Eigen::Vector3d p_M = T_M_S * in.backProject(u, v, z_m);
      cloud.push_back(static_cast<float>(p_M.x()), static_cast<float>(p_M.y()), static_cast<float>(p_M.z()));
    }
  }
  const Eigen::Vector3d origin_M = T_M_S.translation();
  worker_->castRays(octomap::point3d(static_cast<float>(origin_M.x()), static_cast<float>(origin_M.y()),
                                     static_cast<float>(origin_M.z())),
                    t_s, new_time_line_);
  new_time_line_ = false;
}

void SceneMap::clear() {
  worker_->waitForRays();
  worker_->integrated = false;
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

}  // namespace kinect3d
