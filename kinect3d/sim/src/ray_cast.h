// Ray casting shared by the depth and the colour renderers (kinect_simulator.cpp,
// colour_renderer.cpp): the random stream, shapes placed for casting from a camera's origin, and
// the classic ball's panel pattern.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include <Eigen/Geometry>

#include "kinect3d/depth_frame.h"
#include "kinect3d/sim/scene.h"

namespace kinect3d::sim {

inline constexpr float kNoHit = std::numeric_limits<float>::infinity();
// xoshiro256** seeded by splitmix64: fast, and a frame's noise depends only on (seed, frame).
class Random {
 public:
  Random(std::uint64_t seed, std::uint64_t stream) {
    std::uint64_t x = seed * 0x9E3779B97F4A7C15ULL ^ (stream + 0x632BE59BD9B4E019ULL);
    for (auto& word : s_) {
      x += 0x9E3779B97F4A7C15ULL;
      std::uint64_t z = x;
      z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
      z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
      word = z ^ (z >> 31);
    }
  }
  std::uint64_t next() {
    const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  double uniform() { return (next() >> 11) * 0x1.0p-53; }
  // Standard normal from a precomputed table (inverse CDF at 4096 midpoints): far cheaper than
  // Box-Muller for the million draws a frame needs, and exact in variance to 0.1 %.
  float normal() { return table()[next() >> 52]; }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  static const std::array<float, 4096>& table() {
    static const std::array<float, 4096> values = inverseNormalCdfTable();
    return values;
  }
  // Inverse normal CDF by bisection on erfc, run once. A plain function, not a lambda: GCC tried the
  // lambda as a constant initialiser, which cost every file including this header 7-14 s of build.
  static std::array<float, 4096> inverseNormalCdfTable() {
    std::array<float, 4096> t{};
    for (std::size_t i = 0; i < t.size(); ++i) {
      const double p = (i + 0.5) / t.size();
      double lo = -10, hi = 10;
      for (int k = 0; k < 100; ++k) {
        const double mid = 0.5 * (lo + hi);
        (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
      }
      t[i] = static_cast<float>(0.5 * (lo + hi));
    }
    return t;
  }
  std::array<std::uint64_t, 4> s_;
};

// The nearest hit in front of o along o + t d: of a sphere of radius r round the origin, and of the
// side of an upright cylinder of radius r standing on the origin, height high.
inline double sphereHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double r) {
  const double b = o.dot(d), disc = b * b - d.squaredNorm() * (o.squaredNorm() - r * r);
  if (disc < 0.0) return kNoHit;
  const double t = (-b - std::sqrt(disc)) / d.squaredNorm();
  return t > 0.0 ? t : kNoHit;
}
inline double sideHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double r, double height) {
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a <= 1e-12) return kNoHit;
  const double b = o.x() * d.x() + o.y() * d.y();
  const double disc = b * b - a * (o.x() * o.x() + o.y() * o.y() - r * r);
  if (disc < 0.0) return kNoHit;
  const double t = (-b - std::sqrt(disc)) / a;
  const double z = o.z() + t * d.z();
  return t > 0.0 && z >= 0.0 && z <= height ? t : kNoHit;
}

// A shape at one instant, prepared for ray casting from the sensor origin: the ray o + t d with
// d = ((u - cx)/fx, (v - cy)/fy, 1) in the sensor frame hits at optical depth t.
struct PlacedShape {
  Shape::Kind kind;
  Eigen::Matrix3d R_L_S;  // sensor directions into the shape's local frame
  Eigen::Vector3d o_L;    // the sensor origin in the local frame
  Eigen::Vector3d half;   // box half extents; cylinder (r, r, height); sphere (r, r, r); capsule (r, r, length)

  // Optical depth of the nearest hit in front of the sensor, or infinity.
  double intersect(const Eigen::Vector3d& d_S) const {
    const Eigen::Vector3d d = R_L_S * d_S;
    const Eigen::Vector3d& o = o_L;
    switch (kind) {
      case Shape::Kind::kSphere:
        return sphereHit(o, d, half.x());
      case Shape::Kind::kBox: {
        double t_min = 0.0, t_max = kNoHit;
        for (int i = 0; i < 3; ++i) {
          if (std::abs(d[i]) < 1e-12) {
            if (std::abs(o[i]) > half[i]) return kNoHit;
            continue;
          }
          double t1 = (-half[i] - o[i]) / d[i], t2 = (half[i] - o[i]) / d[i];
          if (t1 > t2) std::swap(t1, t2);
          t_min = std::max(t_min, t1);
          t_max = std::min(t_max, t2);
          if (t_min > t_max) return kNoHit;
        }
        return t_min > 0.0 ? t_min : kNoHit;
      }
      case Shape::Kind::kCapsule: {
        // The segment runs from the local origin up z for half.z(); nearest of its side and end balls.
        const double r = half.x(), length = half.z();
        const Eigen::Vector3d along_z(0.0, 0.0, length);
        return std::min({sideHit(o, d, r, length), sphereHit(o, d, r), sphereHit(o - along_z, d, r)});
      }
      case Shape::Kind::kCylinder: {
        const double r = half.x(), height = half.z();
        double best = sideHit(o, d, r, height);
        for (const double cap_z : {0.0, height}) {
          if (std::abs(d.z()) < 1e-12) break;
          const double t = (cap_z - o.z()) / d.z();
          const double x = o.x() + t * d.x(), y = o.y() + t * d.y();
          if (t > 0.0 && t < best && x * x + y * y <= r * r) best = t;
        }
        return best;
      }
    }
    return kNoHit;
  }

  // Corners of the local bounding box, in the sensor frame.
  std::array<Eigen::Vector3d, 8> corners_S() const {
    const double z_lo = kind == Shape::Kind::kCylinder ? 0.0 : kind == Shape::Kind::kCapsule ? -half.x() : -half.z();
    const double z_hi = kind == Shape::Kind::kCapsule ? half.z() + half.x() : half.z();
    std::array<Eigen::Vector3d, 8> corners;
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector3d p_L((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(), (i & 4) ? z_hi : z_lo);
      corners[i] = R_L_S.transpose() * (p_L - o_L);
    }
    return corners;
  }
};

struct PixelRect {
  int u0, v0, u1, v1;  // inclusive-exclusive
  bool empty() const { return u0 >= u1 || v0 >= v1; }
};

// A rotation that turns direction a onto +z, about which a capsule is symmetric: its rows are a
// right-handed basis ending in a. (Eigen's Quaternion::FromTwoVectors does it too, but brings in an
// SVD that cost each file including this header seconds of build.)
inline Eigen::Matrix3d rotationTakingToZ(const Eigen::Vector3d& a) {
  if (a.squaredNorm() < 1e-24) return Eigen::Matrix3d::Identity();
  const Eigen::Vector3d z = a.normalized();
  const Eigen::Vector3d helper = std::abs(z.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d x = helper.cross(z).normalized();
  Eigen::Matrix3d R;
  R.row(0) = x;
  R.row(1) = z.cross(x);
  R.row(2) = z;
  return R;
}

// A shape where it stands (moved by offset_F), placed for casting from a camera at T_F_C (a camera
// frame with the sensor's optical axes).
inline PlacedShape placeShape(const Shape& shape, const Eigen::Vector3d& offset_F, const Eigen::Isometry3d& T_F_C) {
  // The shape's local frame: turned by its yaw, or for a capsule with z along its axis.
  const Eigen::Matrix3d R_L_F = shape.kind == Shape::Kind::kCapsule
                                    ? rotationTakingToZ(shape.axis_m)
                                    : Eigen::AngleAxisd(-shape.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  PlacedShape placed{shape.kind, R_L_F * T_F_C.linear(), R_L_F * (T_F_C.translation() - shape.center_m - offset_F),
                     shape.size_m / 2.0};
  if (shape.kind == Shape::Kind::kCylinder) placed.half.z() = shape.size_m.z();
  if (shape.kind == Shape::Kind::kCapsule) placed.half.z() = shape.axis_m.norm();
  return placed;
}

// The pixels a box with these corners (camera frame) can cover in a camera, with a margin.
inline PixelRect pixelRectOf(const std::array<Eigen::Vector3d, 8>& corners, const Intrinsics& in, double margin_px) {
  double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
  for (const auto& c : corners) {
    if (c.z() < 0.05) return PixelRect{0, 0, in.width, in.height};  // reaches behind the camera: test everywhere
    const Eigen::Vector2d px = in.project(c);
    u0 = std::min(u0, px.x()), u1 = std::max(u1, px.x()), v0 = std::min(v0, px.y()), v1 = std::max(v1, px.y());
  }
  return PixelRect{std::max(0, int(std::floor(u0 - margin_px))), std::max(0, int(std::floor(v0 - margin_px))),
                   std::min(in.width, int(std::ceil(u1 + margin_px)) + 1),
                   std::min(in.height, int(std::ceil(v1 + margin_px)) + 1)};
}

// A classic ball's black pentagons sit round the 12 vertices of an icosahedron (six axes, both
// ways), each a cap of 17.6 degrees (12 of them cover 28 % of the sphere). n_F: the direction from
// the ball's centre, in the field frame (the pattern does not turn).
inline bool onBallPanel(const Eigen::Vector3d& n_F) {
  static const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
  static const std::array<Eigen::Vector3d, 6> axes = {
      Eigen::Vector3d(0, 1, phi).normalized(), Eigen::Vector3d(0, -1, phi).normalized(),
      Eigen::Vector3d(1, phi, 0).normalized(), Eigen::Vector3d(-1, phi, 0).normalized(),
      Eigen::Vector3d(phi, 0, 1).normalized(), Eigen::Vector3d(-phi, 0, 1).normalized()};
  static const double cos_cap = std::cos(17.6 * M_PI / 180.0);
  const Eigen::Vector3d n = n_F.normalized();
  for (const Eigen::Vector3d& axis : axes) {
    if (std::abs(n.dot(axis)) > cos_cap) return true;
  }
  return false;
}

}  // namespace kinect3d::sim
