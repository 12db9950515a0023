#include "kinect3d/ball_refiner.h"

#include <algorithm>
#include <cmath>

namespace kinect3d {

namespace {

// Gauss-Newton for the centre of a sphere of known radius; points farther than gate_m from the
// current surface are left out of each step.
Eigen::Vector3d fitSphere(const std::vector<Eigen::Vector3d>& points, Eigen::Vector3d center,
                          double radius, double gate_m) {
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

std::optional<BallFit> BallRefiner::refine(const BallCandidate& candidate, const OccupancyGrid& grid,
                                           const DepthFrame& frame, const Eigen::Isometry3d& T_R_S,
                                           const PointProjector& surface) const {
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
    if (c_S.z() < 0.1) return std::nullopt;  // reaches behind the sensor: not a ball in view
    const Eigen::Vector2d px = in.project(c_S);
    u0 = std::min(u0, px.x()), u1 = std::max(u1, px.x()), v0 = std::min(v0, px.y()), v1 = std::max(v1, px.y());
  }
  // Every surface pixel in the rectangle whose point lies in the box.
  points_.clear();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  const int ua = std::max(1, int(u0)), ub = std::min(in.width - 1, int(u1) + 1);
  const int va = std::max(1, int(v0)), vb = std::min(in.height - 1, int(v1) + 1);
  for (int v = va; v < vb; ++v) {
    for (int u = ua; u < ub; ++u) {
      if (!surface.isSurface(frame, u, v)) continue;
      const double z = frame.at(u, v) * 0.001;
      const Eigen::Vector3d p_R = T_R_S * in.backProject(u, v, z);
      if ((p_R.cast<float>().array() < lo.array()).any() || (p_R.cast<float>().array() > hi.array()).any()) continue;
      if (p_R.z() < surface.config().floor_margin_m) continue;
      points_.push_back(p_R);
      centroid += p_R;
    }
  }
  if (points_.size() < 5) return std::nullopt;
  centroid /= double(points_.size());

  const Eigen::Vector3d sensor_R = T_R_S.translation();
  const Eigen::Vector3d ray = (centroid - sensor_R).normalized();
  const double range = (centroid - sensor_R).norm();
  const double r = config_.radius_m;

  // Plausibility: enough pixels for a ball at this range, and not wider than one.
  const double ball_pixels = M_PI * std::pow(in.fx * r / range, 2);
  if (points_.size() < config_.min_visible_fraction * ball_pixels) return std::nullopt;
  const Eigen::Vector3d side = ray.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d up = side.cross(ray);
  double side_lo = 1e9, side_hi = -1e9, up_lo = 1e9, up_hi = -1e9;
  for (const Eigen::Vector3d& p : points_) {
    const double s = side.dot(p - centroid), h = up.dot(p - centroid);
    side_lo = std::min(side_lo, s), side_hi = std::max(side_hi, s);
    up_lo = std::min(up_lo, h), up_hi = std::max(up_hi, h);
  }
  const double widest = std::max(side_hi - side_lo, up_hi - up_lo);
  if (widest > config_.max_size_ratio * 2.0 * r) return std::nullopt;

  // The centre, first from the visible disc: pixels sample the cap evenly in the image, so for a
  // disc of normalised radius a (the edge filter trims the limb, a < 1) the mean depth lies
  // (2/3)(1 - (1 - a^2)^(3/2)) / a^2 of a radius in front of the centre. a is measured from the
  // spread of the points across the ray (98th percentile of the distance from the centroid).
  radial_.clear();
  for (const Eigen::Vector3d& p : points_) {
    const Eigen::Vector3d across_ray = (p - centroid) - ray.dot(p - centroid) * ray;
    radial_.push_back(across_ray.norm());
  }
  const std::size_t rank = radial_.size() * 98 / 100;
  std::nth_element(radial_.begin(), radial_.begin() + rank, radial_.end());
  const double a = std::clamp(radial_[rank] / std::sqrt(0.98) / r, 0.3, 1.0);
  const double cap_depth = (2.0 / 3.0) * (1.0 - std::pow(1.0 - a * a, 1.5)) / (a * a);
  BallFit fit;
  fit.center_R = centroid + cap_depth * r * ray;

  // Where the cap's depth is resolved (noise well under the radius) a sphere of the known radius
  // fitted to its points also uses the cap's shape, which keeps a partly hidden ball centred.
  // Depth noise moves points off the sphere mostly along the ray, so on average they lie
  // sqrt(r^2 + sigma^2) from the centre: that is the radius fitted. A fit that strays from the
  // disc estimate by more than a third of a radius is not trusted.
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

  // Uncertainty: a random part, the per-point noise over the number of points (at most 100
  // independent: neighbouring Kinect pixels share their correlation window), and a systematic
  // part, 1 cm in every direction for the extrinsics plus a quarter of the depth quantisation step
  // along the ray, which grows with the square of the range.
  const double n_eff = std::max(1.0, std::min(100.0, double(fit.points)));
  const double along = std::sqrt(std::pow(sigma, 2) / n_eff +
                                 std::pow(noise_.quantisationStep_m(range) / 4, 2) + 1e-4);
  const double across = std::sqrt(std::pow(noise_.lateralSigma_m(range), 2) / n_eff + 1e-4);
  Eigen::Matrix3d basis;
  basis << side, up, ray;
  fit.covariance_m2 = basis * Eigen::Vector3d(across * across, across * across, along * along).asDiagonal() * basis.transpose();
  return fit;
}

}  // namespace kinect3d
