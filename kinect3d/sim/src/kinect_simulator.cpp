#include "kinect3d/sim/kinect_simulator.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "colour_renderer.h"
#include "kinect3d/camera_file.h"
#include "kinect3d/depth_noise.h"
#include "kinect3d/kinect_disparity.h"
#include "ray_cast.h"

namespace kinect3d::sim {

namespace {

constexpr std::int16_t kIdNone = -1;
constexpr std::int16_t kIdFloor = 0;
// Shapes are 1..N; the ball and its partly covered trail pixels come after every shape id.
constexpr std::int16_t kIdBall = 30000;
constexpr std::int16_t kIdTrail = 30001;
constexpr std::int16_t kIdBallDark = 30002;  // the ball's black panels: no depth
constexpr int kBlurSamples = 8;

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
    return pixelRectOf(corners, scene->intrinsics, 2.0 + 4.0 * scene->noise.lateral_noise_px);
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
        const PlacedShape shape_S = placeShape(shape, offset_F, T_F_S);
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

  // A classic ball's black pentagons, where they return no depth.
  bool dark_panels = false;

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
          id[i] = dark_panels && onBallPanel(T_F_S.linear() * (d * depth_m[i] + ball_at[samples / 2].o_L)) ? kIdBallDark
                                                                                                           : kIdBall;
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
        double sigma = noise.axial_noise_scale * DepthNoiseModel::axialSigma_m(z) * 8.0 * fb / (z * z);
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
    ball_motion_ = std::make_unique<BallMotion>(*scene_.ball, scene_.physics,
                                                scene_.duration_s + scene_.noise.exposure_s, scene_.objects);
  }
  renderer_->resize(static_cast<std::size_t>(scene_.intrinsics.width) * scene_.intrinsics.height);
  renderer_->scene = &scene_;
  renderer_->dark_panels = scene_.ball && scene_.ball->dark_panels;
}

void KinectSimulator::setColour(bool on) { colour_renderer_ = on ? std::make_unique<ColourRenderer>(scene_) : nullptr; }

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
  if (colour_renderer_) {
    const ColourCamera camera = ColourCamera::kinectV1();
    frame.colour = camera.image(colour_renderer_->render(t, r.T_F_S, ball_motion_.get(), camera, frame_index),
                                frame.source_time_s);
  }
}

}  // namespace kinect3d::sim
