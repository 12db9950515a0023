// The whole per-frame path of the paper, stage by stage:
//   depth frame -> surface points (robot frame) -> occupancy grid -> mask candidates -> balls.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <vector>

#include "framework_api/types.h"
#include "kinect3d/ball_candidates.h"
#include "kinect3d/ball_refiner.h"
#include "kinect3d/depth_frame.h"
#include "kinect3d/ground_aligner.h"
#include "kinect3d/occupancy_grid.h"
#include "kinect3d/point_projector.h"

namespace kinect3d {

struct DetectorConfig {
  GroundAligner::Config ground;
  PointProjector::Config points;
  OccupancyGrid::Config grid;
  BallCandidateFinder::Config mask;
  BallRefiner::Config ball;
};

// Wall time of each stage for one frame, for benchmarks and the detect log.
struct StageTimes {
  enum Stage { kGround, kPoints, kGrid, kCandidates, kRefine, kCount };
  static const char* name(int stage);
  std::array<double, kCount> seconds{};
  double total() const;
};

struct Detections {
  std::vector<fw::BallObservation> balls;  // robot frame, air first
  bool aligned = false;                    // false while the floor has not been found
  int occupied_voxels = 0;                 // in the grid this frame
  int candidates = 0;                      // groups that passed the mask, before refinement
  StageTimes times;
};

class BallDetector {
 public:
  explicit BallDetector(const DetectorConfig& config);
  ~BallDetector();

  // Every ball in the frame. Observations carry source "kinect3d" and the frame's times.
  void detect(const DepthFrame& frame, Detections& out);

  const OccupancyGrid* grid() const { return grid_.get(); }
  std::optional<Eigen::Isometry3d> T_R_S() const { return T_R_S_; }

 private:
  DetectorConfig config_;
  GroundAligner ground_;
  PointProjector projector_;
  // Made for the first frame's focal length.
  std::unique_ptr<OccupancyGrid> grid_;
  std::unique_ptr<BallCandidateFinder> finder_;
  std::unique_ptr<BallRefiner> refiner_;
  std::optional<Eigen::Isometry3d> T_R_S_;
  PointSet points_;
  std::vector<BallCandidate> candidates_;
};

}  // namespace kinect3d
