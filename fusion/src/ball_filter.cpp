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
// No bounce is certain to hop on or to end the hops (a ball trapped by a robot, a softer floor).
constexpr double kLandingProbabilityFloor = 0.02;
// The iterated update stops when an iteration moves the ball less than this, or after this many.
constexpr double kUpdateSettled_m = 1e-3;
constexpr int kMaxUpdateIterations = 5;
constexpr int kMaxStepHalvings = 6;
// A touchdown within a step is found to this, and Newton's estimate of it probed this far either
// side, inside that width, so that one pair of probes closes the bracket.
constexpr double kTouchdownTolerance_s = 1e-5;
constexpr double kTouchdownProbe_s = 4e-6;

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

// A measurement's Jacobian with respect to the state (position and velocity; only the position enters).
using MeasurementJacobian = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::ColMajor, 3, 6>;

MeasurementJacobian jacobian(const MeasurementModel& measurement, const Eigen::Vector3d& p_F) {
  constexpr double kStep_m = 1e-4;
  MeasurementJacobian H = MeasurementJacobian::Zero(measurement.value().size(), 6);
  for (int j = 0; j < 3; ++j) {
    Eigen::Vector3d plus = p_F, minus = p_F;
    plus[j] += kStep_m;
    minus[j] -= kStep_m;
    H.col(j) = measurement.residual(measurement.predict(plus), measurement.predict(minus)) / (2.0 * kStep_m);
  }
  return H;
}

// The Kalman gain P H' S^-1.
using Gain = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, 3>;

struct Innovation {
  MeasurementVector y;
  MeasurementJacobian H;
  MeasurementMatrix R, S;
  // The innovation's covariance with the sensor's own noise (MeasurementModel::sensorNoise): the
  // branch's likelihood.
  MeasurementMatrix S_sensor;
};

// The measurement's innovation for hypothesis h, linearised about x_lin (h's own mean, or an
// iterate of the update): y = z - h(x_lin) - H (x - x_lin).
Innovation innovate(const Hypothesis& h, const MeasurementModel& measurement, const Vector6d& x_lin) {
  const Eigen::Vector3d p = x_lin.head<3>();
  Innovation in;
  in.H = jacobian(measurement, p);
  in.y = measurement.residual(measurement.value(), measurement.predict(p)) - in.H * (h.x - x_lin);
  in.R = measurement.noise(p);
  // How fast the prediction changes at x_lin, by the ball's motion and the sensor's: what an error
  // in the measurement's time does.
  const MeasurementVector rate = in.H.leftCols<3>() * x_lin.tail<3>() + measurement.ownMotionRate(p);
  const MeasurementMatrix timing = measurement.timingSigma_s() * measurement.timingSigma_s() * rate * rate.transpose();
  in.R += timing;
  const MeasurementMatrix HPH = in.H * h.P * in.H.transpose();
  in.S = HPH + in.R;
  in.S_sensor = HPH + measurement.sensorNoise(p) + timing;
  return in;
}

}  // namespace

BallFilter::BallFilter(const MotionConfig& config, double time_s, std::vector<Hypothesis> hypotheses)
    : config_(config), time_s_(time_s), hypotheses_(std::move(hypotheses)) {
  for (Hypothesis& h : hypotheses_) {
    if (h.mode == fw::BallState::kGround) keepOnFloor(h);
  }
}

void BallFilter::useBounceOf(const MotionConfig& motion) {
  config_.restitution = motion.restitution;
  config_.restitution_sigma = motion.restitution_sigma;
  config_.bounce_friction = motion.bounce_friction;
  config_.bounce_friction_sigma = motion.bounce_friction_sigma;
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

void BallFilter::fly(Hypothesis& h, double dt, const Vector6d& moved) const {
  // Drag pulls by drag v^2: an uncertain drag is an acceleration uncertain by drag_sigma v^2.
  const double drag_sigma_mps2 = config_.drag_sigma_per_m * h.x.tail<3>().squaredNorm();
  h.x = moved;
  propagateCovariance(h.P, dt, std::hypot(config_.air_accel_sigma_mps2, drag_sigma_mps2), 3);
}

bool BallFilter::flyUntilFloor(Hypothesis& h, double dt, double& dt_left) const {
  const double r = config_.radius_m;
  auto heightAfter = [&](double s) {
    Vector6d x = h.x;
    propagateMean(x, fw::BallState::kAir, config_, s);
    return x;
  };
  // The mean at hi is kept as it is found: the flight's propagation is most of the fusion's time.
  double hi = dt;
  Vector6d at_hi = heightAfter(dt);
  if (at_hi[kZ] >= r) {
    fly(h, dt, at_hi);
    dt_left = 0.0;
    return true;
  }
  // The touchdown: the first time the centre comes down to the radius, to kTouchdownTolerance_s,
  // between lo (the centre above it) and hi (below). Every probe keeps that bracket, so a poor guess
  // costs only time. Newton's step from the fall's start (gravity and the drag there), once more from
  // where it led, and a probe either side of the result close it most often; bisection closes the rest.
  double lo = 0.0;
  const auto inside = [&](double t) { return t > lo && t < hi; };
  const auto probe = [&](double t) {
    const Vector6d at_t = heightAfter(t);
    if (at_t[kZ] < r) {
      hi = t;
      at_hi = at_t;
    } else {
      lo = t;
    }
    return at_t;
  };
  if (h.x[kZ] <= r && h.x[kVz] < 0.0) {
    hi = 0.0;
    at_hi = heightAfter(0.0);
  } else {
    const double height = h.x[kZ] - r, vz = h.x[kVz];
    const double az = -fw::kGravity_mps2 - config_.drag_per_m * h.x.tail<3>().norm() * vz;
    // The smallest positive root of height + vz t + az t^2 / 2 (az < 0 while the ball falls).
    const double discriminant = vz * vz - 2.0 * az * height;
    double guess = discriminant >= 0.0 && az < 0.0 ? (vz + std::sqrt(discriminant)) / -az : 0.5 * hi;
    if (inside(guess)) {
      const Vector6d at_guess = probe(guess);
      if (at_guess[kVz] < 0.0) guess -= (at_guess[kZ] - r) / at_guess[kVz];
    }
    for (const double t : {guess, guess - kTouchdownProbe_s, guess + kTouchdownProbe_s}) {
      if (inside(t)) probe(t);
    }
  }
  for (int i = 0; i < 30 && hi - lo > kTouchdownTolerance_s; ++i) probe(0.5 * (lo + hi));
  fly(h, hi, at_hi);
  h.x[kZ] = r;
  dt_left = dt - hi;
  return false;
}

std::vector<Hypothesis> BallFilter::branchesAt(double t_s) const {
  const double dt = t_s - time_s_;
  if (dt <= 0.0) return hypotheses_;
  std::vector<Hypothesis> branches;
  const double kick = 1.0 - std::exp(-config_.kick_rate_hz * dt);
  const double deflection = 1.0 - std::exp(-config_.deflection_rate_hz * dt);
  const double sk2 = config_.kick_speed_sigma_mps * config_.kick_speed_sigma_mps;
  // A kick at some instant within dt: any new velocity, the position moved by up to dt of it. With
  // two sensors interleaved dt may be a millisecond, but a kick shows in the sensor that sees it up
  // to a frame later: the position spreads over at least that frame.
  const double since_kick = std::max(dt, kKickWindow_s);
  auto kicked = [&](Hypothesis h, double weight, int axes) {
    h.weight = weight;
    for (int i = 0; i < axes; ++i) {
      h.P(i + 3, i + 3) += sk2;
      h.P(i, i) += sk2 * since_kick * since_kick / 4.0;
    }
    return h;
  };
  for (const Hypothesis& h : hypotheses_) {
    if (h.mode == fw::BallState::kGround) {
      Hypothesis rolling = h;
      roll(rolling, dt);
      rolling.weight = h.weight * (1.0 - 2.0 * kick);
      branches.push_back(rolling);
      branches.push_back(kicked(rolling, h.weight * kick, 2));
      Hypothesis into_air = kicked(rolling, h.weight * kick, 3);
      into_air.mode = fw::BallState::kAir;
      branches.push_back(into_air);
      continue;
    }
    Hypothesis flying = h;
    double dt_left = 0.0;
    if (flyUntilFloor(flying, dt, dt_left)) {
      // Flying on, or deflected: a robot's hull, a head or a post gives it a new velocity.
      flying.weight = h.weight * (1.0 - deflection);
      branches.push_back(flying);
      branches.push_back(kicked(flying, h.weight * deflection, 3));
      continue;
    }
    // At the floor: a bounce (restitution and friction uncertain) or the end of the hops, by the
    // chance that this bounce's restitution leaves the ball too slow to hop noticeably.
    const double vz_in = flying.x[kVz];
    const double landing_speed_mps = std::sqrt(2.0 * fw::kGravity_mps2 * kNoticeableHop_m);
    const double restitution_to_land = landing_speed_mps / std::max(std::abs(vz_in), 1e-6);
    const double sigma = std::max(config_.restitution_sigma, 1e-3);
    const double land =
        std::clamp(0.5 * std::erfc((config_.restitution - restitution_to_land) / (sigma * std::sqrt(2.0))),
                   kLandingProbabilityFloor, 1.0 - kLandingProbabilityFloor);
    Hypothesis bounce = bounced(flying);
    bounce.weight = h.weight * (1.0 - land);
    Hypothesis landed = bounce;
    landed.mode = fw::BallState::kGround;
    landed.weight = h.weight * land;
    keepOnFloor(landed);
    roll(landed, dt_left);
    // The rest of the step untouched: a step may span many frames (the world's ball carried to its
    // time after the sensors have long lost it), and a ball stopped at its next touchdown would
    // stand there, falling, until a sensor saw it again.
    bounce = untouched(bounce, dt_left);
    branches.push_back(bounce);
    branches.push_back(landed);
  }
  return branches;
}

Hypothesis BallFilter::bounced(const Hypothesis& flying) const {
  const double vz_in = flying.x[kVz];
  Hypothesis bounce = flying;
  bounce.x[kVz] = -config_.restitution * vz_in;
  bounce.x.segment<2>(3) *= 1.0 - config_.bounce_friction;
  bounce.P(kVz, kVz) += std::pow(std::max(config_.restitution_sigma, 1e-3) * vz_in, 2);
  for (int i = 3; i < 5; ++i) bounce.P(i, i) += std::pow(config_.bounce_friction_sigma * flying.x[i], 2);
  return bounce;
}

Hypothesis BallFilter::untouched(Hypothesis h, double dt) const {
  // Each hop is lower than the last by the restitution: a few dozen end any flight on a field.
  constexpr int kMaxBounces = 50;
  for (int bounce = 1; dt > 0.0; ++bounce) {
    if (h.mode == fw::BallState::kGround) {
      roll(h, dt);
      break;
    }
    double dt_left = 0.0;
    if (flyUntilFloor(h, dt, dt_left)) break;
    h = bounced(h);
    if (!hopsNoticeably(h) || bounce == kMaxBounces) {
      h.mode = fw::BallState::kGround;
      keepOnFloor(h);
    }
    dt = dt_left;
  }
  return h;
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
    const Innovation in = innovate(h, measurement, h.x);
    const Eigen::LDLT<MeasurementMatrix> S(in.S);
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
    // Iterated: linearised again about the updated state until it stays put. An omni phantom's
    // distance bends so steeply with the height that one linearisation about the prior can throw
    // the ball metres away. A step that leaves the ball where the sensor could not have seen it
    // (the model is only held finite there), or a ball in the air under the floor (an omni ray goes
    // on below the floor past the ball), is halved until it does not.
    const double r = config_.radius_m;
    const auto possible = [&](const Vector6d& state) {
      return measurement.canSee(state.head<3>()) && (h.mode != fw::BallState::kAir || state[kZ] >= r);
    };
    Vector6d x = h.x;
    Innovation in;
    Gain K;
    for (int iteration = 0; iteration < kMaxUpdateIterations; ++iteration) {
      const Innovation at_x = innovate(h, measurement, x);
      const Gain K_at_x = Eigen::LDLT<MeasurementMatrix>(at_x.S).solve(at_x.H * h.P).transpose();  // P H' S^-1
      Vector6d next = h.x + K_at_x * at_x.y;
      for (int halving = 0; halving < kMaxStepHalvings && !possible(next); ++halving) {
        next = x + 0.5 * (next - x);
      }
      if (iteration > 0 && !possible(next)) break;
      const bool settled = (next - x).head<3>().norm() < kUpdateSettled_m;
      in = at_x;
      K = K_at_x;
      x = next;
      if (settled) break;
    }
    h.x = x;
    const Matrix6d I_KH = Matrix6d::Identity() - K * in.H;
    h.P = I_KH * h.P * I_KH.transpose() + K * in.R * K.transpose();  // Joseph form: stays symmetric
    if (h.mode == fw::BallState::kGround) keepOnFloor(h);
    if (h.mode == fw::BallState::kAir) h.x[kZ] = std::max(h.x[kZ], r);  // what halving left under the floor
    // Weighed by the sensor's own noise: the looser hold on an omni phantom keeps the update's step
    // short, but as a likelihood it made a flight that predicted the phantom as unlikely as a wide
    // guess, and a ground branch chasing the phantoms outweighed it (docs/fusion.md).
    const Eigen::LDLT<MeasurementMatrix> S(in.S_sensor);
    const double log_det = S.vectorD().array().log().sum();
    log_likelihood[i] = -0.5 * (in.y.dot(S.solve(in.y)) + log_det + in.y.size() * std::log(2.0 * M_PI));
    if (h.weight > 0.0) best_log = std::max(best_log, log_likelihood[i]);
  }
  // Relative to the likeliest branch that has weight (a branch without any keeps none: its likelihood
  // may be far above, and 0 times a huge factor is not a number). No branch could have made it (the
  // sensor sees none of them): the measurement says nothing of which is right, and the weights stay.
  if (std::isfinite(best_log)) {
    for (std::size_t i = 0; i < branches.size(); ++i) {
      if (branches[i].weight > 0.0) branches[i].weight *= std::exp(log_likelihood[i] - best_log);
    }
  }
  mergePerMode(branches);
  time_s_ = std::max(time_s_, t_s);
}

void BallFilter::forgetVelocity(double sigma_mps) {
  for (Hypothesis& h : hypotheses_) {
    h.P.topRightCorner<3, 3>().setZero();
    h.P.bottomLeftCorner<3, 3>().setZero();
    h.P.bottomRightCorner<3, 3>() = sigma_mps * sigma_mps * Eigen::Matrix3d::Identity();
    if (h.mode == fw::BallState::kGround) keepOnFloor(h);
  }
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

const Hypothesis& BallFilter::best() const { return likeliest(hypotheses_); }

const Hypothesis& BallFilter::likeliest(const std::vector<Hypothesis>& branches) {
  return *std::max_element(branches.begin(), branches.end(),
                           [](const Hypothesis& a, const Hypothesis& b) { return a.weight < b.weight; });
}

bool BallFilter::hopsNoticeably(const Hypothesis& h) const {
  if (h.mode != fw::BallState::kAir) return false;
  const double height = h.x[kZ] - config_.radius_m, vz = h.x[kVz];
  const double two_g = 2.0 * fw::kGravity_mps2;
  if (vz > 0.0) return height + vz * vz / two_g >= kNoticeableHop_m;
  // Coming down: the next hop rises by the restitution's share of the speed at touchdown.
  const double touchdown_speed2 = vz * vz + two_g * std::max(height, 0.0);
  return std::max(height, config_.restitution * config_.restitution * touchdown_speed2 / two_g) >= kNoticeableHop_m;
}

double BallFilter::airProbability() const {
  for (const Hypothesis& h : hypotheses_) {
    if (h.mode == fw::BallState::kAir) return h.weight;
  }
  return 0.0;
}

}  // namespace fusion
