// The whole per-frame path of the paper, stage by stage:
//   depth frame -> surface points (robot frame) -> occupancy grid -> mask candidates (with a shell
//   the sensor saw) -> balls -> the colour image's verdict on each (when the check is on) -> far
//   away, only the balls the last frames saw too or the colour confirms (second_sight_beyond_m),
// with the scene map (OctoMap) remembering across frames which space is static.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <vector>

#include "framework_api/types.h"
#include "kinect3d/ball_candidates.h"
#include "kinect3d/ball_refiner.h"
#include "kinect3d/colour_check.h"
#include "kinect3d/depth_frame.h"
#include "kinect3d/ground_aligner.h"
#include "kinect3d/occupancy_grid.h"
#include "kinect3d/point_projector.h"
#include "kinect3d/scene_map.h"
#include "kinect3d/sensor_coverage.h"
#include "kinect3d/shell_evidence.h"

namespace kinect3d {

struct DetectorConfig {
  GroundAligner::Config ground;
  PointProjector::Config points;
  OccupancyGrid::Config grid;
  BallCandidateFinder::Config mask;
  BallRefiner::Config ball;
  SceneMap::Config map;
  ColourCheckConfig colour;
  // A ball farther than this is reported only when a ball of the last two frames could have become
  // it, or the colour image confirms it: beyond it a hand, a fist or a foot has a ball's size,
  // outline and depth for a frame, and a free ball is never seen only once.
  double second_sight_beyond_m = 4.0;
};

// Wall time of each stage for one frame, for benchmarks and the detect log.
struct StageTimes {
  enum Stage { kGround, kPoints, kGrid, kCandidates, kRefine, kColour, kMap, kCount };
  static const char* name(int stage);
  std::array<double, kCount> seconds{};
  double total() const;
};

struct Detections {
  std::vector<fw::BallObservation> balls;  // robot frame, air first; rejected by colour ones too, flagged
  bool aligned = false;                    // false while the floor has not been found
  int occupied_voxels = 0;                 // in the grid this frame
  int candidates = 0;                      // groups that passed the mask with an observed shell, before refinement
  StageTimes times;
};

class BallDetector {
 public:
  // source: the name the observations carry (the plugin's or the command's, e.g. "kinect3d").
  BallDetector(const DetectorConfig& config, std::string source);
  ~BallDetector();

  // Every ball in the frame. Observations carry the detector's source name and the frame's times. T_F_R, the
  // robot's pose on the field at the frame's time when localisation gives one, keeps the scene map
  // in the field frame (without it, in the robot frame: right while the robot stands).
  void detect(const DepthFrame& frame, Detections& out, const std::optional<Eigen::Isometry3d>& T_F_R = std::nullopt);

  const OccupancyGrid* grid() const { return grid_.get(); }
  const SceneMap* sceneMap() const { return map_.get(); }
  std::optional<Eigen::Isometry3d> T_R_S() const { return T_R_S_; }

 private:
  // Whether most of the candidate's occupied voxels have been occupied for seconds in the map.
  bool insideStaticSpace(const BallCandidate& candidate, const Eigen::Isometry3d& T_M_R) const;
  // Drops the balls beyond second_sight_beyond_m that no ball of the last frames could have become
  // and the colour did not confirm, and remembers this frame's for the next.
  void keepSecondSights(std::vector<fw::BallObservation>& balls, const Eigen::Isometry3d& T_M_R, double time_s);

  DetectorConfig config_;
  std::string source_;
  GroundAligner ground_;
  // Made for the frame's intrinsics, and again when they change.
  std::unique_ptr<PointProjector> projector_;
  std::unique_ptr<OccupancyGrid> grid_;
  std::unique_ptr<BallCandidateFinder> finder_;
  SensorCoverage coverage_;
  std::unique_ptr<ShellEvidence> shell_evidence_;
  std::unique_ptr<BallRefiner> refiner_;
  std::unique_ptr<SceneMap> map_;
  ColourCheck colour_check_;
  bool map_in_field_ = false;  // the map's frame: field (a pose was given) or robot
  std::optional<Eigen::Isometry3d> T_R_S_;
  PointSet points_;
  std::vector<BallCandidate> candidates_;
  // Every ball of the last frames (map frame, before keepSecondSights drops any), with its frame's time.
  struct Sight {
    double time_s;
    Eigen::Vector3d position_M;
  };
  std::vector<Sight> recent_sights_;
};

}  // namespace kinect3d
