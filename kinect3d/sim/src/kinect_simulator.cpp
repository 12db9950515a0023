#include "kinect3d/sim/kinect_simulator.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "kinect3d/camera_file.h"
#include "kinect3d/depth_noise.h"
#include "kinect3d/kinect_disparity.h"

namespace kinect3d::sim {

namespace {

constexpr float kNoHit = std::numeric_limits<float>::infinity();
constexpr std::int16_t kIdNone = -1;
constexpr std::int16_t kIdFloor = 0;
// Shapes are 1..N; the ball and its partly covered trail pixels come after every shape id.
constexpr std::int16_t kIdBall = 30000;
constexpr std::int16_t kIdTrail = 30001;
constexpr std::int16_t kIdBallDark = 30002;  // the ball's black panels: no depth
constexpr int kBlurSamples = 8;

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
    static const std::array<float, 4096> values = [] {
      std::array<float, 4096> t{};
      for (std::size_t i = 0; i < t.size(); ++i) {
        // Inverse normal CDF by bisection on erfc: run once.
        const double p = (i + 0.5) / t.size();
        double lo = -10, hi = 10;
        for (int k = 0; k < 100; ++k) {
          const double mid = 0.5 * (lo + hi);
          (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
        }
        t[i] = static_cast<float>(0.5 * (lo + hi));
      }
      return t;
    }();
    return values;
  }
  std::array<std::uint64_t, 4> s_;
};

// The nearest hit in front of o along o + t d: of a sphere of radius r round the origin, and of the
// side of an upright cylinder of radius r standing on the origin, height high.
double sphereHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double r) {
  const double b = o.dot(d), disc = b * b - d.squaredNorm() * (o.squaredNorm() - r * r);
  if (disc < 0.0) return kNoHit;
  const double t = (-b - std::sqrt(disc)) / d.squaredNorm();
  return t > 0.0 ? t : kNoHit;
}
double sideHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double r, double height) {
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

// Distance from a point to a shape's surface (0 inside), in the field frame.
double distanceToShape(const Shape& shape, const Eigen::Vector3d& offset_F, const Eigen::Vector3d& p_F) {
  const Eigen::Vector3d rel = p_F - (shape.center_m + offset_F);
  const Eigen::Vector3d p = Eigen::AngleAxisd(-shape.yaw_rad, Eigen::Vector3d::UnitZ()) * rel;
  switch (shape.kind) {
    case Shape::Kind::kSphere:
      return std::max(0.0, p.norm() - shape.size_m.x() / 2);
    case Shape::Kind::kBox:
      return (p.cwiseAbs() - shape.size_m / 2).cwiseMax(0.0).norm();
    case Shape::Kind::kCapsule: {
      const Eigen::Vector3d& axis = shape.axis_m;
      const double s = std::clamp(rel.dot(axis) / std::max(axis.squaredNorm(), 1e-12), 0.0, 1.0);
      return std::max(0.0, (rel - s * axis).norm() - shape.size_m.x() / 2);
    }
    case Shape::Kind::kCylinder: {
      const double radial = std::max(0.0, p.head<2>().norm() - shape.size_m.x() / 2);
      const double vertical = std::max({0.0, -p.z(), p.z() - shape.size_m.z()});
      return std::hypot(radial, vertical);
    }
  }
  return 0.0;
}

struct PixelRect {
  int u0, v0, u1, v1;  // inclusive-exclusive
  bool empty() const { return u0 >= u1 || v0 >= v1; }
};

}  // namespace

// Renders one frame, stage by stage, into buffers kept between frames (so rendering allocates
// nothing once warm). The stages draw from one random stream in a fixed order, so a frame depends
// only on the scene, the seed and its index.
struct KinectSimulator::Renderer {
  std::vector<float> depth_m;          // optical depth of the nearest surface, kNoHit for none
  std::vector<std::int16_t> id;        // what is there: kIdNone, kIdFloor, shape index + 1, ball
  std::vector<float> disparity_px;     // f b / z after geometry effects, 0 = no data
  std::vector<float> clean_disparity;  // before edge effects, for the edge test
  std::vector<float> jitter;           // lateral noise: (du, dv) per pixel
  std::vector<double> shape_dropout;   // by id
  std::vector<PlacedShape> placed;

  // The frame being rendered.
  const Scene* scene = nullptr;
  Eigen::Isometry3d T_F_S = Eigen::Isometry3d::Identity();  // where the sensor is in the field now
  bool jittered = false;

  void resize(std::size_t pixels) {
    depth_m.resize(pixels);
    id.resize(pixels);
    disparity_px.resize(pixels);
    clean_disparity.resize(pixels);
    jitter.resize(2 * pixels);
  }

  int width() const { return scene->intrinsics.width; }
  int height() const { return scene->intrinsics.height; }

  // Where each pixel's ray really looks: the lateral noise of the correlation window.
  void jitterRays(Random& random) {
    jittered = scene->noise.lateral_noise_px > 0.0;
    if (!jittered) return;
    for (float& j : jitter) j = static_cast<float>(scene->noise.lateral_noise_px) * random.normal();
  }

  // The direction pixel (u, v) looks along, in the sensor frame (z = 1).
  Eigen::Vector3d ray(int u, int v) const {
    const std::size_t i = static_cast<std::size_t>(v) * width() + u;
    const double du = jittered ? jitter[2 * i] : 0.0, dv = jittered ? jitter[2 * i + 1] : 0.0;
    return scene->intrinsics.backProject(u + du, v + dv, 1.0);
  }

  // The pixels a box with these corners (sensor frame) can cover, with a margin for the jitter.
  PixelRect rectOf(const std::array<Eigen::Vector3d, 8>& corners) const {
    const int W = width(), H = height();
    double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
    for (const auto& c : corners) {
      if (c.z() < 0.05) return PixelRect{0, 0, W, H};  // reaches behind the sensor: test everywhere
      const Eigen::Vector2d px = scene->intrinsics.project(c);
      u0 = std::min(u0, px.x()), u1 = std::max(u1, px.x()), v0 = std::min(v0, px.y()), v1 = std::max(v1, px.y());
    }
    const double margin = 2.0 + 4.0 * scene->noise.lateral_noise_px;
    return PixelRect{std::max(0, int(std::floor(u0 - margin))), std::max(0, int(std::floor(v0 - margin))),
                     std::min(W, int(std::ceil(u1 + margin)) + 1), std::min(H, int(std::ceil(v1 + margin)) + 1)};
  }

  // 1. Geometry: the floor, then every obstacle shape where it stands at time t.
  void castGeometry(double t) {
    const int W = width(), H = height();
    const Eigen::Matrix3d R_F_S = T_F_S.linear();
    const Eigen::Vector3d o_F = T_F_S.translation();
    for (int v = 0; v < H; ++v) {
      for (int u = 0; u < W; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * W + u;
        depth_m[i] = kNoHit;
        id[i] = kIdNone;
        if (!scene->floor) continue;
        const double down = (R_F_S * ray(u, v)).z();
        if (down < -1e-9) {
          depth_m[i] = static_cast<float>(-o_F.z() / down);
          id[i] = kIdFloor;
        }
      }
    }
    placed.clear();
    shape_dropout.assign(1, 0.0);
    for (const SceneObject& object : scene->objects) {
      const Eigen::Vector3d offset_F = object.displacementAt(t);
      for (const Shape& shape : object.shapes) {
        // The shape's local frame: turned by its yaw, or for a capsule with z along its axis.
        const Eigen::Matrix3d R_L_F =
            shape.kind == Shape::Kind::kCapsule
                ? Eigen::Quaterniond::FromTwoVectors(shape.axis_m, Eigen::Vector3d::UnitZ()).toRotationMatrix()
                : Eigen::AngleAxisd(-shape.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        PlacedShape shape_S{shape.kind, R_L_F * R_F_S, R_L_F * (o_F - shape.center_m - offset_F), shape.size_m / 2.0};
        if (shape.kind == Shape::Kind::kCylinder) shape_S.half.z() = shape.size_m.z();
        if (shape.kind == Shape::Kind::kCapsule) shape_S.half.z() = shape.axis_m.norm();
        placed.push_back(shape_S);
        shape_dropout.push_back(shape.dropout);
        const std::int16_t shape_id = static_cast<std::int16_t>(placed.size());
        const PixelRect rect = rectOf(shape_S.corners_S());
        for (int v = rect.v0; v < rect.v1; ++v) {
          for (int u = rect.u0; u < rect.u1; ++u) {
            const std::size_t i = static_cast<std::size_t>(v) * W + u;
            const double z = shape_S.intersect(ray(u, v));
            if (z < depth_m[i]) {
              depth_m[i] = static_cast<float>(z);
              id[i] = shape_id;
            }
          }
        }
      }
    }
  }

  // A classic ball's black pentagons sit round the 12 vertices of an icosahedron (six axes, both
  // ways), each a cap of 17.6 degrees (12 of them cover 28 % of the sphere); fixed in the field.
  bool dark_panels = false;
  bool onDarkPanel(const Eigen::Vector3d& from_centre_S) const {
    static const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
    static const std::array<Eigen::Vector3d, 6> axes = {
        Eigen::Vector3d(0, 1, phi).normalized(), Eigen::Vector3d(0, -1, phi).normalized(),
        Eigen::Vector3d(1, phi, 0).normalized(), Eigen::Vector3d(-1, phi, 0).normalized(),
        Eigen::Vector3d(phi, 0, 1).normalized(), Eigen::Vector3d(-phi, 0, 1).normalized()};
    static const double cos_cap = std::cos(17.6 * M_PI / 180.0);
    const Eigen::Vector3d n_F = (T_F_S.linear() * from_centre_S).normalized();
    for (const Eigen::Vector3d& axis : axes) {
      if (std::abs(n_F.dot(axis)) > cos_cap) return true;
    }
    return false;
  }

  // 2. The ball, smeared over the exposure: a pixel it covers for the whole exposure shows the
  //    ball; one it covers part of the time correlates to a disparity between ball and background
  //    (the trail the paper describes).
  void castBall(const BallMotion& motion, double t, Random& random) {
    const int W = width(), H = height();
    const KinectNoise& noise = scene->noise;
    const int samples = noise.exposure_s > 0.0 ? kBlurSamples : 1;
    std::array<PlacedShape, kBlurSamples> ball_at;
    PixelRect rect{W, H, 0, 0};
    for (int k = 0; k < samples; ++k) {
      const double tk = samples == 1 ? t : t + noise.exposure_s * (double(k) / (samples - 1) - 0.5);
      ball_at[k] =
          PlacedShape{Shape::Kind::kSphere, Eigen::Matrix3d::Identity(), -(T_F_S.inverse() * motion.positionAt(tk)),
                      Eigen::Vector3d::Constant(scene->physics.radius_m)};
      const PixelRect rk = rectOf(ball_at[k].corners_S());
      rect = {std::min(rect.u0, rk.u0), std::min(rect.v0, rk.v0), std::max(rect.u1, rk.u1), std::max(rect.v1, rk.v1)};
    }
    for (int v = rect.v0; v < rect.v1; ++v) {
      for (int u = rect.u0; u < rect.u1; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * W + u;
        const Eigen::Vector3d d = ray(u, v);
        int hits = 0;
        double inverse_depth_sum = 0.0;
        for (int k = 0; k < samples; ++k) {
          const double z = ball_at[k].intersect(d);
          if (z < depth_m[i]) {
            ++hits;
            inverse_depth_sum += 1.0 / z;
          }
        }
        if (hits == 0) continue;
        if (hits == samples) {
          depth_m[i] = static_cast<float>(hits / inverse_depth_sum);
          id[i] = dark_panels && onDarkPanel(d * depth_m[i] + ball_at[samples / 2].o_L) ? kIdBallDark : kIdBall;
          continue;
        }
        const double covered = double(hits) / samples;
        const double ball_inverse = inverse_depth_sum / hits;
        if (depth_m[i] == kNoHit) {
          // Nothing behind: the correlation only finds the ball when it dominates the exposure.
          if (random.uniform() < covered) depth_m[i] = static_cast<float>(1.0 / ball_inverse);
        } else {
          depth_m[i] = static_cast<float>(1.0 / (covered * ball_inverse + (1.0 - covered) / depth_m[i]));
        }
        id[i] = kIdTrail;
      }
    }
  }

  // f b: disparity in pixels times depth in metres.
  double focalBaseline() const { return scene->intrinsics.fx * scene->noise.baseline_m; }

  // 3. Disparity f b / z, inside the range limits.
  void toDisparity() {
    const KinectNoise& noise = scene->noise;
    const double fb = focalBaseline();
    for (std::size_t i = 0; i < depth_m.size(); ++i) {
      const float z = depth_m[i];
      disparity_px[i] = (z >= noise.min_range_m && z <= noise.max_range_m) ? float(fb / z) : 0.0f;
    }
  }

  // 4. Projector shadows. The projector sits at +baseline on the optical x axis, so it sees the
  //    point in pixel u at projector column u - disparity; a point is lit only if no nearer point
  //    to its right reaches the same projector column first. Scanning each row from the right
  //    with the smallest projector column seen so far finds every point the projector cannot see.
  void castShadows() {
    const int W = width(), H = height();
    constexpr float kColumnTolerance_px = 0.25f;  // a surface seen at a grazing angle is not its own shadow
    for (int v = 0; v < H; ++v) {
      float* row = &disparity_px[static_cast<std::size_t>(v) * W];
      float min_column = std::numeric_limits<float>::infinity();
      for (int u = W - 1; u >= 0; --u) {
        if (row[u] <= 0.0f) continue;
        const float column = u - row[u];
        if (column > min_column + kColumnTolerance_px) {
          row[u] = 0.0f;  // occluded from the projector: no dots, no depth
        } else {
          min_column = std::min(min_column, column);
        }
      }
    }
  }

  // 5. Depth edges: the 9x9 correlation window straddles both sides. Some edge pixels drop out,
  //    some take a depth in between ('flying pixels'), the rest keep their own side.
  void blurEdges(Random& random) {
    const int W = width(), H = height();
    const KinectNoise& noise = scene->noise;
    clean_disparity = disparity_px;
    constexpr float kEdgeJump_px = 1.0f;  // about 0.37 m at 4 m: a real depth edge
    if (noise.edge_dropout <= 0.0 && noise.flying_pixels <= 0.0) return;
    for (int v = 1; v < H - 1; ++v) {
      for (int u = 1; u < W - 1; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * W + u;
        const float d = clean_disparity[i];
        if (d <= 0.0f) continue;
        float other = 0.0f, jump = kEdgeJump_px;  // the neighbour across the largest edge
        for (const std::size_t j : {i - 1, i + 1, i - W, i + W}) {
          const float dn = clean_disparity[j];
          if (dn > 0.0f && std::abs(dn - d) > jump) other = dn, jump = std::abs(dn - d);
        }
        if (other == 0.0f) continue;
        const double draw = random.uniform();
        if (draw < noise.edge_dropout) {
          disparity_px[i] = 0.0f;
        } else if (draw < noise.edge_dropout + noise.flying_pixels) {
          disparity_px[i] = d + static_cast<float>(random.uniform()) * (other - d);
        }
      }
    }
  }

  // 5b. Where a dark or absorbing surface returns nothing: whole patches of the size of the
  //     Kinect's correlation window, not single pixels (a surface with a share p of its patches
  //     dark loses those patches and keeps the rest intact). Drawn from their own stream, so that
  //     scenes without such surfaces render as before.
  static constexpr int kDarkPatch_px = 8;
  std::vector<float> block_draw;
  int blocks_across = 0;
  std::size_t blockOf(std::size_t pixel) const {
    const int u = static_cast<int>(pixel % width()), v = static_cast<int>(pixel / width());
    return static_cast<std::size_t>(v / kDarkPatch_px) * blocks_across + u / kDarkPatch_px;
  }
  void drawDarkPatches(std::uint64_t seed, int frame_index) {
    Random patches(seed ^ 0xDA4C9A7C4E5ULL, static_cast<std::uint64_t>(frame_index));
    blocks_across = (width() + kDarkPatch_px - 1) / kDarkPatch_px;
    const int down = (height() + kDarkPatch_px - 1) / kDarkPatch_px;
    block_draw.resize(static_cast<std::size_t>(blocks_across) * down);
    for (float& draw : block_draw) draw = static_cast<float>(patches.uniform());
  }

  // 6. Disparity noise and 1/8 px quantisation, dropouts, then millimetres as OpenNI2 gives them.
  //    Returns how many pixels show the ball with valid depth.
  int toDepth(Random& random, DepthFrame& frame) const {
    const KinectNoise& noise = scene->noise;
    const double fb = focalBaseline();
    int ball_pixels = 0;
    for (std::size_t i = 0; i < disparity_px.size(); ++i) {
      const float d = disparity_px[i];
      if (d <= 0.0f) continue;
      const std::int16_t what = id[i];
      double dropout = noise.random_dropout;
      if (what == kIdTrail) dropout += noise.trail_dropout;
      if (dropout > 0.0 && random.uniform() < dropout) continue;
      if (what > 0 && what < kIdBall && block_draw[blockOf(i)] < shape_dropout[what]) continue;
      if (what == kIdBallDark) continue;
      double eighths = 8.0 * d;
      if (noise.axial_noise) {
        const double z = fb / d;
        double sigma = DepthNoiseModel::axialSigma_m(z) * 8.0 * fb / (z * z);
        // Nguyen's sigma was measured on quantised data; rounding adds 1/12 units^2 of its own.
        if (noise.quantisation) sigma = std::sqrt(std::max(sigma * sigma - 1.0 / 12.0, 0.01));
        eighths += sigma * random.normal();
      }
      if (noise.quantisation) eighths = std::round(eighths);
      if (eighths <= 0.0) continue;
      const double z_m = 8.0 * fb / eighths;
      if (z_m < noise.min_range_m || z_m > noise.max_range_m) continue;
      frame.depth_mm[i] = static_cast<std::uint16_t>(std::lround(z_m * 1000.0));
      if (what == kIdBall) ++ball_pixels;
    }
    return ball_pixels;
  }

  // 8. Colour, as the Kinect v1's colour camera beside the depth camera sees it: each surface the
  //    depth camera hit is carried into the colour image (nearest wins); what it did not see is the
  //    dark hall. A flat colour per thing, darker with distance, the ball orange with its dark
  //    panels black: enough to see a scene and its ball by eye, not a model of a camera's light and noise.
  std::vector<std::uint8_t> colour(const ColourCamera& camera) const {
    const Intrinsics& in = camera.intrinsics;
    const std::size_t pixels = static_cast<std::size_t>(in.width) * in.height;
    std::vector<std::uint8_t> rgb(pixels * 3);
    for (std::size_t i = 0; i < pixels; ++i) rgb[3 * i] = 45, rgb[3 * i + 1] = 45, rgb[3 * i + 2] = 50;
    std::vector<float> nearest(pixels, kNoHit);
    const int W = width();
    for (std::size_t i = 0; i < id.size(); ++i) {
      const std::int16_t what = id[i];
      if (what == kIdNone) continue;
      // Through the pixel's centre, without the depth camera's lateral noise: the colour camera has none of it.
      const Eigen::Vector3d p_C =
          scene->intrinsics.backProject(static_cast<double>(i % W), static_cast<double>(i / W), depth_m[i]) -
          camera.offset_S_m;
      if (p_C.z() <= 0.0) continue;
      const Eigen::Vector2d pixel = in.project(p_C);
      const long u = std::lround(pixel.x()), v = std::lround(pixel.y());
      if (u < 0 || v < 0 || u >= in.width || v >= in.height) continue;
      const std::size_t k = static_cast<std::size_t>(v) * in.width + static_cast<std::size_t>(u);
      if (depth_m[i] >= nearest[k]) continue;
      nearest[k] = depth_m[i];
      std::array<int, 3> base{40, 125, 50};  // the floor
      if (what == kIdBall || what == kIdTrail) base = {240, 120, 25};
      if (what == kIdBallDark) base = {20, 20, 20};
      if (what > 0 && what < kIdBall) base = {90 + 41 * what % 110, 90 + 67 * what % 110, 90 + 23 * what % 110};
      const double shade = std::clamp(1.2 - 0.08 * depth_m[i], 0.4, 1.0);
      for (int c = 0; c < 3; ++c) rgb[3 * k + c] = static_cast<std::uint8_t>(base[c] * shade);
    }
    return rgb;
  }
};

namespace {

// 7. Another Kinect's pattern over an ellipse of the view, where it and ours overlap (fixed for the
//    scene): holes of 2-5 px radius over a tenth of it (Maimone and Fuchs measured 16.6 % of a frame
//    missing with five more Kinects overlapping) and clusters of false depth, drawn from their own
//    stream so that scenes without it render as before.
void addInterference(const Scene& scene, int frame_index, DepthFrame& frame) {
  const double strength = scene.noise.interference;
  if (strength <= 0.0) return;
  Random where(scene.noise.seed ^ 0x1E7E4FE4E11CEULL, 0);
  const double cu = frame.width() * (0.2 + 0.6 * where.uniform()), cv = frame.height() * (0.2 + 0.6 * where.uniform());
  const double ru = 100.0 + 120.0 * where.uniform(), rv = 80.0 + 80.0 * where.uniform();
  auto inside = [&](int u, int v) { return std::pow((u - cu) / ru, 2) + std::pow((v - cv) / rv, 2) <= 1.0; };
  Random random(scene.noise.seed ^ 0x1E7E4FE4E11CEULL, static_cast<std::uint64_t>(frame_index) + 1);
  // A disc of radius r px round a random point of the ellipse, set to depth_mm.
  auto disc = [&](double radius, auto depthAt) {
    const int u0 = static_cast<int>(cu + ru * (2.0 * random.uniform() - 1.0));
    const int v0 = static_cast<int>(cv + rv * (2.0 * random.uniform() - 1.0));
    if (u0 < 0 || v0 < 0 || u0 >= frame.width() || v0 >= frame.height() || !inside(u0, v0)) return;
    const std::uint16_t depth_mm = depthAt(frame.at(u0, v0));
    const int reach = static_cast<int>(radius);
    for (int v = std::max(0, v0 - reach); v <= std::min(frame.height() - 1, v0 + reach); ++v) {
      for (int u = std::max(0, u0 - reach); u <= std::min(frame.width() - 1, u0 + reach); ++u) {
        if (std::hypot(u - u0, v - v0) <= radius)
          frame.depth_mm[static_cast<std::size_t>(v) * frame.width() + u] = depth_mm;
      }
    }
  };
  const double mean_hole_px = M_PI * 3.5 * 3.5;
  const int holes = static_cast<int>(std::lround(0.1 * strength * M_PI * ru * rv / mean_hole_px));
  for (int h = 0; h < holes; ++h) disc(2.0 + 3.0 * random.uniform(), [](std::uint16_t) { return std::uint16_t{0}; });
  const int clusters = static_cast<int>(std::lround(60.0 * strength));
  for (int c = 0; c < clusters; ++c) {
    disc(1.0 + 2.0 * random.uniform(), [&](std::uint16_t here) {
      const double z_m = here != 0 ? here * 1e-3 * (0.6 + 0.6 * random.uniform()) : 1.0 + 5.0 * random.uniform();
      return static_cast<std::uint16_t>(std::lround(z_m * 1000.0));
    });
  }
}

}  // namespace

KinectSimulator::KinectSimulator(Scene scene) : scene_(std::move(scene)), renderer_(std::make_unique<Renderer>()) {
  if (scene_.ball) {
    ball_motion_ =
        std::make_unique<BallMotion>(*scene_.ball, scene_.physics, scene_.duration_s + scene_.noise.exposure_s);
  }
  renderer_->resize(static_cast<std::size_t>(scene_.intrinsics.width) * scene_.intrinsics.height);
  renderer_->scene = &scene_;
  renderer_->dark_panels = scene_.ball && scene_.ball->dark_panels;
}

KinectSimulator::~KinectSimulator() = default;

GroundTruth KinectSimulator::truthAt(int frame_index, double t) const {
  GroundTruth truth;
  truth.frame_index = static_cast<std::uint64_t>(frame_index);
  truth.time_s = t;
  truth.robot_pose = scene_.robot.poseAt(t);
  truth.robot_pose.stamp.source_time_s = scene_.start_time_s + t;
  if (!ball_motion_) return truth;
  const double radius = scene_.physics.radius_m;
  constexpr double kAirborneAbove_m = 0.01;  // above resting height: in the air
  truth.has_ball = true;
  truth.ball_center_F = ball_motion_->positionAt(t);
  truth.ball_velocity_F = ball_motion_->velocityAt(t);
  const Eigen::Isometry3d T_R_F = truth.robot_pose.T_F_R().inverse();
  truth.ball_center_R = T_R_F * truth.ball_center_F;
  truth.ball_velocity_R = T_R_F.linear() * truth.ball_velocity_F;
  truth.airborne = truth.ball_center_F.z() > radius + kAirborneAbove_m;
  truth.clearance_m = std::numeric_limits<double>::infinity();
  for (const SceneObject& object : scene_.objects) {
    for (const Shape& shape : object.shapes) {
      truth.clearance_m =
          std::min(truth.clearance_m, distanceToShape(shape, object.displacementAt(t), truth.ball_center_F) - radius);
    }
  }
  truth.clearance_m = std::max(0.0, truth.clearance_m);
  return truth;
}

void KinectSimulator::render(int frame_index, DepthFrame& frame, GroundTruth& truth) {
  Renderer& r = *renderer_;
  Random random(scene_.noise.seed, static_cast<std::uint64_t>(frame_index));
  const double t = frame_index / scene_.fps;
  r.jitterRays(random);
  r.T_F_S = scene_.robot.poseAt(t).T_F_R() * scene_.sensorPoseAt(t).T_R_S();
  r.castGeometry(t);
  truth = truthAt(frame_index, t);
  if (ball_motion_) r.castBall(*ball_motion_, t, random);
  r.toDisparity();
  if (scene_.noise.shadows) r.castShadows();
  r.blurEdges(random);
  frame.resize(scene_.intrinsics);
  frame.index = static_cast<std::uint64_t>(frame_index);
  frame.source_time_s = scene_.start_time_s + t;
  frame.sensor_id = "sim:" + scene_.name;
  r.drawDarkPatches(scene_.noise.seed, frame_index);
  truth.visible_pixels = r.toDepth(random, frame);
  addInterference(scene_, frame_index, frame);
  // What the Kinect v1's accelerometer reads on a level robot: gravity alone (the robot's own
  // accelerations are left out).
  frame.gravity_S_mps2 = r.T_F_S.linear().transpose() * Eigen::Vector3d(0.0, 0.0, -kStandardGravity_mps2);
  if (colour_) {
    const ColourCamera camera = ColourCamera::kinectV1();
    frame.colour = camera.image(r.colour(camera), frame.source_time_s);
  }
}

}  // namespace kinect3d::sim
