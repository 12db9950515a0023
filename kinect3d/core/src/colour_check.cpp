#include "kinect3d/colour_check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "kinect3d/depth_noise.h"

namespace kinect3d {

namespace {

constexpr double kExplainedSigma2 = 9.0;   // a pixel within 3 sigma (Mahalanobis) of a colour is explained by it
constexpr double kMainColourShare = 0.15;  // a colour this common on the ball must show in its disc ...
constexpr double kShownShare = 0.5;        // ... with at least this share of its learnt share
constexpr double kDiscShare = 0.8;         // colours are sampled inside this share of the disc's radius
constexpr int kOutlinePoints = 32;         // points on the circle tested for an edge
constexpr double kEdgeSobel = 80.0;        // a 3x3 Sobel response of a 20-level step
constexpr double kMaxColourOffset = 0.33;  // radii: main colours' pixels centred on the disc and each other
constexpr double kMinShown = 0.3;          // of a disc, unhidden, to judge it by
constexpr double kMaxRingExplained = 0.5;  // a confirmed disc's surroundings are mostly not the ball's colours
constexpr int kContrast = 90;              // summed over R, G, B: colours this different across the circle
constexpr double kPanelWidth = 0.4;        // radii: a classic ball's pentagon across
constexpr double kBlendedPanel_px = 5.0;   // a panel narrower than this shows mostly blended
constexpr int kMinContrasted = kOutlinePoints / 4;  // directions with contrast needed to call an outline smeared
constexpr double kSpreadFactor = 1.2;               // the learnt spread widened a little: no hall is quite the session
const Eigen::Vector3d kMinSigma(4.0, 2.5, 2.5);     // L*, a*, b*: camera noise at the least
// Light. A matt surface in more or less light has its linear RGB scaled by the light, and so its
// (L* + 16, a*, b*) by the light's cube root (above L* 8): one colour in more or less light lies on
// a ray from (-16, 0, 0). The hall's light on a ball may differ from the session's it was learnt in
// (a darker corner, a lamp above) from a quarter to twice: these cube roots, about 8 % apart. Each
// disc is judged at the one level that explains it best, all the ball's colours together (its white
// panels stay lighter than its black ones); the ball's own shading is in the learnt spread.
constexpr double kLightLevels[] = {0.63, 0.69, 0.76, 0.83, 0.91, 1.0, 1.08, 1.17, 1.26};

// RGB pixels (8-bit) to CIE L*a*b*.
std::vector<Eigen::Vector3f> toLab(const std::vector<cv::Vec3b>& rgb) {
  std::vector<Eigen::Vector3f> lab(rgb.size());
  if (rgb.empty()) return lab;
  cv::Mat in(1, static_cast<int>(rgb.size()), CV_8UC3, const_cast<cv::Vec3b*>(rgb.data())), in_f, out;
  in.convertTo(in_f, CV_32FC3, 1.0 / 255.0);
  cv::cvtColor(in_f, out, cv::COLOR_RGB2Lab);
  for (int i = 0; i < out.cols; ++i) {
    const cv::Vec3f& p = out.at<cv::Vec3f>(0, i);
    lab[static_cast<std::size_t>(i)] = {p[0], p[1], p[2]};
  }
  return lab;
}

cv::Vec3b pixelAt(const fw::ColourImage& image, int u, int v) {
  const std::uint8_t* p = &image.rgb[3 * (static_cast<std::size_t>(v) * image.width + u)];
  return {p[0], p[1], p[2]};
}

// What the depth shows in front of the ball: a colour pixel is hidden when the depth image, at the
// pixel the same ray falls on at the ball's distance (the colour camera sits beside the depth
// camera), holds a surface nearer than the ball's near side. A ball behind a player is judged on
// what of it shows. Without depth (or where it has none) nothing is hidden.
class Occluders {
 public:
  Occluders(const DepthFrame& frame, const fw::ColourImage& image, const Eigen::Vector3d& centre_S, double radius_m)
      : frame_(frame),
        image_(image),
        z_C_m_(centre_S.z() - image.offset_S_m.z()),
        nearest_mm_(1000.0 * (centre_S.z() - radius_m - marginOf(frame, centre_S.z() - radius_m))) {}

  bool hides(double u, double v) const {
    const std::uint16_t along = depthAlong(u, v, z_C_m_);
    if (along == 0 || along >= nearest_mm_) return false;
    // Something nearer. The ray was followed to the ball's distance; a near surface sits elsewhere
    // in the depth image (the cameras' parallax grows as it comes nearer): look again at its own.
    const std::uint16_t again = depthAlong(u, v, along * 1e-3 - image_.offset_S_m.z());
    return again != 0 && again < nearest_mm_;
  }

 private:
  // In front of the ball by more than the depth's own error there (3 sigma and a quantisation step:
  // 7 cm at 3 m, 27 cm at 6 m), and by 10 cm at the least.
  static double marginOf(const DepthFrame& frame, double z_m) {
    const DepthNoiseModel noise{frame.intrinsics.fx};
    return std::max(0.1, 3.0 * DepthNoiseModel::axialSigma_m(z_m) + noise.quantisationStep_m(z_m));
  }
  // The depth (mm, 0 for none) where the colour pixel's ray is z_C_m along the colour camera's axis.
  std::uint16_t depthAlong(double u, double v, double z_C_m) const {
    if (frame_.depth_mm.empty()) return 0;
    const Eigen::Vector3d p_S =
        Eigen::Vector3d((u - image_.cx) / image_.fx * z_C_m, (v - image_.cy) / image_.fy * z_C_m, z_C_m) +
        image_.offset_S_m;
    const Intrinsics& in = frame_.intrinsics;
    const long du = std::lround(in.fx * p_S.x() / p_S.z() + in.cx), dv = std::lround(in.fy * p_S.y() / p_S.z() + in.cy);
    if (du < 0 || dv < 0 || du >= in.width || dv >= in.height) return 0;
    return frame_.at(static_cast<int>(du), static_cast<int>(dv));
  }

  const DepthFrame& frame_;
  const fw::ColourImage& image_;
  double z_C_m_;       // the ball centre's distance along the colour camera's axis
  double nearest_mm_;  // depth nearer than this hides the ball
};

// The pixels between two radii round a disc's centre, on a grid of about 12 across the disc, but
// those occluders hide. Counts the grid points that fell outside the image in `outside` and the
// hidden ones in `hidden`.
struct DiscSamples {
  std::vector<cv::Vec3b> pixels;
  std::vector<Eigen::Vector2f> offsets;  // each pixel's from the disc's centre, in radii
  int outside = 0, hidden = 0;
};
DiscSamples pixelsAround(const fw::ColourImage& image, const BallDisc& disc, double inner_px, double outer_px,
                         const Occluders* occluders = nullptr) {
  DiscSamples samples;
  const double step = std::max(1.0, disc.radius_px / 6.0);
  for (double dv = -outer_px; dv <= outer_px; dv += step) {
    for (double du = -outer_px; du <= outer_px; du += step) {
      const double r2 = du * du + dv * dv;
      if (r2 > outer_px * outer_px || r2 < inner_px * inner_px) continue;
      const long u = std::lround(disc.centre_px.x() + du), v = std::lround(disc.centre_px.y() + dv);
      if (u < 0 || v < 0 || u >= image.width || v >= image.height) {
        ++samples.outside;
        continue;
      }
      if (occluders && occluders->hides(u, v)) {
        ++samples.hidden;
        continue;
      }
      samples.pixels.push_back(pixelAt(image, static_cast<int>(u), static_cast<int>(v)));
      samples.offsets.emplace_back(du / disc.radius_px, dv / disc.radius_px);
    }
  }
  return samples;
}

// The disc's inside, where its colours are judged.
DiscSamples discPixels(const fw::ColourImage& image, const BallDisc& disc, const Occluders* occluders = nullptr) {
  return pixelsAround(image, disc, 0.0, kDiscShare * disc.radius_px, occluders);
}

// Whether each of the ball's main colours is spread over the disc: its pixels centred within a third
// of the radius of what shows of the disc (the whole disc, or its unhidden part), and of each other.
// A ball's panels lie all over it; a white box on a dark carpet puts its white on one side of the
// disc and the dark on the other.
bool coloursCentred(const BallColourModel& model, const std::vector<Eigen::Vector3f>& lab,
                    const std::vector<Eigen::Vector2f>& offsets, double light) {
  Eigen::Vector2f shown = Eigen::Vector2f::Zero();
  for (const Eigen::Vector2f& o : offsets) shown += o;
  shown /= std::max<std::size_t>(offsets.size(), 1);
  std::vector<Eigen::Vector2f> centres;
  for (std::size_t c = 0; c < model.size(); ++c) {
    if (model[c].share < kMainColourShare) continue;
    Eigen::Vector2f sum = Eigen::Vector2f::Zero();
    int count = 0;
    for (std::size_t i = 0; i < lab.size(); ++i) {
      if (explainingColour(model, lab[i], light) != static_cast<int>(c)) continue;
      sum += offsets[i];
      ++count;
    }
    if (count == 0 || (sum / count - shown).norm() > kMaxColourOffset) return false;
    centres.push_back(sum / count);
  }
  for (std::size_t a = 0; a < centres.size(); ++a) {
    for (std::size_t b = a + 1; b < centres.size(); ++b) {
      if ((centres[a] - centres[b]).norm() > kMaxColourOffset) return false;
    }
  }
  return true;
}

// A pixel's squared distance from a colour in its learnt sigmas, the colour in `light` (a level of
// kLightLevels). Its a* and b* are compared at the colour's lightness (the ball's own shading moves
// them along the ray), its lightness with the colour's in that light.
double distance2(const BallColour& colour, const Eigen::Vector3f& lab, double light) {
  const double lit = (colour.lab.x() + 16.0) * light, pixel_lit = std::max(lab.x() + 16.0, 1e-3);
  const Eigen::Vector2d ab = lab.tail<2>().cast<double>() * (colour.lab.x() + 16.0) / pixel_lit;
  const double sigma_lit = std::max(colour.sigma.x() * light, kMinSigma.x());
  return (ab - colour.lab.tail<2>()).cwiseQuotient(colour.sigma.tail<2>()).squaredNorm() +
         (pixel_lit - lit) * (pixel_lit - lit) / (sigma_lit * sigma_lit);
}

// Two of the ball's main colours blended in one pixel, t of the way from colour a to colour b.
struct Blend {
  BallColour colour;
  std::size_t a, b;
  double t;
};
// Mixed in linear RGB, where light adds up as on the sensor, an eighth to seven eighths of the way
// (OpenCV's L*a*b* as in toLab(), its linear RGB without the sRGB curve).
std::vector<Blend> blendsOf(const BallColourModel& model) {
  constexpr int kSteps = 7;
  std::vector<Blend> blends;
  for (std::size_t a = 0; a < model.size(); ++a) {
    for (std::size_t b = a + 1; b < model.size(); ++b) {
      if (model[a].share < kMainColourShare || model[b].share < kMainColourShare) continue;
      cv::Mat ends_lab(1, 2, CV_32FC3), ends, mixes(1, kSteps, CV_32FC3), mixes_lab;
      ends_lab.at<cv::Vec3f>(0, 0) = cv::Vec3f(model[a].lab.cast<float>().eval().data());
      ends_lab.at<cv::Vec3f>(0, 1) = cv::Vec3f(model[b].lab.cast<float>().eval().data());
      cv::cvtColor(ends_lab, ends, cv::COLOR_Lab2LRGB);
      for (int k = 0; k < kSteps; ++k) {
        const float t = (k + 1) / float(kSteps + 1);
        mixes.at<cv::Vec3f>(0, k) = (1.0f - t) * ends.at<cv::Vec3f>(0, 0) + t * ends.at<cv::Vec3f>(0, 1);
      }
      cv::cvtColor(mixes, mixes_lab, cv::COLOR_LRGB2Lab);
      for (int k = 0; k < kSteps; ++k) {
        const cv::Vec3f& lab = mixes_lab.at<cv::Vec3f>(0, k);
        Blend blend{{}, a, b, (k + 1) / double(kSteps + 1)};
        blend.colour.lab = Eigen::Vector3d(lab[0], lab[1], lab[2]);
        blend.colour.sigma = model[a].sigma.cwiseMax(model[b].sigma);
        blends.push_back(blend);
      }
    }
  }
  return blends;
}

// A disc's match at one light level; blends: the main colours' blends that count for both, if any.
ColourMatch matchAt(const BallColourModel& model, const std::vector<Blend>& blends,
                    const std::vector<Eigen::Vector3f>& lab, double light) {
  ColourMatch match;
  match.light = light;
  if (lab.empty() || model.empty()) return match;
  std::vector<double> count(model.size(), 0.0);
  int explained = 0;
  for (const Eigen::Vector3f& p : lab) {
    const int c = explainingColour(model, p, light);
    if (c >= 0) {
      count[static_cast<std::size_t>(c)] += 1.0;
      ++explained;
      continue;
    }
    // Neither colour, but two of them blended in one pixel: it shows each in its part, though it
    // explains the disc as neither.
    double best_d2 = kExplainedSigma2;
    const Blend* nearest = nullptr;
    for (const Blend& blend : blends) {
      const double d2 = distance2(blend.colour, p, light);
      if (d2 <= best_d2) best_d2 = d2, nearest = &blend;
    }
    if (nearest) {
      count[nearest->a] += 1.0 - nearest->t;
      count[nearest->b] += nearest->t;
    }
  }
  // A white shirt is not a white ball with black panels: each main colour must show.
  double consistency = 1.0;
  for (std::size_t c = 0; c < model.size(); ++c) {
    if (model[c].share < kMainColourShare) continue;
    const double shown = count[c] / lab.size();
    consistency = std::min(consistency, shown / (kShownShare * model[c].share));
    // ... and not swamp the disc: black panels on a quarter of a ball, not on two thirds of a disc.
    if (shown > 2.0 * model[c].share) consistency = 0.0;
  }
  match.explained = double(explained) / lab.size();
  match.score = std::min(1.0, consistency) * match.explained;
  return match;
}

// The largest share of a disc the ball's colours explain at any light level. Smeared, a classic ball's
// white and black panels mix into greys: its white in less light.
double mostExplained(const BallColourModel& model, const std::vector<Eigen::Vector3f>& lab) {
  double most = 0.0;
  for (const double light : kLightLevels) most = std::max(most, colourMatch(model, lab, light).explained);
  return most;
}

// The evidence on a disc that lies in the image (ColourCheck::check).
ColourEvidence judge(const ColourCheckConfig& config, const fw::ColourImage& image, const BallDisc& disc,
                     const Occluders& occluders) {
  ColourEvidence evidence;
  evidence.verdict = fw::ColourVerdict::kNoEvidence;
  if (disc.radius_px < config.min_radius_px) {
    evidence.note = fw::ColourNote::kTooSmall;
    return evidence;
  }
  const DiscSamples disc_samples = discPixels(image, disc, &occluders);
  const std::size_t in_image = disc_samples.pixels.size() + disc_samples.hidden;
  if (in_image < static_cast<std::size_t>(disc_samples.outside) || in_image == 0) {
    evidence.note = fw::ColourNote::kOutsideImage;  // most of the disc is off the colour image
    return evidence;
  }
  if (disc_samples.pixels.size() < kMinShown * in_image) {
    evidence.note = fw::ColourNote::kHidden;  // behind something nearer: too little of it shows
    return evidence;
  }
  const std::vector<Eigen::Vector3f> lab = toLab(disc_samples.pixels);
  double lightness = 0.0;
  for (const Eigen::Vector3f& p : lab) lightness += p.x();
  if (lightness / lab.size() < config.dark_lightness) {
    evidence.note = fw::ColourNote::kTooDark;
    return evidence;
  }
  // Overexposed: the ring round the disc blown out (a ball against a window or a lamp's glare). A
  // disc blown out on its own is a light, not a ball, and is judged like anything else.
  int saturated = 0;
  const std::vector<cv::Vec3b> ring =
      pixelsAround(image, disc, 1.2 * disc.radius_px, 1.6 * disc.radius_px, &occluders).pixels;
  for (const cv::Vec3b& p : ring) saturated += std::min({p[0], p[1], p[2]}) >= 250;
  if (!ring.empty() && 2 * saturated >= static_cast<int>(ring.size())) {
    evidence.note = fw::ColourNote::kOverexposed;
    return evidence;
  }
  // Far away a ball's panels (0.4 of its radius across) are a few pixels wide and show mostly
  // blended with the rest: there a blend of two of its colours counts for both.
  const bool panels_blend = kPanelWidth * disc.radius_px < kBlendedPanel_px;
  const ColourMatch match = colourMatch(config.ball_colours, lab, panels_blend);
  evidence.score = match.score;
  // The ball's colours end at its outline: a disc cut from a larger patch of them (a grey carpet for
  // a white ball with black panels, an orange shirt) is not confirmed.
  const double ring_explained = colourMatch(config.ball_colours, toLab(ring), match.light).explained;

  // The outline: an edge across the circle the depth predicts (Sobel on each channel, the strongest
  // one, pointing along the radius), searched within a band for the depth's own error. Where the
  // colours inside and outside the circle differ, the edge's width too: wider than max_blur_px on a
  // quarter of those directions is a smeared outline (motion blur), and then the colours inside are
  // the ball's mixed with what it crossed.
  const double band = std::max(2.0, 0.25 * disc.radius_px);
  const double reach = disc.radius_px + band + 2.0;
  const cv::Rect roi = cv::Rect(static_cast<int>(std::floor(disc.centre_px.x() - reach)),
                                static_cast<int>(std::floor(disc.centre_px.y() - reach)),
                                static_cast<int>(2 * reach) + 2, static_cast<int>(2 * reach) + 2) &
                       cv::Rect(0, 0, image.width, image.height);
  const cv::Mat patch = cv::Mat(image.height, image.width, CV_8UC3, const_cast<std::uint8_t*>(image.rgb.data()))(roi);
  cv::Mat gx, gy;
  cv::Sobel(patch, gx, CV_16S, 1, 0, 3, 1, 0, cv::BORDER_REPLICATE);
  cv::Sobel(patch, gy, CV_16S, 0, 1, 3, 1, 0, cv::BORDER_REPLICATE);
  auto at = [&](const Eigen::Vector2d& p, int& x, int& y) {
    x = static_cast<int>(std::lround(p.x())) - roi.x, y = static_cast<int>(std::lround(p.y())) - roi.y;
    return x >= 0 && y >= 0 && x < roi.width && y < roi.height;
  };
  auto difference = [](const cv::Vec3b& a, const cv::Vec3b& b) {
    return std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2]);
  };
  int shown = 0, supported = 0, contrasted = 0, smeared = 0;
  for (int k = 0; k < kOutlinePoints; ++k) {
    const double angle = 2.0 * M_PI * k / kOutlinePoints;
    const Eigen::Vector2d dir(std::cos(angle), std::sin(angle));
    // The outline behind an occluder is the occluder's edge, if any: not evidence either way.
    const Eigen::Vector2d on_outline = disc.centre_px + disc.radius_px * dir;
    if (occluders.hides(on_outline.x(), on_outline.y())) continue;
    ++shown;
    bool edge = false;
    for (double r = disc.radius_px - band; r <= disc.radius_px + band && !edge; r += 1.0) {
      int x, y;
      if (!at(disc.centre_px + r * dir, x, y)) continue;
      const cv::Vec3s& sx = gx.at<cv::Vec3s>(y, x);
      const cv::Vec3s& sy = gy.at<cv::Vec3s>(y, x);
      for (int c = 0; c < 3; ++c) {
        const double along = sx[c] * dir.x() + sy[c] * dir.y();
        const double squared = double(sx[c]) * sx[c] + double(sy[c]) * sy[c];
        if (std::abs(along) >= kEdgeSobel && along * along >= 0.6 * squared) edge = true;
      }
    }
    supported += edge;
    // The edge's width: from inside the disc outwards, the distance over which the colour moves from
    // a tenth to nine tenths of the way to the outside's.
    int xi, yi, xo, yo;
    const double r_in = 0.5 * disc.radius_px, r_out = disc.radius_px + band;
    const Eigen::Vector2d outside_px = disc.centre_px + r_out * dir;
    if (!at(disc.centre_px + r_in * dir, xi, yi) || !at(outside_px, xo, yo) ||
        occluders.hides(outside_px.x(), outside_px.y())) {
      continue;
    }
    const cv::Vec3b inside = patch.at<cv::Vec3b>(yi, xi), outside_colour = patch.at<cv::Vec3b>(yo, xo);
    const int contrast = difference(inside, outside_colour);
    if (contrast < kContrast) continue;
    ++contrasted;
    double first = -1.0, last = -1.0;
    for (double r = r_in; r <= r_out; r += 0.5) {
      int x, y;
      if (!at(disc.centre_px + r * dir, x, y)) break;
      const double moved = double(difference(inside, patch.at<cv::Vec3b>(y, x))) / contrast;
      if (first < 0.0 && moved >= 0.1) first = r;
      if (moved <= 0.9) last = r;
    }
    smeared += first >= 0.0 && last - first > config.max_blur_px;
  }
  evidence.outline = shown > 0 ? double(supported) / shown : 0.0;
  const bool blurred = contrasted >= kMinContrasted && 4 * smeared >= contrasted;

  if (evidence.score >= config.confirm_score && evidence.outline >= config.min_outline &&
      ring_explained < kMaxRingExplained &&
      coloursCentred(config.ball_colours, lab, disc_samples.offsets, match.light)) {
    evidence.verdict = fw::ColourVerdict::kConfirmed;
  } else if (blurred && mostExplained(config.ball_colours, lab) >= config.reject_score) {
    // Smeared, the ball's colours mix (its score drops) but still show, in some light.
    evidence.note = fw::ColourNote::kBlurred;
  } else if (evidence.score < config.reject_score) {
    evidence.verdict = fw::ColourVerdict::kRejected;
  } else {
    evidence.note = fw::ColourNote::kWeak;
  }
  return evidence;
}

}  // namespace

std::optional<BallDisc> discOf(const fw::ColourImage& image, const Eigen::Vector3d& centre_S, double radius_m) {
  const Eigen::Vector3d p_C = centre_S - image.offset_S_m;
  if (p_C.z() <= radius_m) return std::nullopt;
  // A sphere subtends asin(r / d): its outline's radius on the image is f r / sqrt(d^2 - r^2).
  const double range = p_C.norm();
  return BallDisc{{image.fx * p_C.x() / p_C.z() + image.cx, image.fy * p_C.y() / p_C.z() + image.cy},
                  image.fx * radius_m / std::sqrt(range * range - radius_m * radius_m)};
}

int explainingColour(const BallColourModel& model, const Eigen::Vector3f& lab, double light) {
  int best = -1;
  double best_d2 = kExplainedSigma2;
  for (std::size_t c = 0; c < model.size(); ++c) {
    const double d2 = distance2(model[c], lab, light);
    if (d2 <= best_d2) best = static_cast<int>(c), best_d2 = d2;
  }
  return best;
}

ColourMatch colourMatch(const BallColourModel& model, const std::vector<Eigen::Vector3f>& lab, double light,
                        bool panels_blend) {
  return matchAt(model, panels_blend ? blendsOf(model) : std::vector<Blend>{}, lab, light);
}

ColourMatch colourMatch(const BallColourModel& model, const std::vector<Eigen::Vector3f>& lab, bool panels_blend) {
  const std::vector<Blend> blends = panels_blend ? blendsOf(model) : std::vector<Blend>{};
  // The session's light unless another level explains the disc better.
  ColourMatch best = matchAt(model, blends, lab, 1.0);
  for (const double light : kLightLevels) {
    if (light == 1.0) continue;  // the start
    const ColourMatch match = matchAt(model, blends, lab, light);
    if (match.score > best.score || (match.score == best.score && match.explained > best.explained)) best = match;
  }
  return best;
}

ColourCheck::ColourCheck(ColourCheckConfig config) : config_(std::move(config)) {}

ColourEvidence ColourCheck::check(const DepthFrame& frame, const Eigen::Vector3d& centre_S, double radius_m) const {
  ColourEvidence evidence;
  if (config_.mode == ColourCheckConfig::Mode::kOff) return evidence;
  evidence.verdict = fw::ColourVerdict::kNoEvidence;
  if (!frame.colour || frame.colour->rgb.empty()) {
    evidence.note = fw::ColourNote::kNoImage;
  } else if (const std::optional<BallDisc> disc = discOf(*frame.colour, centre_S, radius_m)) {
    evidence = judge(config_, *frame.colour, *disc, Occluders(frame, *frame.colour, centre_S, radius_m));
  } else {
    evidence.note = fw::ColourNote::kOutsideImage;
  }
  if (config_.mode == ColourCheckConfig::Mode::kRequired && evidence.verdict != fw::ColourVerdict::kConfirmed) {
    evidence.verdict = fw::ColourVerdict::kRejected;
  }
  return evidence;
}

// ---------------------------------------------------------------------------------------------

void BallColourLearner::add(const fw::ColourImage& image, const Eigen::Vector3d& centre_S, double radius_m) {
  const std::optional<BallDisc> disc = discOf(image, centre_S, radius_m);
  if (!disc || disc->radius_px < 3.0) return;
  const DiscSamples samples = discPixels(image, *disc);
  if (samples.outside > 0 || samples.pixels.empty()) return;  // the whole ball in view, or nothing from this frame
  const std::vector<Eigen::Vector3f> own = toLab(samples.pixels);
  ++frames_;
  ball_lab_.insert(ball_lab_.end(), own.begin(), own.end());
  ball_discs_.push_back(own);
  // Everything else: a grid over the image away from the ball, and ball-sized discs on it.
  std::vector<cv::Vec3b> others;
  const double keep_away = 2.0 * disc->radius_px;
  for (int v = 4; v < image.height; v += 8) {
    for (int u = 4; u < image.width; u += 8) {
      if ((Eigen::Vector2d(u, v) - disc->centre_px).norm() > keep_away) others.push_back(pixelAt(image, u, v));
    }
  }
  const std::vector<Eigen::Vector3f> other_lab = toLab(others);
  other_lab_.insert(other_lab_.end(), other_lab.begin(), other_lab.end());
  const double step = 2.5 * disc->radius_px;
  for (double v = step; v < image.height - step; v += step) {
    for (double u = step; u < image.width - step; u += step) {
      const BallDisc elsewhere{{u, v}, disc->radius_px};
      if ((elsewhere.centre_px - disc->centre_px).norm() < 2.0 * disc->radius_px) continue;
      other_discs_.push_back(toLab(discPixels(image, elsewhere).pixels));
    }
  }
}

BallColourFit BallColourLearner::fit() const {
  constexpr int kMinFrames = 10;
  if (frames_ < kMinFrames || ball_lab_.size() < 200) {
    throw std::runtime_error("the ball was seen whole in " + std::to_string(frames_) + " colour frames (" +
                             std::to_string(ball_lab_.size()) + " pixels); at least " + std::to_string(kMinFrames) +
                             " are needed: is kinect3d.colour on, and is the ball in view of both cameras?");
  }
  // k-means in L*a*b* with two clusters (a ball's colour and its panels' or print's), then merged
  // when they are one colour in light and shade, and dropped when rare.
  const std::size_t n = std::min<std::size_t>(ball_lab_.size(), 20000);
  cv::Mat samples(static_cast<int>(n), 3, CV_32F);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = ball_lab_[i * ball_lab_.size() / n];
    for (int c = 0; c < 3; ++c) samples.at<float>(static_cast<int>(i), c) = p[c];
  }
  cv::Mat labels, centres;
  cv::theRNG().state = 0x1234567;  // the same recording always gives the same model
  constexpr int kColours = 2;
  cv::kmeans(samples, kColours, labels, cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 0.1), 3,
             cv::KMEANS_PP_CENTERS, centres);
  std::vector<std::vector<int>> members(kColours);
  for (int i = 0; i < labels.rows; ++i) members[static_cast<std::size_t>(labels.at<int>(i))].push_back(i);
  auto meanOf = [&](const std::vector<int>& rows) {
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    for (const int r : rows)
      m += Eigen::Vector3d(samples.at<float>(r, 0), samples.at<float>(r, 1), samples.at<float>(r, 2));
    return Eigen::Vector3d(m / std::max<std::size_t>(rows.size(), 1));
  };
  // One colour in light and shade is one colour: the same hue, lighter or darker. Two greys or a
  // white and a black differ in lightness alone and stay two.
  auto sameColour = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    constexpr double kMergeDeltaE = 15.0, kChromatic = 15.0, kSameHue_rad = 20.0 * M_PI / 180.0;
    if ((a - b).norm() < kMergeDeltaE) return true;
    const double chroma_a = a.tail<2>().norm(), chroma_b = b.tail<2>().norm();
    if (chroma_a < kChromatic || chroma_b < kChromatic) return false;
    return std::acos(std::clamp(a.tail<2>().dot(b.tail<2>()) / (chroma_a * chroma_b), -1.0, 1.0)) < kSameHue_rad;
  };
  for (bool merged = true; merged;) {
    merged = false;
    for (std::size_t a = 0; a < members.size() && !merged; ++a) {
      for (std::size_t b = a + 1; b < members.size() && !merged; ++b) {
        if (!sameColour(meanOf(members[a]), meanOf(members[b]))) continue;
        members[a].insert(members[a].end(), members[b].begin(), members[b].end());
        members.erase(members.begin() + static_cast<long>(b));
        merged = true;
      }
    }
  }
  BallColourFit fit;
  for (const std::vector<int>& rows : members) {
    const double share = double(rows.size()) / n;
    if (share < 0.05) continue;  // a few pixels of the background or the outline
    BallColour colour;
    colour.lab = meanOf(rows);
    // The spread of lightness as it is; of a* and b* at the colour's lightness (as distance2 compares them).
    Eigen::Vector3d var = Eigen::Vector3d::Zero();
    for (const int r : rows) {
      Eigen::Vector3d p(samples.at<float>(r, 0), samples.at<float>(r, 1), samples.at<float>(r, 2));
      p.tail<2>() *= (colour.lab.x() + 16.0) / std::max(p.x() + 16.0, 1e-3);
      const Eigen::Vector3d d = p - colour.lab;
      var += d.cwiseProduct(d);
    }
    colour.sigma = (kSpreadFactor * (var / rows.size()).cwiseSqrt()).cwiseMax(kMinSigma);
    colour.share = share;
    fit.model.push_back(colour);
  }
  std::sort(fit.model.begin(), fit.model.end(),
            [](const BallColour& a, const BallColour& b) { return a.share > b.share; });

  fit.frames = frames_;
  fit.ball_pixels = static_cast<int>(ball_lab_.size());
  fit.other_pixels = static_cast<int>(other_lab_.size());
  int ball_explained = 0;
  for (const Eigen::Vector3f& p : ball_lab_) ball_explained += explainingColour(fit.model, p, 1.0) >= 0;
  fit.ball_explained = double(ball_explained) / ball_lab_.size();
  fit.other_explained_by.assign(fit.model.size(), 0.0);
  int other_explained = 0;
  for (const Eigen::Vector3f& p : other_lab_) {
    const int c = explainingColour(fit.model, p, 1.0);
    if (c < 0) continue;
    ++other_explained;
    fit.other_explained_by[static_cast<std::size_t>(c)] += 1.0 / std::max<std::size_t>(other_lab_.size(), 1);
  }
  fit.other_explained = double(other_explained) / std::max<std::size_t>(other_lab_.size(), 1);
  std::vector<double> ball_scores, other_scores;
  for (const auto& disc : ball_discs_) ball_scores.push_back(colourMatch(fit.model, disc).score);
  for (const auto& disc : other_discs_) other_scores.push_back(colourMatch(fit.model, disc).score);
  fit.ball_score_p10 = fw::quantile(ball_scores, 0.1);
  fit.other_score_p99 = other_scores.empty() ? 0.0 : fw::quantile(other_scores, 0.99);
  return fit;
}

std::string ballColoursYaml(const BallColourModel& model) {
  std::string yaml = "[";
  for (std::size_t i = 0; i < model.size(); ++i) {
    const BallColour& c = model[i];
    char text[200];
    std::snprintf(text, sizeof text, "%s{lab: [%.1f, %.1f, %.1f], sigma: [%.1f, %.1f, %.1f], share: %.2f}",
                  i ? ", " : "", c.lab.x(), c.lab.y(), c.lab.z(), c.sigma.x(), c.sigma.y(), c.sigma.z(), c.share);
    yaml += text;
  }
  return yaml + "]";
}

}  // namespace kinect3d
