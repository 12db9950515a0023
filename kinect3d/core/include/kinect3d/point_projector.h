// Depth frame -> points in the robot frame, keeping only pixels that lie on a surface.
//
// A Kinect pixel at a depth edge is often a mix of the near and the far side ('flying pixel'), and
// a fast ball leaves a trail of such pixels. They make spurious occupancy in the empty shell around
// a ball, so a pixel is kept only if all four neighbours agree with its depth to within a few
// quantisation steps of that range: true of every surface the sensor resolves (the floor at
// grazing angles changes by about 0.1 px of disparity per row), false across an edge or a trail.
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "kinect3d/depth_frame.h"
#include "kinect3d/depth_noise.h"

namespace kinect3d {

// Points of one frame in the robot frame (reused between frames).
using PointSet = std::vector<Eigen::Vector3f>;

class PointProjector {
 public:
  struct Config {
    int pixel_stride = 2;               // use every n-th pixel in u and v for the grid (1 = all)
    double edge_tolerance_steps = 4.0;  // neighbours may differ by this many quantisation steps
    double min_range_m = 0.5;           // Kinect v1 returns nothing nearer
    double max_range_m = 9.5;           // steps are 25 cm and more beyond
    double floor_margin_m = 0.05;       // points below this height are the floor (plus its noise)
    double baseline_m = DepthNoiseModel::kKinectV1Baseline_m;  // sets the quantisation step
  };

  // For frames with these intrinsics (the tolerance and the rays depend on them).
  PointProjector(const Config& config, const Intrinsics& intrinsics);
  const Config& config() const { return config_; }
  const Intrinsics& intrinsics() const { return intrinsics_; }

  // Valid, non-edge pixels on the sampling grid, above the floor margin, in the robot frame.
  // Throws std::invalid_argument for a frame with other intrinsics.
  void project(const DepthFrame& frame, const Eigen::Isometry3f& T_R_S, PointSet& out) const;

  // Whether pixel (u, v) lies on a resolved surface: valid, in range, and all four neighbours
  // within tolerance. Border pixels are never surface pixels.
  bool isSurface(const DepthFrame& frame, int u, int v) const {
    const std::optional<Neighbours> n = neighboursOf(frame, u, v);
    return n && n->holes == 0 && !n->edge;
  }
  // For a pixel that would be a surface pixel but for one of its four neighbours, which returns
  // nothing: the step towards that neighbour. Nothing for any other pixel.
  std::optional<Eigen::Vector2i> holeBeside(const DepthFrame& frame, int u, int v) const {
    const std::optional<Neighbours> n = neighboursOf(frame, u, v);
    if (!n || n->holes != 1 || n->edge) return std::nullopt;
    return n->hole;
  }

 private:
  // How far a neighbour may lie from depth z_mm: k steps of z^2 / (8 f b), with z in metres.
  float toleranceAt_mm(float z_mm) const { return tolerance_per_m2_ * z_mm * z_mm * 1e-3f; }

  // Pixel (u, v)'s four neighbours against its depth: how many return nothing (and the step to the
  // last of them), and whether any lies beyond the tolerance. Nothing for a border pixel or a depth
  // out of range.
  struct Neighbours {
    int holes = 0;
    Eigen::Vector2i hole = Eigen::Vector2i::Zero();
    bool edge = false;
  };
  std::optional<Neighbours> neighboursOf(const DepthFrame& frame, int u, int v) const {
    if (u <= 0 || v <= 0 || u >= frame.width() - 1 || v >= frame.height() - 1) return std::nullopt;
    const std::uint16_t* d = &frame.depth_mm[static_cast<std::size_t>(v) * frame.width() + u];
    const float z_mm = d[0];
    if (z_mm < min_mm_ || z_mm > max_mm_) return std::nullopt;
    const float tolerance_mm = toleranceAt_mm(z_mm);
    const int stride = frame.width();
    Neighbours n;
    for (const auto& [offset, step] :
         {std::pair{-1, Eigen::Vector2i(-1, 0)}, std::pair{1, Eigen::Vector2i(1, 0)},
          std::pair{-stride, Eigen::Vector2i(0, -1)}, std::pair{stride, Eigen::Vector2i(0, 1)}}) {
      const std::uint16_t depth = d[offset];
      if (depth == 0) {
        ++n.holes;
        n.hole = step;
      } else {
        n.edge |= std::abs(float(depth) - z_mm) > tolerance_mm;
      }
    }
    return n;
  }

  Config config_;
  float min_mm_ = 0, max_mm_ = 0;
  float tolerance_per_m2_ = 0;  // edge_tolerance_steps / (8 f b)
  Intrinsics intrinsics_;
  std::vector<float> column_x_;  // (u - cx) / fx per column
  std::vector<float> row_y_;     // (v - cy) / fy per row
};

}  // namespace kinect3d
