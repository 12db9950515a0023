#include "kinect3d/ball_refiner.h"

#include <algorithm>
#include <cmath>

namespace kinect3d {

namespace {

// Gauss-Newton for the centre of a sphere of known radius; points farther than gate_m from the
// current surface are left out of each step.
Eigen::Vector3d fitSphere(const std::vector<Eigen::Vector3d>& points, Eigen::Vector3d center, double radius,
                          double gate_m) {
  for (int iteration = 0; iteration < 8; ++iteration) {
    Eigen::Matrix3d JtJ = Eigen::Matrix3d::Zero();
    Eigen::Vector3d Jtr = Eigen::Vector3d::Zero();
    int used = 0;
    for (const Eigen::Vector3d& p : points) {
      const Eigen::Vector3d offset = p - center;
      const double distance = offset.norm();
      const double residual = distance - radius;
      if (distance < 1e-9 || std::abs(residual) > gate_m) continue;
      const Eigen::Vector3d J = -offset / distance;  // d residual / d centre
      JtJ += J * J.transpose();
      Jtr += J * residual;
      ++used;
    }
    if (used < 4) break;
    const Eigen::Vector3d step = JtJ.ldlt().solve(-Jtr);
    center += step;
    if (step.norm() < 1e-5) break;
  }
  return center;
}

}  // namespace

bool BallRefiner::gatherPoints(const BallCandidate& candidate, const OccupancyGrid& grid, const DepthFrame& frame,
                               const Eigen::Isometry3d& T_R_S, const PointProjector& surface) const {
  const Intrinsics& in = frame.intrinsics;
  // The candidate's voxels as a box in the robot frame, grown by a ball radius so that the parts
  // of the ball in voxels below the occupancy threshold are kept (the empty shell guarantees no
  // other occupied voxel that close), and that box's rectangle in the image.
  const float grow = static_cast<float>(grid.voxel_m() / 2 + config_.radius_m);
  const Eigen::Vector3f lo = grid.centerOf(candidate.min) - Eigen::Vector3f::Constant(grow);
  const Eigen::Vector3f hi = grid.centerOf(candidate.max) + Eigen::Vector3f::Constant(grow);
  const Eigen::Isometry3d T_S_R = T_R_S.inverse();
  double u0 = in.width, v0 = in.height, u1 = 0, v1 = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d c_R((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                              (corner & 4) ? hi.z() : lo.z());
    const Eigen::Vector3d c_S = T_S_R * c_R;
    if (c_S.z() < kMinDepthInFront_m) return false;  // reaches behind the sensor: not a ball in view
    const Eigen::Vector2d px = in.project(c_S);
    u0 = std::min(u0, px.x()), u1 = std::max(u1, px.x()), v0 = std::min(v0, px.y()), v1 = std::max(v1, px.y());
  }
  // Every surface pixel in the rectangle whose point lies in the box.
  points_.clear();
  const int ua = std::max(1, int(u0)), ub = std::min(in.width - 1, int(u1) + 1);
  const int va = std::max(1, int(v0)), vb = std::min(in.height - 1, int(v1) + 1);
  for (int v = va; v < vb; ++v) {
    for (int u = ua; u < ub; ++u) {
      if (!surface.isSurface(frame, u, v)) continue;
      const Eigen::Vector3d p_R = T_R_S * in.backProject(u, v, frame.at(u, v) * 0.001);
      const Eigen::Vector3f p = p_R.cast<float>();
      if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) continue;
      if (p_R.z() < surface.config().floor_margin_m) continue;
      points_.push_back(p_R);
    }
  }
  return points_.size() >= kMinPoints;
}

bool BallRefiner::isBallSized(const Eigen::Vector3d& centroid, const Eigen::Vector3d& ray, double range,
                              double focal_px) const {
  // Enough pixels for a ball at this range, and not wider than one.
  const double r = config_.radius_m;
  const double ball_pixels = M_PI * std::pow(focal_px * r / range, 2);
  if (points_.size() < config_.min_visible_fraction * ball_pixels) return false;
  const Eigen::Vector3d side = ray.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d up = side.cross(ray);
  double side_lo = 1e9, side_hi = -1e9, up_lo = 1e9, up_hi = -1e9;
  for (const Eigen::Vector3d& p : points_) {
    const double s = side.dot(p - centroid), h = up.dot(p - centroid);
    side_lo = std::min(side_lo, s), side_hi = std::max(side_hi, s);
    up_lo = std::min(up_lo, h), up_hi = std::max(up_hi, h);
  }
  const double widest = std::max(side_hi - side_lo, up_hi - up_lo);
  return widest <= config_.max_size_ratio * 2.0 * r;
}

Eigen::Vector3d BallRefiner::centreFromDisc(const Eigen::Vector3d& centroid, const Eigen::Vector3d& ray) const {
  // Pixels sample the cap evenly in the image, so for a disc of normalised radius a (the edge
  // filter trims the limb, a < 1) the mean depth lies (2/3)(1 - (1 - a^2)^(3/2)) / a^2 of a radius
  // in front of the centre. a is measured from the spread of the points across the ray (the 98th
  // percentile of the distance from the centroid, scaled to the whole disc).
  constexpr double kSpreadQuantile = 0.98;
  constexpr double kMinDisc = 0.3;  // below this the cap is too small to measure its spread
  const double r = config_.radius_m;
  radial_.clear();
  for (const Eigen::Vector3d& p : points_) {
    const Eigen::Vector3d across_ray = (p - centroid) - ray.dot(p - centroid) * ray;
    radial_.push_back(across_ray.norm());
  }
  const std::size_t rank = static_cast<std::size_t>(radial_.size() * kSpreadQuantile);
  std::nth_element(radial_.begin(), radial_.begin() + rank, radial_.end());
  const double a = std::clamp(radial_[rank] / std::sqrt(kSpreadQuantile) / r, kMinDisc, 1.0);
  const double cap_depth = (2.0 / 3.0) * (1.0 - std::pow(1.0 - a * a, 1.5)) / (a * a);
  return centroid + cap_depth * r * ray;
}

Eigen::Matrix3d BallRefiner::covariance(const Eigen::Vector3d& ray, double range, int points) const {
  // A random part, the per-point noise over the number of points (at most kMaxIndependentPoints:
  // neighbouring Kinect pixels share their correlation window), and a systematic part, 1 cm in
  // every direction for the extrinsics plus a quarter of the depth quantisation step along the
  // ray, which grows with the square of the range.
  constexpr double kMaxIndependentPoints = 100.0;
  constexpr double kExtrinsicsSigma_m = 0.01;
  const double n_eff = std::clamp(double(points), 1.0, kMaxIndependentPoints);
  const double extrinsics = kExtrinsicsSigma_m * kExtrinsicsSigma_m;
  const double along = std::sqrt(std::pow(noise_.axialSigma_m(range), 2) / n_eff +
                                 std::pow(noise_.quantisationStep_m(range) / 4, 2) + extrinsics);
  const double across = std::sqrt(std::pow(noise_.lateralSigma_m(range), 2) / n_eff + extrinsics);
  const Eigen::Vector3d side = ray.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d up = side.cross(ray);
  Eigen::Matrix3d basis;
  basis << side, up, ray;
  return basis * Eigen::Vector3d(across * across, across * across, along * along).asDiagonal() * basis.transpose();
}

std::optional<BallFit> BallRefiner::refine(const BallCandidate& candidate, const OccupancyGrid& grid,
                                           const DepthFrame& frame, const Eigen::Isometry3d& T_R_S,
                                           const PointProjector& surface) const {
  if (!gatherPoints(candidate, grid, frame, T_R_S, surface)) return std::nullopt;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points_) centroid += p;
  centroid /= double(points_.size());
  const Eigen::Vector3d sensor_R = T_R_S.translation();
  const Eigen::Vector3d ray = (centroid - sensor_R).normalized();
  const double range = (centroid - sensor_R).norm();
  if (!isBallSized(centroid, ray, range, frame.intrinsics.fx)) return std::nullopt;

  BallFit fit;
  fit.center_R = centreFromDisc(centroid, ray);
  // Where the cap's depth is resolved (noise well under the radius) a sphere of the known radius
  // fitted to its points also uses the cap's shape, which keeps a partly hidden ball centred.
  // Depth noise moves points off the sphere mostly along the ray, so on average they lie
  // sqrt(r^2 + sigma^2) from the centre: that is the radius fitted. A fit that strays from the
  // disc estimate by more than a third of a radius is not trusted.
  const double r = config_.radius_m;
  const double sigma = noise_.axialSigma_m(range);
  if (sigma + noise_.quantisationStep_m(range) / 2 < r / 4) {
    const double gate = std::max(0.5 * r, 3.0 * (sigma + noise_.quantisationStep_m(range)));
    const Eigen::Vector3d sphere = fitSphere(points_, fit.center_R, std::hypot(r, sigma), gate);
    if ((sphere - fit.center_R).norm() < r / 3) fit.center_R = sphere;
  }
  // A ball cannot sink into the floor: its centre stays near one radius up.
  if (fit.center_R.z() < 0.5 * r) return std::nullopt;
  fit.points = static_cast<int>(points_.size());
  fit.state = fit.center_R.z() > r + config_.air_min_height_m ? fw::BallState::kAir : fw::BallState::kGround;
  fit.covariance_m2 = covariance(ray, range, fit.points);
  return fit;
}

}  // namespace kinect3d
