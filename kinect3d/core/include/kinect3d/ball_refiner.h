// Candidate -> ball: the centre beyond the voxel, from all the candidate's pixels at full
// resolution, and a check that what was found can be a ball of this size at this range.
//
// The visible cap's centroid sits in front of the true centre (2/3 of the radius for an evenly
// seen cap): the centre is the centroid moved back along the viewing ray by the depth of the
// visible disc, refined by a least-squares fit of a sphere of the known radius where the sensor
// resolves the cap's shape (see refine()). When part of the ball's outline is hidden (by something
// nearer, or cut by the edge of the view) the centroid sits towards the visible part; the outline
// that is the ball's own then fixes the centre across the view, and must be a ball's: a circle of
// the ball's radius at its range holding every pixel (see centreFromOutline()).
#pragma once

#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "framework_api/types.h"
#include "kinect3d/ball_candidates.h"
#include "kinect3d/depth_frame.h"
#include "kinect3d/depth_noise.h"
#include "kinect3d/point_projector.h"
#include "kinect3d/sensor_coverage.h"

namespace kinect3d {

struct BallFit {
  Eigen::Vector3d center_R = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance_m2 = Eigen::Matrix3d::Identity();
  fw::BallState state = fw::BallState::kAir;
  int points = 0;
};

class BallRefiner {
 public:
  struct Config {
    double radius_m = 0.11;              // FIFA size 5
    double min_visible_fraction = 0.25;  // of the pixels a whole ball would cover at this range
    double max_size_ratio = 1.6;         // largest extent across the view over the ball's diameter
    double air_min_height_m = 0.08;      // centre this far above resting height: in the air
  };

  BallRefiner(const Config& config, const DepthNoiseModel& noise) : config_(config), noise_(noise) {}

  // The ball the candidate holds, or nothing if it cannot be one.
  std::optional<BallFit> refine(const BallCandidate& candidate, const OccupancyGrid& grid, const DepthFrame& frame,
                                const SensorCoverage& coverage, const Eigen::Isometry3d& T_R_S,
                                const PointProjector& surface) const;

 private:
  static constexpr std::size_t kMinPoints = 5;       // fewer full-resolution points: nothing to refine
  static constexpr double kMinDepthInFront_m = 0.1;  // a box reaching nearer is partly behind the sensor

  // Fills points_ with the candidate's surface points (robot frame) and pixels_ with their pixels;
  // false if too few or not in view.
  bool gatherPoints(const BallCandidate& candidate, const OccupancyGrid& grid, const DepthFrame& frame,
                    const Eigen::Isometry3d& T_R_S, const PointProjector& surface) const;
  // Whether pixel (u, v), beside a hole, shows the ball round one of its dark panels.
  bool besidePanelHole(const DepthFrame& frame, int u, int v, const PointProjector& surface) const;
  // Enough pixels for a ball at this range, and no wider than one.
  bool isBallSized(const Eigen::Vector3d& centroid, const Eigen::Vector3d& ray, double range, double focal_px) const;
  // The centre: the centroid moved back along the ray by the visible cap's depth, and down by what
  // the floor band (points below floor_margin_m) cut off a ball near the floor.
  Eigen::Vector3d centreFromDisc(const Eigen::Vector3d& centroid, const Eigen::Vector3d& ray,
                                 double floor_margin_m) const;
  // For a ball seen in part, the centre moved across the view so that the rays through the visible
  // limb graze a sphere of the ball's radius; nothing when that outline is not a ball's. Unchanged
  // when the whole outline is visible.
  std::optional<Eigen::Vector3d> centreFromOutline(const Eigen::Vector3d& center_R, const DepthFrame& frame,
                                                   const SensorCoverage& coverage, const Eigen::Isometry3d& T_R_S,
                                                   double floor_margin_m) const;
  // Whether the points recede from the centre across the view like a sphere of the ball's radius
  // (not a flat panel, not a thinner limb), as one smooth surface (not an arm before a body).
  bool surfacedLikeABall(const Eigen::Vector3d& center_R, const Eigen::Isometry3d& T_R_S) const;
  // The centre's covariance, mostly along the viewing ray.
  Eigen::Matrix3d covariance(const Eigen::Vector3d& ray, double range, int points) const;

  Config config_;
  DepthNoiseModel noise_;
  // Scratch, reused between candidates.
  mutable std::vector<int> coarse_, piece_cells_, flood_;  // the coarse pass's cells and pieces
  mutable std::vector<bool> speck_;                        // per piece: left out
  mutable std::vector<Eigen::Vector3d> points_;
  mutable std::vector<Eigen::Vector2i> pixels_;  // where each point was seen
  mutable int beside_panels_ = 0;                // and pixels beside a dark panel's hole, only counted
  mutable std::vector<std::pair<int, int>> row_ends_, column_ends_;
  mutable std::vector<Eigen::Vector3d> limb_rays_S_, floor_cut_rays_S_;
  mutable std::vector<bool> limb_blank_, notch_;
  mutable std::vector<double> radial_;
  struct Regressed {  // a point's regressors in the surface fit (surfacedLikeABall), and its range
    Eigen::Vector4d J;
    double range_m;
  };
  mutable std::vector<Regressed> regressed_;
};

}  // namespace kinect3d
