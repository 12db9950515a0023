// The scene over time, which one frame cannot tell: an OctoMap occupancy map (octomap::OcTree,
// log-odds with clamping, so what moves is forgotten again) of the rays of a few frames a second.
// Per voxel it answers: never observed (unknown), observed free, occupied, or static (occupied
// without a break for static_after_s: a lamp, a poster, a bag on a stand, a ball on a wire).
//
// Rays are cast off the per-frame path: every update_interval_frames-th frame hands a coarse cloud
// to a worker thread, and the next such frame waits for that work and publishes the result. Frame n
// therefore always sees the map of the same earlier frames, however fast the machine is, and a
// replay gives the same answers as the run it replays.
//
// The map is kept in one frame, M: the robot frame while the robot stands, the field frame once a
// robot pose is available (the caller passes T_M_S accordingly and clears the map when M changes).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Geometry>

#include "framework_api/time_line.h"
#include "kinect3d/depth_frame.h"

namespace kinect3d {

class SceneMap {
 public:
  struct Config {
    double voxel_m = 0.27;            // coarse: the paper's grid size, whatever the detector's grid
    int update_interval_frames = 10;  // rays from every n-th frame (3 Hz at 30 Hz)
    int ray_stride_px = 8;            // from every n-th pixel in u and v (80 x 60 rays at VGA)
    double static_after_s = 2.0;      // occupied this long without a break: static
  };

  enum class VoxelState : std::uint8_t { kUnknown, kFree, kOccupied, kStatic };

  // Depths outside [min_range_m, max_range_m] (the sensor's, as the detector uses) cast no ray.
  SceneMap(const Config& config, double min_range_m, double max_range_m);
  ~SceneMap();  // lets the rays in flight finish
  SceneMap(const SceneMap&) = delete;
  SceneMap& operator=(const SceneMap&) = delete;

  // One frame, seen from T_M_S (sensor optical frame to map frame), at t_s on the source clock.
  // A frame whose time or pose is not finite is left out; a time that jumps (fw::TimeLine) starts
  // the voxels' occupied-since times again (the free and occupied space stays).
  void update(const DepthFrame& frame, const Eigen::Isometry3d& T_M_S, double t_s);
  // Forgets everything (the map's frame changed).
  void clear();

  // The state of the voxel holding p_M, as of the last published integration.
  VoxelState stateAt(const Eigen::Vector3d& p_M) const;
  // Integrations published so far.
  int integrations() const { return integrations_; }
  // Wall time the worker spent on the last integration (for the benchmark).
  double lastIntegration_s() const { return last_integration_s_; }

  // Writes the map as OctoMap's binary .bt (free and occupied, opened by octovis), after the rays in
  // flight. Throws std::runtime_error naming the path when it cannot.
  void writeBinary(const std::string& path) const;

 private:
  struct Worker;  // the OcTree and the work in flight; defined in scene_map.cpp
  void publish();

  Config config_;
  double min_range_m_, max_range_m_;
  std::unique_ptr<Worker> worker_;
  int frames_seen_ = 0;  // frames since the map was made or cleared
  fw::TimeLine time_line_;
  bool new_time_line_ = false;  // a jump seen since the last rays were cast
  int integrations_ = 0;
  double last_integration_s_ = 0.0;
};

}  // namespace kinect3d
