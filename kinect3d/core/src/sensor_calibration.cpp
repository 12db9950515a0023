#include "kinect3d/sensor_calibration.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "kinect3d/kinect_disparity.h"

namespace kinect3d {

namespace {

constexpr double kDetectionNoise_m = 0.005;  // what marks agree to at best: a ball centre's error

std::string metres(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f m", value);
  return text;
}

double horizontalSpread(const std::vector<const CalibrationMark*>& marks) {
  double spread = 0.0;
  for (const CalibrationMark* a : marks) {
    for (const CalibrationMark* b : marks) spread = std::max(spread, (a->ball_R_m - b->ball_R_m).head<2>().norm());
  }
  return spread;
}

// The distance of the mark farthest from the best line through all of them: the line along the
// marks' principal direction (their scatter's largest eigenvector) through their mean.
double offLine(const std::vector<const CalibrationMark*>& marks) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const CalibrationMark* mark : marks) mean += mark->ball_R_m;
  mean /= static_cast<double>(marks.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const CalibrationMark* mark : marks) scatter += (mark->ball_R_m - mean) * (mark->ball_R_m - mean).transpose();
  const Eigen::Vector3d direction = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvectors().col(2);
  double farthest = 0.0;
  for (const CalibrationMark* mark : marks) {
    const Eigen::Vector3d p = mark->ball_R_m - mean;
    farthest = std::max(farthest, (p - direction * direction.dot(p)).norm());
  }
  return farthest;
}

void requireLayout(const std::vector<const CalibrationMark*>& marks, bool floor, const CalibrationOptions& options) {
  const std::size_t needed = floor ? 2 : 3;
  if (marks.size() < needed) {
    throw CalibrationError(std::to_string(marks.size()) + " mark(s) with a ball: " +
                           (floor ? "with the floor in view two marks fix the pose; add another"
                                  : "without the floor three marks off one line are needed; add " +
                                        std::to_string(needed - marks.size()) + " more"));
  }
  const double spread = horizontalSpread(marks);
  if (spread < options.min_spread_m) {
    throw CalibrationError("the marks lie within " + metres(spread) + " of each other: spread them at least " +
                           metres(options.min_spread_m) + " apart, across the sensor's view");
  }
  if (!floor && offLine(marks) < options.min_off_line_m) {
    throw CalibrationError("the marks lie on one line (none is " + metres(options.min_off_line_m) +
                           " off it), which leaves the pose free to turn about it: add a mark off the line, "
                           "or calibrate with the floor in view");
  }
}

// The rigid fit of the used marks: in the floor's plane on top of the floor's pose, or in 3D.
Eigen::Isometry3d fit(const std::vector<const CalibrationMark*>& marks,
                      const std::optional<Eigen::Isometry3d>& floor_T_R_S) {
  const int n = static_cast<int>(marks.size());
  if (floor_T_R_S) {
    // In the floor's plane the least-squares turn has a closed form: the angle whose tangent is the
    // summed cross products over the summed dot products of the centred points.
    Eigen::Vector2d seen_mean = Eigen::Vector2d::Zero(), truth_mean = Eigen::Vector2d::Zero();
    std::vector<Eigen::Vector2d> seen(n);
    for (int i = 0; i < n; ++i) {
      seen[i] = (*floor_T_R_S * marks[i]->ball_S_m).head<2>();
      seen_mean += seen[i];
      truth_mean += marks[i]->ball_R_m.head<2>();
    }
    seen_mean /= n;
    truth_mean /= n;
    double dot = 0.0, cross = 0.0;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d s = seen[i] - seen_mean, t = marks[i]->ball_R_m.head<2>() - truth_mean;
      dot += s.dot(t);
      cross += s.x() * t.y() - s.y() * t.x();
    }
    const Eigen::Rotation2Dd turn(std::atan2(cross, dot));
    Eigen::Isometry3d planar = Eigen::Isometry3d::Identity();
    planar.linear().topLeftCorner<2, 2>() = turn.toRotationMatrix();
    planar.translation().head<2>() = truth_mean - turn * seen_mean;
    return planar * *floor_T_R_S;
  }
  Eigen::Matrix3Xd seen(3, n), truth(3, n);
  for (int i = 0; i < n; ++i) {
    seen.col(i) = marks[i]->ball_S_m;
    truth.col(i) = marks[i]->ball_R_m;
  }
  return Eigen::Isometry3d(Eigen::umeyama(seen, truth, false));
}

// The floor search's settings without the configured pose, which would stand in for the fit.
GroundAligner::Config withoutPose(GroundAligner::Config ground) {
  ground.pose.reset();
  return ground;
}

double residual(const CalibrationMark& mark, const Eigen::Isometry3d& T_R_S) {
  return (T_R_S * mark.ball_S_m - mark.ball_R_m).norm();
}

Eigen::Matrix<double, 6, 1> parameters(const Eigen::Isometry3d& T_R_S) {
  const fw::SensorPose pose = fw::SensorPose::fromTransform(T_R_S);
  return (Eigen::Matrix<double, 6, 1>() << pose.x_m, pose.y_m, pose.z_m, pose.yaw_rad, pose.pitch_rad, pose.roll_rad)
      .finished();
}

}  // namespace

CalibrationResult calibrateSensorPose(const std::vector<CalibrationMark>& marks,
                                      const std::optional<Eigen::Isometry3d>& floor_T_R_S,
                                      const CalibrationOptions& options) {
  std::vector<const CalibrationMark*> used;
  for (const CalibrationMark& mark : marks) used.push_back(&mark);
  requireLayout(used, floor_T_R_S.has_value(), options);

  // A mislabelled mark: the one whose leaving out lets the others agree, while it lies far off
  // their fit. With four or more marks the rest still determine the pose; repeat while that holds.
  while (used.size() >= 4) {
    std::size_t suspect = 0;
    double others_rms_m = INFINITY, suspect_off_m = 0.0;
    for (std::size_t i = 0; i < used.size(); ++i) {
      std::vector<const CalibrationMark*> others = used;
      others.erase(others.begin() + static_cast<long>(i));
      const Eigen::Isometry3d T = fit(others, floor_T_R_S);
      double sum_sq = 0.0;
      for (const CalibrationMark* mark : others) sum_sq += std::pow(residual(*mark, T), 2);
      const double rms = std::sqrt(sum_sq / others.size());
      if (rms < others_rms_m) {
        others_rms_m = rms;
        suspect = i;
        suspect_off_m = residual(*used[i], T);
      }
    }
    if (suspect_off_m < options.reject_above_m ||
        suspect_off_m < options.reject_factor * std::max(others_rms_m, kDetectionNoise_m)) {
      break;
    }
    used.erase(used.begin() + static_cast<long>(suspect));
  }
  requireLayout(used, floor_T_R_S.has_value(), options);

  const Eigen::Isometry3d T_R_S = fit(used, floor_T_R_S);
  CalibrationResult result;
  result.pose = fw::SensorPose::fromTransform(T_R_S);
  result.used_floor = floor_T_R_S.has_value();
  for (const CalibrationMark& mark : marks) {
    result.residuals_m.push_back(residual(mark, T_R_S));
    result.used.push_back(std::find(used.begin(), used.end(), &mark) != used.end());
  }
  // Jackknife: the spread of the fits that leave one mark out, scaled to the whole set.
  if (used.size() >= (floor_T_R_S ? 3u : 4u)) {
    const Eigen::Matrix<double, 6, 1> all = parameters(T_R_S);
    Eigen::Matrix<double, 6, 1> sum_sq = Eigen::Matrix<double, 6, 1>::Zero();
    for (std::size_t i = 0; i < used.size(); ++i) {
      std::vector<const CalibrationMark*> others = used;
      others.erase(others.begin() + static_cast<long>(i));
      Eigen::Matrix<double, 6, 1> d = parameters(fit(others, floor_T_R_S)) - all;
      for (int k = 3; k < 6; ++k) d[k] = std::remainder(d[k], 2.0 * M_PI);
      sum_sq += d.cwiseProduct(d);
    }
    const double n = static_cast<double>(used.size());
    result.sigma = (sum_sq * (n - 1.0) / n).cwiseSqrt();
  }
  return result;
}

std::optional<Eigen::Vector3d> ballCentreAtPixel(const DepthFrame& frame, const Eigen::Vector2d& pixel,
                                                 double radius_m) {
  const Intrinsics& k = frame.intrinsics;
  const int u0 = static_cast<int>(std::lround(pixel.x())), v0 = static_cast<int>(std::lround(pixel.y()));
  if (u0 < 0 || v0 < 0 || u0 >= k.width || v0 >= k.height) return std::nullopt;
  // The ball's depth at the pick (the median of a few pixels round it, so one flying pixel or the
  // floor at the ball's edge cannot set it), then its surface: pixels within its image radius no
  // nearer than that (the floor in front of a resting ball is) and no deeper than its radius behind.
  std::vector<double> near_pick;
  for (int dv = -2; dv <= 2; ++dv) {
    for (int du = -2; du <= 2; ++du) {
      const int u = u0 + du, v = v0 + dv;
      if (u >= 0 && v >= 0 && u < k.width && v < k.height && frame.at(u, v) != 0)
        near_pick.push_back(frame.at(u, v) * 1e-3);
    }
  }
  if (near_pick.empty()) return std::nullopt;
  std::nth_element(near_pick.begin(), near_pick.begin() + near_pick.size() / 2, near_pick.end());
  const double pick_m = near_pick[near_pick.size() / 2];
  const double nearest_m = pick_m - radius_m * 0.5, deepest_m = pick_m + radius_m;
  const int reach_px = static_cast<int>(k.fx * radius_m / pick_m * 1.3);
  std::vector<Eigen::Vector3d> surface;
  for (int v = std::max(0, v0 - reach_px); v <= std::min(k.height - 1, v0 + reach_px); ++v) {
    for (int u = std::max(0, u0 - reach_px); u <= std::min(k.width - 1, u0 + reach_px); ++u) {
      const double z = frame.at(u, v) * 1e-3;
      if (z == 0.0 || z < nearest_m || z > deepest_m) continue;
      surface.push_back(k.backProject(u, v, z));
    }
  }
  if (surface.size() < 10) return std::nullopt;
  // Start behind the mean surface point along its ray; Gauss-Newton on |p - c| = r, then again on
  // the points that fit (the floor under a resting ball and its edge's flying pixels do not).
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : surface) mean += p;
  mean /= static_cast<double>(surface.size());
  Eigen::Vector3d centre = mean + mean.normalized() * radius_m * 0.7;
  constexpr double kInlier_m = 0.015;
  for (int round = 0; round < 3; ++round) {
    for (int iteration = 0; iteration < 15; ++iteration) {
      Eigen::Matrix3d JtJ = Eigen::Matrix3d::Zero();
      Eigen::Vector3d Jtr = Eigen::Vector3d::Zero();
      for (const Eigen::Vector3d& p : surface) {
        const Eigen::Vector3d d = centre - p;
        const double distance = d.norm();
        if (distance < 1e-9 || (round > 0 && std::abs(distance - radius_m) > kInlier_m)) continue;
        const Eigen::Vector3d J = d / distance;
        JtJ += J * J.transpose();
        Jtr += J * (distance - radius_m);
      }
      const Eigen::Vector3d step = JtJ.ldlt().solve(-Jtr);
      if (!step.allFinite()) return std::nullopt;
      centre += step;
      if (step.norm() < 1e-6) break;
    }
  }
  return centre;
}

FloorCalibrationCheck::FloorCalibrationCheck(const Config& config, const fw::SensorPose& calibrated,
                                             GroundAligner::Config ground)
    : config_(config), calibrated_(calibrated), floor_(withoutPose(ground)) {}

std::optional<fw::SensorPose> FloorCalibrationCheck::check(const DepthFrame& frame) {
  if (++frames_ % config_.interval_frames != 0) return std::nullopt;
  const std::optional<Eigen::Isometry3d> fitted = floor_.fitFloor(frame);
  if (!fitted) return std::nullopt;  // no floor in view: nothing to compare
  const Eigen::Isometry3d T_calibrated = calibrated_.T_R_S();
  // The floor's up direction seen from the sensor, by the calibration and by the fit.
  const Eigen::Vector3d up_calibrated = T_calibrated.linear().transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_fitted = fitted->linear().transpose() * Eigen::Vector3d::UnitZ();
  const double tilt_rad = std::acos(std::clamp(up_calibrated.dot(up_fitted), -1.0, 1.0));
  const double height_m = std::abs(fitted->translation().z() - T_calibrated.translation().z());
  if (tilt_rad <= config_.max_tilt_error_rad && height_m <= config_.max_height_error_m) {
    disagreements_ = 0;
    alarmed_ = false;
    return std::nullopt;
  }
  if (++disagreements_ < config_.confirmations || alarmed_) return std::nullopt;
  alarmed_ = true;
  const fw::SensorPose floor = fw::SensorPose::fromTransform(*fitted);
  fw::SensorPose moved = calibrated_;
  moved.z_m = floor.z_m;
  moved.pitch_rad = floor.pitch_rad;
  moved.roll_rad = floor.roll_rad;
  return moved;
}

GravityCalibrationCheck::GravityCalibrationCheck(const Config& config, const fw::SensorPose& calibrated)
    : config_(config),
      calibrated_(calibrated),
      expected_down_S_(calibrated.T_R_S().linear().transpose() * -Eigen::Vector3d::UnitZ()) {}

std::optional<fw::SensorPose> GravityCalibrationCheck::check(const DepthFrame& frame) {
  if (!frame.gravity_S_mps2) return std::nullopt;
  const Eigen::Vector3d& gravity = *frame.gravity_S_mps2;
  if (std::abs(gravity.norm() - kStandardGravity_mps2) > kMaxMagnitudeError * kStandardGravity_mps2) {
    return std::nullopt;  // the robot is accelerating
  }
  if (window_.empty()) window_start_s_ = frame.source_time_s;
  window_.push_back(gravity.normalized());
  if (frame.source_time_s - window_start_s_ < config_.window_s) return std::nullopt;
  // The median of each component: a burst of acceleration inside the window moves it little.
  Eigen::Vector3d down_S;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> values;
    for (const Eigen::Vector3d& reading : window_) values.push_back(reading[axis]);
    std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
    down_S[axis] = values[values.size() / 2];
  }
  down_S.normalize();
  window_.clear();
  const auto angle = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::acos(std::clamp(a.dot(b), -1.0, 1.0));
  };
  if (!reference_down_S_) {
    reference_down_S_ = angle(down_S, expected_down_S_) <= kAccelerometerAccuracy_rad ? down_S : expected_down_S_;
  }
  if (angle(down_S, *reference_down_S_) <= config_.max_tilt_error_rad) {
    disagreements_ = 0;
    alarmed_ = false;
    return std::nullopt;
  }
  if (++disagreements_ < config_.confirmations || alarmed_) return std::nullopt;
  alarmed_ = true;
  // The sensor turned by the smallest rotation that takes the reference down direction to the
  // measured one: about their cross product (any axis across them if they are opposite).
  const Eigen::Vector3d across = reference_down_S_->cross(down_S);
  const Eigen::Vector3d axis = across.norm() > 1e-9 ? across.normalized() : reference_down_S_->unitOrthogonal();
  const Eigen::Matrix3d turn_S = Eigen::AngleAxisd(angle(*reference_down_S_, down_S), axis).toRotationMatrix();
  Eigen::Isometry3d T_R_S = calibrated_.T_R_S();
  T_R_S.linear() = T_R_S.linear() * turn_S.transpose();
  fw::SensorPose moved = calibrated_;
  const fw::SensorPose tilted = fw::SensorPose::fromTransform(T_R_S);
  moved.pitch_rad = tilted.pitch_rad;
  moved.roll_rad = tilted.roll_rad;
  return moved;
}

}  // namespace kinect3d
