// 'Empty' must be observed. The grid knows where points are, not where the sensor looked: a voxel
// without points is empty only if the sensor could have seen something there. Each voxel of the
// shell around a candidate is checked against the depth image, along the rays through it:
//   - depth measured behind the voxel: seen through, empty;
//   - depth measured in front of it: hidden (by the ball itself, or by a robot in front);
//   - outside the sensor's view (past the image border or in its edge bands, SensorCoverage):
//     hidden;
//   - no depth, the voxel nearer than the farthest depth the sensor has returned (and than the
//     configured range): empty (nothing returned light there), unless the pixel lies in the
//     projector's shadow of something nearer (the projector sits at +baseline on the optical x
//     axis, so shadows fall to the left of what casts them): hidden;
//   - no depth, the voxel at or beyond that range: unknown. A surface there may be returning nothing.
// A candidate whose shell holds a voxel with more unknown rays than empty ones is not isolated
// for all the sensor knows: the end of a wall at the range limit, an object on a wall beyond it.
// Hidden voxels do not count against a candidate: a ball half behind a robot or cut by the image
// border is still a ball, and the refiner checks its shape.
#pragma once

#include <Eigen/Geometry>

#include "kinect3d/ball_candidates.h"
#include "kinect3d/depth_frame.h"
#include "kinect3d/depth_noise.h"
#include "kinect3d/occupancy_grid.h"
#include "kinect3d/point_projector.h"
#include "kinect3d/sensor_coverage.h"

namespace kinect3d {

class ShellEvidence {
 public:
  // shell_voxels: the mask's shell thickness. The points' max_range_m caps the sensor's range
  // whatever it returns; min_range_m and baseline_m bound the projector's shadows.
  ShellEvidence(const Intrinsics& intrinsics, int shell_voxels, const PointProjector::Config& points);

  // Whether every voxel of the shell around the candidate's box is empty or hidden, not unknown.
  // T_S_R maps the robot frame (the grid's) to the sensor optical frame.
  bool shellObserved(const BallCandidate& candidate, const OccupancyGrid& grid, const DepthFrame& frame,
                     const SensorCoverage& coverage, const Eigen::Isometry3f& T_S_R) const;

  enum class Ray { kEmpty, kHidden, kUnknown, kSurface };
  // What the ray through pixel (u, v) says about a voxel spanning depths [near_m, far_m] along it.
  Ray classify(const DepthFrame& frame, const SensorCoverage& coverage, int u, int v, float near_m, float far_m) const;

 private:
  // Whether a no-depth pixel could lie in the projector's shadow of a nearer surface to its right,
  // for a surface behind it at far_m.
  bool inShadow(const DepthFrame& frame, int u, int v, float far_m) const;

  // The range within which no depth means nothing there: what the sensor has returned (at most the
  // configured range) less one depth step, the noise of a surface at that range.
  float sureReturn_m(const SensorCoverage& coverage) const;

  Intrinsics intrinsics_;
  int shell_;
  float max_range_m_;
  DepthNoiseModel noise_;
  float fb_;           // focal length times baseline: disparity (px) = fb / z
  int max_shadow_px_;  // the widest shadow: cast from the nearest range onto infinity
};

}  // namespace kinect3d
