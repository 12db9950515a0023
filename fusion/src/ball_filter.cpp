#include "fusion/ball_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/LU>

namespace fusion {

namespace {

constexpr int kZ = 2, kVz = 5;
// A branch lighter than this share of the heaviest is not worth gating against. Kept small: an
// unlikely branch (a kick) is exactly the one a surprising measurement belongs to.
constexpr double kNegligibleWeight = 1e-6;
// A branch with less than this share of its mode's heaviest is pruned, not merged: merged, an
// unlikely kick would widen the velocity of every rolling ball at every step.
constexpr double kPruneWeight = 0.01;
// A kick is seen at most this long after it happened (a sensor frame at 30 Hz).
constexpr double kKickWindow_s = 1.0 / 30.0;
// Below this vertical speed after a bounce the ball most likely rolls on: its hops stay under 5 cm,
// which a robot treats as a ball on the floor.
constexpr double kLandingSpeed_mps = 1.0;

// Position and velocity of the mean after dt, by the same propagation as fw::BallTrajectory.
void propagateMean(Vector6d& x, fw::BallState mode, const MotionConfig& config, double dt) {
  fw::BallTrajectory motion;
  motion.state = mode;
  motion.position_m = x.head<3>();
  motion.velocity_mps = x.tail<3>();
  motion.drag_per_m = config.drag_per_m;
  motion.rolling_decel_mps2 = config.rolling_decel_mps2;
  const fw::BallTrajectory moved = motion.movedTo(dt);
  x.head<3>() = moved.position_m;
  x.tail<3>() = moved.velocity_mps;
}

// Constant-velocity transition and white-noise acceleration of sigma on the given axes.
void propagateCovariance(Matrix6d& P, double dt, double accel_sigma, int axes) {
  Matrix6d F = Matrix6d::Identity();
  F.topRightCorner<3, 3>() = dt * Eigen::Matrix3d::Identity();
  P = F * P * F.transpose();
  const double q = accel_sigma * accel_sigma;
  for (int i = 0; i < axes; ++i) {
    P(i, i) += q * dt * dt * dt / 3.0;
    P(i, i + 3) += q * dt * dt / 2.0;
    P(i + 3, i) += q * dt * dt / 2.0;
    P(i + 3, i + 3) += q * dt;
  }
}

Eigen::MatrixXd jacobian(const MeasurementModel& measurement, const Eigen::Vector3d& p_F) {
  constexpr double kStep_m = 1e-4;
  const Eigen::VectorXd h0 = measurement.predict(p_F);
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(h0.size(), 6);
  for (int j = 0; j < 3; ++j) {
    Eigen::Vector3d plus = p_F, minus = p_F;
    plus[j] += kStep_m;
    minus[j] -= kStep_m;
    H.col(j) = measurement.residual(measurement.predict(plus), measurement.predict(minus)) / (2.0 * kStep_m);
  }
  return H;
}

struct Innovation {
  Eigen::VectorXd y;
  Eigen::MatrixXd H, R, S;
};

Innovation innovate(const Hypothesis& h, const MeasurementModel& measurement) {
  const Eigen::Vector3d p = h.x.head<3>();
  Innovation in;
  in.y = measurement.residual(measurement.value(), measurement.predict(p));
  in.H = jacobian(measurement, p);
  in.R = measurement.noise(p);
  const Eigen::VectorXd rate = BallFilter::predictionRate(h, measurement);
  in.R += measurement.timingSigma_s() * measurement.timingSigma_s() * rate * rate.transpose();
  in.S = in.H * h.P * in.H.transpose() + in.R;
  return in;
}

}  // namespace

BallFilter::BallFilter(const MotionConfig& config, double time_s, std::vector<Hypothesis> hypotheses)
    : config_(config), time_s_(time_s), hypotheses_(std::move(hypotheses)) {
  for (Hypothesis& h : hypotheses_) {
    if (h.mode == fw::BallState::kGround) keepOnFloor(h);
  }
}

void BallFilter::keepOnFloor(Hypothesis& h) const {
  h.x[kZ] = config_.radius_m;
  h.x[kVz] = 0.0;
  for (const int i : {kZ, kVz}) {
    h.P.row(i).setZero();
    h.P.col(i).setZero();
  }
}

void BallFilter::roll(Hypothesis& h, double dt) const {
  propagateMean(h.x, fw::BallState::kGround, config_, dt);
  propagateCovariance(h.P, dt, config_.ground_accel_sigma_mps2, 2);
  keepOnFloor(h);
}

void BallFilter::fly(Hypothesis& h, double dt) const {
  propagateMean(h.x, fw::BallState::kAir, config_, dt);
  propagateCovariance(h.P, dt, config_.air_accel_sigma_mps2, 3);
}

bool BallFilter::flyUntilFloor(Hypothesis& h, double dt, double& dt_left) const {
  const double r = config_.radius_m;
  auto heightAfter = [&](double s) {
    Vector6d x = h.x;
    propagateMean(x, fw::BallState::kAir, config_, s);
    return x;
  };
  const Vector6d end = heightAfter(dt);
  if (end[kZ] >= r) {
    fly(h, dt);
    dt_left = 0.0;
    return true;
  }
  // Bisect for the touchdown: the first time the centre comes down to the radius.
  double lo = 0.0, hi = dt;
  if (h.x[kZ] <= r && h.x[kVz] < 0.0) hi = 0.0;
  for (int i = 0; i < 30 && hi - lo > 1e-5; ++i) {
    const double mid = 0.5 * (lo + hi);
    (heightAfter(mid)[kZ] < r ? hi : lo) = mid;
  }
  fly(h, hi);
  h.x[kZ] = r;
  dt_left = dt - hi;
  return false;
}

std::vector<Hypothesis> BallFilter::branchesAt(double t_s) const {
  const double dt = t_s - time_s_;
  if (dt <= 0.0) return hypotheses_;
  std::vector<Hypothesis> branches;
  const double kick = 1.0 - std::exp(-config_.kick_rate_hz * dt);
  const double sk2 = config_.kick_speed_sigma_mps * config_.kick_speed_sigma_mps;
  for (const Hypothesis& h : hypotheses_) {
    if (h.mode == fw::BallState::kGround) {
      Hypothesis rolling = h;
      roll(rolling, dt);
      rolling.weight = h.weight * (1.0 - 2.0 * kick);
      branches.push_back(rolling);
      // A kick at some instant within dt: any new velocity, the position moved by up to dt of it.
      // With two sensors interleaved dt may be a millisecond, but a kick shows in the sensor that
      // sees it up to a frame later: the position spreads over at least that frame.
      const double since_kick = std::max(dt, kKickWindow_s);
      Hypothesis along_ground = rolling;
      along_ground.weight = h.weight * kick;
      for (int i = 0; i < 2; ++i) {
        along_ground.P(i + 3, i + 3) += sk2;
        along_ground.P(i, i) += sk2 * since_kick * since_kick / 4.0;
      }
      branches.push_back(along_ground);
      Hypothesis into_air = along_ground;
      into_air.mode = fw::BallState::kAir;
      into_air.P(kZ, kZ) += sk2 * since_kick * since_kick / 4.0;
      into_air.P(kVz, kVz) += sk2;
      branches.push_back(into_air);
      continue;
    }
    Hypothesis flying = h;
    double dt_left = 0.0;
    if (flyUntilFloor(flying, dt, dt_left)) {
      branches.push_back(flying);
      continue;
    }
    // At the floor: a bounce (restitution and friction uncertain) or the end of the hops.
    const double vz_in = flying.x[kVz];
    const double vz_out = -config_.restitution * vz_in;
    const double land = std::abs(vz_out) < kLandingSpeed_mps ? 0.9 : 0.2;
    Hypothesis bounce = flying;
    bounce.x[kVz] = vz_out;
    bounce.x.segment<2>(3) *= 1.0 - config_.bounce_friction;
    bounce.P(kVz, kVz) += std::pow(0.25 * vz_out, 2);
    for (int i = 3; i < 5; ++i) bounce.P(i, i) += std::pow(0.2 * bounce.x[i], 2);
    bounce.weight = h.weight * (1.0 - land);
    Hypothesis landed = bounce;
    landed.mode = fw::BallState::kGround;
    landed.weight = h.weight * land;
    keepOnFloor(landed);
    roll(landed, dt_left);
    double unused = 0.0;
    flyUntilFloor(bounce, dt_left, unused);  // a second bounce within one step is below a frame's notice
    branches.push_back(bounce);
    branches.push_back(landed);
  }
  return branches;
}

Eigen::VectorXd BallFilter::predictionRate(const Hypothesis& h, const MeasurementModel& measurement) {
  const Eigen::Vector3d p = h.x.head<3>();
  return jacobian(measurement, p).leftCols<3>() * h.x.tail<3>() + measurement.ownMotionRate(p);
}

MeasurementFit BallFilter::fit(const std::vector<Hypothesis>& branches, const MeasurementModel& measurement) {
  double heaviest = 0.0, total = 0.0;
  for (const Hypothesis& h : branches) {
    heaviest = std::max(heaviest, h.weight);
    total += h.weight;
  }
  MeasurementFit fit{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  double likelihood = 0.0;
  for (const Hypothesis& h : branches) {
    if (h.weight < kNegligibleWeight * heaviest || !measurement.canSee(h.x.head<3>())) continue;
    const Innovation in = innovate(h, measurement);
    const Eigen::LDLT<Eigen::MatrixXd> S(in.S);
    const double d2 = in.y.dot(S.solve(in.y));
    fit.mahalanobis = std::min(fit.mahalanobis, std::sqrt(d2));
    const double log_det = S.vectorD().array().log().sum();
    likelihood += h.weight / total * std::exp(-0.5 * (d2 + log_det + in.y.size() * std::log(2.0 * M_PI)));
  }
  if (likelihood > 0.0) fit.log_likelihood = std::log(likelihood);
  return fit;
}

void BallFilter::update(std::vector<Hypothesis> branches, double t_s, const MeasurementModel& measurement) {
  std::vector<double> log_likelihood(branches.size());
  double best_log = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < branches.size(); ++i) {
    Hypothesis& h = branches[i];
    // A ball where the sensor cannot see it did not make this measurement; its branch is not
    // moved by it either (near an omni camera's viewpoint height the model is singular).
    if (!measurement.canSee(h.x.head<3>())) {
      log_likelihood[i] = -std::numeric_limits<double>::infinity();
      continue;
    }
    const Innovation in = innovate(h, measurement);
    const Eigen::LDLT<Eigen::MatrixXd> S(in.S);
    const Eigen::MatrixXd K = (S.solve(in.H * h.P)).transpose();  // P H' S^-1, S symmetric
    h.x += K * in.y;
    const Matrix6d I_KH = Matrix6d::Identity() - K * in.H;
    h.P = I_KH * h.P * I_KH.transpose() + K * in.R * K.transpose();  // Joseph form: stays symmetric
    if (h.mode == fw::BallState::kGround) keepOnFloor(h);
    const double log_det = S.vectorD().array().log().sum();
    log_likelihood[i] = -0.5 * (in.y.dot(S.solve(in.y)) + log_det + in.y.size() * std::log(2.0 * M_PI));
    if (h.weight > 0.0) best_log = std::max(best_log, log_likelihood[i]);
  }
  for (std::size_t i = 0; i < branches.size(); ++i) branches[i].weight *= std::exp(log_likelihood[i] - best_log);
  mergePerMode(branches);
  time_s_ = std::max(time_s_, t_s);
}

void BallFilter::notSeen(double t_s, const std::function<double(const Hypothesis&)>& detection_probability) {
  // Each mode is looked for where it would be now, without branching: a look that found nothing
  // says where the ball is not, and is no reason to widen the state by another step's kicks.
  const double dt = t_s - time_s_;
  double total = 0.0;
  for (Hypothesis& h : hypotheses_) {
    Hypothesis now = h;
    if (dt > 0.0 && h.mode == fw::BallState::kGround) roll(now, dt);
    double unused = 0.0;
    if (dt > 0.0 && h.mode == fw::BallState::kAir) flyUntilFloor(now, dt, unused);
    h.weight *= 1.0 - detection_probability(now);
    total += h.weight;
  }
  if (total > 0.0) {
    for (Hypothesis& h : hypotheses_) h.weight /= total;
  }
}

void BallFilter::predict(double t_s) {
  std::vector<Hypothesis> branches = branchesAt(t_s);
  mergePerMode(branches);
  time_s_ = std::max(time_s_, t_s);
}

void BallFilter::mergePerMode(std::vector<Hypothesis>& branches) {
  double total = 0.0;
  for (const Hypothesis& h : branches) total += h.weight;
  std::vector<Hypothesis> merged;
  for (const fw::BallState mode : {fw::BallState::kGround, fw::BallState::kAir}) {
    double heaviest = 0.0;
    for (const Hypothesis& h : branches) {
      if (h.mode == mode) heaviest = std::max(heaviest, h.weight);
    }
    Hypothesis m;
    m.mode = mode;
    m.weight = 0.0;
    m.x.setZero();
    double kept = 0.0;
    for (const Hypothesis& h : branches) {
      if (h.mode != mode) continue;
      m.weight += h.weight;
      if (h.weight < kPruneWeight * heaviest) continue;
      kept += h.weight;
      m.x += h.weight * h.x;
    }
    // A mode explaining less than a millionth of the data is dropped; transitions bring it back.
    if (m.weight <= 1e-6 * total) continue;
    m.x /= kept;
    m.P.setZero();
    for (const Hypothesis& h : branches) {
      if (h.mode != mode || h.weight < kPruneWeight * heaviest) continue;
      const Vector6d d = h.x - m.x;
      m.P += h.weight * (h.P + d * d.transpose());
    }
    m.P /= kept;
    m.weight /= total;
    if (mode == fw::BallState::kGround) keepOnFloor(m);
    merged.push_back(m);
  }
  hypotheses_ = std::move(merged);
}

const Hypothesis& BallFilter::best() const {
  return *std::max_element(hypotheses_.begin(), hypotheses_.end(),
                           [](const Hypothesis& a, const Hypothesis& b) { return a.weight < b.weight; });
}

double BallFilter::airProbability() const {
  for (const Hypothesis& h : hypotheses_) {
    if (h.mode == fw::BallState::kAir) return h.weight;
  }
  return 0.0;
}

}  // namespace fusion
