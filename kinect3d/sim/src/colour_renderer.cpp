#include "colour_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "ray_cast.h"

namespace kinect3d::sim {

namespace {

constexpr int kSurfaces = static_cast<int>(Surface::kPoster) + 1;
constexpr int kBlurSamples = 8;
constexpr double kLampRadiance = 4.0;  // a lamp's light against a white wall's 0.8: it saturates

// A colour from hue (degrees), saturation and value as a person picks it, in linear RGB.
Eigen::Vector3d fromHsv(double hue_deg, double saturation, double value) {
  const double h = std::fmod(hue_deg, 360.0) / 60.0, c = value * saturation;
  const double x = c * (1.0 - std::abs(std::fmod(h, 2.0) - 1.0)), m = value - c;
  Eigen::Vector3d rgb;
  switch (static_cast<int>(h)) {
    case 0:
      rgb = {c, x, 0};
      break;
    case 1:
      rgb = {x, c, 0};
      break;
    case 2:
      rgb = {0, c, x};
      break;
    case 3:
      rgb = {0, x, c};
      break;
    case 4:
      rgb = {x, 0, c};
      break;
    default:
      rgb = {c, 0, x};
      break;
  }
  return (rgb.array() + m).pow(2.2).matrix();  // perceived (gamma-encoded) to linear
}

// One colour for a surface of one object, drawn from the scene's stream.
Eigen::Vector3d drawAlbedo(Surface surface, Random& random) {
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * random.uniform(); };
  // A colour drawn within ranges of hue (deg), saturation and value, one draw a statement, value
  // first: as fromHsv's arguments their order was the compiler's.
  auto drawHsv = [&](double h_lo, double h_hi, double s_lo, double s_hi, double v_lo, double v_hi) {
    const double v = uniform(v_lo, v_hi);
    const double s = uniform(s_lo, s_hi);
    return fromHsv(uniform(h_lo, h_hi), s, v);
  };
  switch (surface) {
    case Surface::kPlain:
    case Surface::kPoster:  // the poster's own ground
      return drawHsv(0, 360, 0.0, 0.3, 0.35, 0.85);
    case Surface::kShirt:
      // Any colour; one shirt in four orange or yellow, like a match ball.
      if (random.uniform() < 0.25) return drawHsv(15, 55, 0.8, 1.0, 0.8, 1.0);
      return drawHsv(0, 360, 0.1, 1.0, 0.15, 0.95);
    case Surface::kTrousers:
      return drawHsv(0, 360, 0.0, 0.6, 0.08, 0.5);
    case Surface::kSkin: {
      const double tone = random.uniform();  // from fair to dark skin
      const double s = uniform(0.25, 0.5);
      return fromHsv(uniform(15, 30), s, 0.9 - 0.6 * tone);
    }
    case Surface::kHair: {
      const std::array<Eigen::Vector3d, 4> hair = {fromHsv(20, 0.3, 0.08), fromHsv(25, 0.6, 0.3),
                                                   fromHsv(45, 0.5, 0.75), fromHsv(0, 0.0, 0.6)};
      return hair[static_cast<std::size_t>(random.uniform() * hair.size())];
    }
    case Surface::kFlag: {
      const std::array<Eigen::Vector3d, 3> flag = {fromHsv(55, 0.95, 0.95), fromHsv(0, 0.95, 0.85),
                                                   fromHsv(25, 0.95, 0.95)};
      return flag[static_cast<std::size_t>(random.uniform() * flag.size())];
    }
    case Surface::kRobot:
      return Eigen::Vector3d::Constant(0.03);
    case Surface::kGoal:
      return Eigen::Vector3d::Constant(0.8);
    case Surface::kLamp: {
      const double s = uniform(0.0, 0.15);
      return kLampRadiance * fromHsv(uniform(30, 60), s, 1.0);
    }
    case Surface::kLoudspeaker:
      return Eigen::Vector3d::Constant(0.025);
  }
  return Eigen::Vector3d::Constant(0.5);
}

// The field's carpet and its white lines (MSL: 22 x 14 m, lines 12.5 cm wide), at a floor point.
Eigen::Vector3d floorAlbedo(const Eigen::Vector3d& p_F) {
  const double x = std::abs(p_F.x()), y = std::abs(p_F.y()), w = 0.0625;
  auto near = [&](double value, double line) { return std::abs(value - line) <= w; };
  const bool line = (near(x, 7.0) && y <= 11.0 + w) || (near(y, 11.0) && x <= 7.0 + w) || near(y, 0.0) ||
                    near(std::hypot(p_F.x(), p_F.y()), 2.0) ||  // centre circle
                    (near(y, 11.0 - 2.25) && x <= 3.25) || (near(x, 3.25) && y >= 8.75 && y <= 11.0) ||  // penalty area
                    (near(y, 11.0 - 0.75) && x <= 1.75) || (near(x, 1.75) && y >= 10.25 && y <= 11.0);   // goal area
  return line ? Eigen::Vector3d(0.75, 0.75, 0.75) : Eigen::Vector3d(0.05, 0.25, 0.05);
}

// The outward normal of a placed shape at a local point on its surface (local frame).
Eigen::Vector3d normalAt(const PlacedShape& shape, const Eigen::Vector3d& p_L) {
  switch (shape.kind) {
    case Shape::Kind::kSphere:
      return p_L.normalized();
    case Shape::Kind::kBox: {
      int axis = 0;
      for (int i = 1; i < 3; ++i) {
        if (std::abs(p_L[i]) / shape.half[i] > std::abs(p_L[axis]) / shape.half[axis]) axis = i;
      }
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      n[axis] = p_L[axis] > 0 ? 1.0 : -1.0;
      return n;
    }
    case Shape::Kind::kCapsule: {
      const double s = std::clamp(p_L.z(), 0.0, shape.half.z());
      return (p_L - Eigen::Vector3d(0, 0, s)).normalized();
    }
    case Shape::Kind::kCylinder:
      if (p_L.z() >= shape.half.z() - 1e-6) return Eigen::Vector3d::UnitZ();
      if (p_L.z() <= 1e-6) return -Eigen::Vector3d::UnitZ();
      return Eigen::Vector3d(p_L.x(), p_L.y(), 0.0).normalized();
  }
  return Eigen::Vector3d::UnitZ();
}

// sRGB encoding of a linear value in [0, 1], by table.
std::uint8_t encode(double linear) {
  static const std::array<std::uint8_t, 4096> table = [] {
    std::array<std::uint8_t, 4096> t{};
    for (std::size_t i = 0; i < t.size(); ++i) {
      const double c = i / double(t.size() - 1);
      const double e = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
      t[i] = static_cast<std::uint8_t>(std::lround(255.0 * e));
    }
    return t;
  }();
  return table[static_cast<std::size_t>(std::clamp(linear, 0.0, 1.0) * (table.size() - 1))];
}

}  // namespace

ColourRenderer::ColourRenderer(const Scene& scene) : scene_(scene) {
  Random random(scene.noise.seed ^ 0xC010C010ULL, 0);
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    std::vector<Eigen::Vector3d> albedo(kSurfaces);
    for (int s = 0; s < kSurfaces; ++s)
      albedo[static_cast<std::size_t>(s)] = drawAlbedo(static_cast<Surface>(s), random);
    surface_albedo_.push_back(albedo);
  }
  const double azimuth = 2.0 * M_PI * random.uniform(), elevation = 0.9 + 0.5 * random.uniform();
  light_from_F_ = Eigen::Vector3d(std::cos(azimuth) * std::cos(elevation), std::sin(azimuth) * std::cos(elevation),
                                  std::sin(elevation));
  const double slope_direction = 2.0 * M_PI * random.uniform();
  light_slope_ = scene.look.light_gradient * Eigen::Vector2d(std::cos(slope_direction), std::sin(slope_direction));
}

Eigen::Vector3d ColourRenderer::albedoOf(std::size_t object, const Shape& shape) const {
  if (shape.albedo) return *shape.albedo;
  return surface_albedo_[object][static_cast<std::size_t>(shape.surface)];
}

std::vector<std::uint8_t> ColourRenderer::render(double t, const Eigen::Isometry3d& T_F_S, const BallMotion* ball,
                                                 const ColourCamera& camera, int frame_index) {
  const Intrinsics& in = camera.intrinsics;
  const int W = in.width, H = in.height;
  const std::size_t pixels = static_cast<std::size_t>(W) * H;
  Eigen::Isometry3d T_F_C = T_F_S;
  T_F_C.translate(camera.offset_S_m);
  const Eigen::Matrix3d R_F_C = T_F_C.linear();
  const Eigen::Vector3d o_F = T_F_C.translation();
  auto ray = [&](int u, int v) { return in.backProject(u, v, 1.0); };

  // Radiance reaching each pixel before the light's level and slope: albedo times shading.
  nearest_.assign(pixels, kNoHit);
  radiance_.assign(pixels, Eigen::Vector3f::Constant(0.02f));  // the dark hall
  std::vector<float>& nearest = nearest_;
  std::vector<Eigen::Vector3f>& radiance = radiance_;
  auto shade = [&](const Eigen::Vector3d& n_F) { return 0.55 + 0.45 * std::max(0.0, n_F.dot(light_from_F_)); };
  if (scene_.floor) {
    const Eigen::Vector3f shaded_up = Eigen::Vector3f::Constant(static_cast<float>(shade(Eigen::Vector3d::UnitZ())));
    for (int v = 0; v < H; ++v) {
      for (int u = 0; u < W; ++u) {
        const Eigen::Vector3d d_F = R_F_C * ray(u, v);
        if (d_F.z() >= -1e-9) continue;
        const double s = -o_F.z() / d_F.z();
        const std::size_t i = static_cast<std::size_t>(v) * W + u;
        nearest[i] = static_cast<float>(s);  // the ray's z is 1: s is the optical depth
        radiance[i] = floorAlbedo(o_F + s * d_F).cast<float>().cwiseProduct(shaded_up);
      }
    }
  }
  for (std::size_t o = 0; o < scene_.objects.size(); ++o) {
    const SceneObject& object = scene_.objects[o];
    const Eigen::Vector3d offset_F = object.displacementAt(t);
    for (const Shape& shape : object.shapes) {
      const PlacedShape placed = placeShape(shape, offset_F, T_F_C);
      const PixelRect rect = pixelRectOf(placed.corners_S(), in, 2.0);
      const Eigen::Vector3d albedo = albedoOf(o, shape);
      // The poster's print: a ball in the match ball's colours filling most of its front.
      const double print_r = 0.4 * std::min(placed.half.x(), placed.half.z());
      for (int v = rect.v0; v < rect.v1; ++v) {
        for (int u = rect.u0; u < rect.u1; ++u) {
          const std::size_t i = static_cast<std::size_t>(v) * W + u;
          const Eigen::Vector3d d = ray(u, v);
          const double z = placed.intersect(d);
          if (!(z < nearest[i])) continue;
          nearest[i] = static_cast<float>(z);
          if (shape.surface == Surface::kLamp) {
            radiance[i] = albedo.cast<float>();
            continue;
          }
          const Eigen::Vector3d p_L = placed.o_L + z * (placed.R_L_S * d);
          const Eigen::Vector3d n_F = R_F_C * (placed.R_L_S.transpose() * normalAt(placed, p_L));
          Eigen::Vector3d colour = albedo;
          if (shape.surface == Surface::kPoster && p_L.y() < -0.99 * placed.half.y() &&
              std::hypot(p_L.x(), p_L.z()) < print_r) {
            const double a = p_L.x() / print_r, b = p_L.z() / print_r;
            const Eigen::Vector3d n_print(a, -std::sqrt(std::max(0.0, 1.0 - a * a - b * b)), b);
            colour =
                scene_.look.panel_albedo && onBallPanel(n_print) ? *scene_.look.panel_albedo : scene_.look.ball_albedo;
          }
          radiance[i] = (colour * shade(n_F)).cast<float>();
        }
      }
    }
  }

  // The ball over the colour camera's exposure: each pixel averages what it saw at each instant.
  if (ball) {
    const double r = scene_.physics.radius_m;
    const int samples = scene_.look.exposure_s > 0.0 ? kBlurSamples : 1;
    std::array<Eigen::Vector3d, kBlurSamples> centre_C;
    PixelRect rect{W, H, 0, 0};
    for (int k = 0; k < samples; ++k) {
      const double tk = samples == 1 ? t : t + scene_.look.exposure_s * (double(k) / (samples - 1) - 0.5);
      centre_C[k] = T_F_C.inverse() * ball->positionAt(tk);
      const PlacedShape at{Shape::Kind::kSphere, Eigen::Matrix3d::Identity(), -centre_C[k],
                           Eigen::Vector3d::Constant(r)};
      const PixelRect rk = pixelRectOf(at.corners_S(), in, 2.0);
      rect = {std::min(rect.u0, rk.u0), std::min(rect.v0, rk.v0), std::max(rect.u1, rk.u1), std::max(rect.v1, rk.v1)};
    }
    for (int v = rect.v0; v < rect.v1; ++v) {
      for (int u = rect.u0; u < rect.u1; ++u) {
        const std::size_t i = static_cast<std::size_t>(v) * W + u;
        const Eigen::Vector3d d = ray(u, v);
        Eigen::Vector3f sum = Eigen::Vector3f::Zero();
        int hits = 0;
        for (int k = 0; k < samples; ++k) {
          const double z = sphereHit(-centre_C[k], d, r);
          if (!(z < nearest[i])) {
            sum += radiance[i];
            continue;
          }
          ++hits;
          const Eigen::Vector3d n_F = R_F_C * (z * d - centre_C[k]) / r;
          const Eigen::Vector3d& albedo =
              scene_.look.panel_albedo && onBallPanel(n_F) ? *scene_.look.panel_albedo : scene_.look.ball_albedo;
          sum += (albedo * shade(n_F)).cast<float>();
        }
        if (hits > 0) radiance[i] = sum / static_cast<float>(samples);
      }
    }
  }

  // The hall's light, its slope over the frame, the camera's gamma and noise.
  Random noise(scene_.noise.seed ^ 0xC010C0DEULL, static_cast<std::uint64_t>(frame_index));
  std::vector<std::uint8_t> rgb(pixels * 3);
  const Eigen::Vector3f tint = (scene_.look.light * scene_.look.tint).cast<float>();
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * W + u;
      const float level = static_cast<float>(
          std::max(0.0, 1.0 + light_slope_.x() * (2.0 * u / W - 1.0) + light_slope_.y() * (2.0 * v / H - 1.0)));
      const Eigen::Vector3f lit = level * radiance[i].cwiseProduct(tint);
      for (int c = 0; c < 3; ++c) {
        const int value = encode(lit[c]) + static_cast<int>(std::lround(255.0 * scene_.look.noise * noise.normal()));
        rgb[3 * i + c] = static_cast<std::uint8_t>(std::clamp(value, 0, 255));
      }
    }
  }
  return rgb;
}

}  // namespace kinect3d::sim
