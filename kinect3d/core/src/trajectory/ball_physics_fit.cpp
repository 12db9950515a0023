#include "kinect3d/ball_physics_fit.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace kinect3d {

namespace {

using Vector8d = Eigen::Matrix<double, 8, 1>;
using Matrix8d = Eigen::Matrix<double, 8, 8>;

constexpr double kAirMargin_m = 0.05;   // above resting height: in the air
constexpr double kMaxGap_s = 0.1;       // a longer gap ends a run of detections
constexpr double kMaxSpeed_mps = 20.0;  // a jump needing more is another ball
constexpr int kMinDetections = 8;
constexpr double kMinSpan_s = 0.2;
constexpr double kMinSpeed_mps = 2.0;          // slower flights say almost nothing about drag
constexpr double kMaxBounceGap_s = 0.25;       // between the end of one flight and the next's start
constexpr double kMinFrictionSpeed_mps = 0.5;  // slower along the floor, a bounce says little of its friction
constexpr double kMinDragSigma_per_m = 0.002;  // the prior never pins the drag: a ball's drag moves with speed
// A flight whose own drag is this uncertain (short, slow, far) says little about the ball; it
// would only inflate the spread between flights, so the prior leaves it out when others say more.
constexpr double kInformativeSigma_per_m = 0.005;

struct Detection {
  double t_s;
  Eigen::Vector3d p_m;
};

// theta = (p0, v0, drag, curve) at t0.
fw::BallTrajectory modelOf(const Vector8d& theta, double t0) {
  fw::BallTrajectory m;
  m.time_s = t0;
  m.position_m = theta.head<3>();
  m.velocity_mps = theta.segment<3>(3);
  m.state = fw::BallState::kAir;
  m.gravity_mps2 = fw::kGravity_mps2;
  m.drag_per_m = std::max(0.0, theta[6]);
  m.curve_radps = theta[7];
  return m;
}

// Stacked positions of the model at the detections' times.
Eigen::VectorXd predict(const Vector8d& theta, const std::vector<Detection>& run) {
  Eigen::VectorXd out(3 * run.size());
  fw::BallTrajectory along = modelOf(theta, run.front().t_s);
  for (std::size_t i = 0; i < run.size(); ++i) {
    along = along.movedTo(run[i].t_s);
    out.segment<3>(3 * i) = along.position_m;
  }
  return out;
}

std::optional<FlightFit> fitFlight(const std::vector<Detection>& run) {
  const double t0 = run.front().t_s;
  Eigen::VectorXd observed(3 * run.size());
  for (std::size_t i = 0; i < run.size(); ++i) observed.segment<3>(3 * i) = run[i].p_m;
  // Start from the drag-free flight (linear), no drag and no curve.
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * run.size(), 6);
  Eigen::VectorXd b(3 * run.size());
  for (std::size_t i = 0; i < run.size(); ++i) {
    const double tau = run[i].t_s - t0;
    A.block<3, 3>(3 * i, 0).setIdentity();
    A.block<3, 3>(3 * i, 3) = tau * Eigen::Matrix3d::Identity();
    b.segment<3>(3 * i) = run[i].p_m + Eigen::Vector3d(0, 0, 0.5 * fw::kGravity_mps2 * tau * tau);
  }
  Vector8d theta = Vector8d::Zero();
  theta.head<6>() = A.colPivHouseholderQr().solve(b);
  const Vector8d step_sizes = (Vector8d() << 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-3).finished();
  Eigen::MatrixXd J(3 * run.size(), 8);
  for (int iteration = 0; iteration < 10; ++iteration) {
    const Eigen::VectorXd at = predict(theta, run);
    for (int k = 0; k < 8; ++k) {
      Vector8d nudged = theta;
      nudged[k] += step_sizes[k];
      J.col(k) = (predict(nudged, run) - at) / step_sizes[k];
    }
    const Vector8d step = (J.transpose() * J).ldlt().solve(J.transpose() * (observed - at));
    theta += step;
    theta[6] = std::max(0.0, theta[6]);
    if (step.cwiseQuotient(step_sizes).cwiseAbs().maxCoeff() < 1e-2) break;
  }
  const Eigen::VectorXd residual = observed - predict(theta, run);
  const double dof = 3.0 * run.size() - 8.0;
  const double variance = residual.squaredNorm() / dof;
  const Matrix8d covariance = variance * (J.transpose() * J).inverse();
  if (!std::isfinite(covariance(6, 6))) return std::nullopt;
  FlightFit fit;
  fit.start_s = t0;
  fit.end_s = run.back().t_s;
  fit.detections = static_cast<int>(run.size());
  fit.trajectory = modelOf(theta, t0);
  fit.drag_sigma_per_m = std::sqrt(covariance(6, 6));
  fit.rms_m = std::sqrt(residual.squaredNorm() / run.size());
  return fit;
}

// The mean of values, and from two of them on their spread (sample standard deviation).
void meanAndSpread(const std::vector<double>& values, std::optional<double>& mean, std::optional<double>& sigma) {
  if (values.empty()) return;
  double sum = 0.0, squares = 0.0;
  for (const double v : values) sum += v, squares += v * v;
  const double n = static_cast<double>(values.size());
  mean = sum / n;
  if (n >= 2) sigma = std::sqrt(std::max(0.0, (squares - sum * sum / n) / (n - 1)));
}

// Where a flight's model meets the floor (the centre at the ball's radius), searched forward or
// backward from its time in 5 ms steps for at most a second; its state there.
std::optional<fw::BallTrajectory> atFloor(const fw::BallTrajectory& flight, double radius_m, double direction) {
  constexpr double kStep_s = 0.005;
  fw::BallTrajectory walk = flight;
  for (int i = 0; i < 200; ++i) {
    const fw::BallTrajectory next = walk.movedTo(walk.time_s + direction * kStep_s);
    if (next.position_m.z() <= radius_m) {
      const double w = (walk.position_m.z() - radius_m) / (walk.position_m.z() - next.position_m.z());
      return walk.movedTo(walk.time_s + direction * w * kStep_s);
    }
    walk = next;
  }
  return std::nullopt;
}

}  // namespace

BallPhysicsCalibration calibrateBallPhysics(const std::vector<fw::BallFrame>& frames, double radius_m) {
  // One ball through the frames, then runs of airborne detections.
  std::vector<std::vector<Detection>> runs(1);
  std::optional<Detection> last;
  for (const fw::BallFrame& frame : frames) {
    if (frame.balls.empty()) continue;
    const Eigen::Vector3d* chosen = &frame.balls.front().position_m;
    if (last) {
      for (const fw::BallObservation& ball : frame.balls) {
        if ((ball.position_m - last->p_m).norm() < (*chosen - last->p_m).norm()) chosen = &ball.position_m;
      }
    }
    const Detection detection{frame.stamp.source_time_s, *chosen};
    const bool continues = last && detection.t_s - last->t_s <= kMaxGap_s && detection.t_s > last->t_s &&
                           (detection.p_m - last->p_m).norm() <= kMaxSpeed_mps * (detection.t_s - last->t_s) + 0.3;
    if (!continues && !runs.back().empty()) runs.emplace_back();
    if (detection.p_m.z() > radius_m + kAirMargin_m) {
      runs.back().push_back(detection);
    } else if (!runs.back().empty()) {
      runs.emplace_back();  // on the floor: a bounce or a roll ends the run
    }
    last = detection;
  }

  BallPhysicsCalibration result;
  for (const std::vector<Detection>& run : runs) {
    if (run.empty()) continue;
    const double span = run.back().t_s - run.front().t_s;
    const double speed = span > 0.0 ? (run.back().p_m - run.front().p_m).norm() / span : 0.0;
    const std::optional<FlightFit> fit =
        static_cast<int>(run.size()) >= kMinDetections && span >= kMinSpan_s && speed >= kMinSpeed_mps ? fitFlight(run)
                                                                                                       : std::nullopt;
    if (fit) {
      result.flights.push_back(*fit);
    } else {
      ++result.runs_skipped;
    }
  }
  if (result.flights.empty()) {
    throw std::invalid_argument("no flight to fit: " + std::to_string(result.runs_skipped) +
                                " runs of detections in the air, none with " + std::to_string(kMinDetections) +
                                " detections over 0.2 s at 2 m/s or faster");
  }

  // The drag: precision-weighted mean, widened by the spread between flights their own errors do
  // not explain (DerSimonian and Laird's between-study variance).
  std::vector<FlightFit> informative;
  for (const FlightFit& f : result.flights) {
    if (f.drag_sigma_per_m <= kInformativeSigma_per_m) informative.push_back(f);
  }
  if (informative.empty()) informative = result.flights;
  double sum_w = 0.0, sum_w2 = 0.0, sum_wk = 0.0;
  for (const FlightFit& f : informative) {
    const double w = 1.0 / std::pow(std::max(f.drag_sigma_per_m, 1e-5), 2);
    sum_w += w, sum_w2 += w * w, sum_wk += w * f.trajectory.drag_per_m;
  }
  const double mean = sum_wk / sum_w;
  double q = 0.0;
  for (const FlightFit& f : informative) {
    q += std::pow((f.trajectory.drag_per_m - mean) / std::max(f.drag_sigma_per_m, 1e-5), 2);
  }
  const double between =
      result.flights.size() > 1 ? std::max(0.0, (q - (result.flights.size() - 1.0)) / (sum_w - sum_w2 / sum_w)) : 0.0;
  result.drag_per_m = mean;
  result.drag_sigma_per_m = std::max(kMinDragSigma_per_m, std::sqrt(between + 1.0 / sum_w));

  // Bounces: one flight's fall meets the next one's rise at the floor, at the same time and place.
  for (std::size_t i = 0; i + 1 < result.flights.size(); ++i) {
    const FlightFit &before = result.flights[i], &after = result.flights[i + 1];
    if (after.start_s - before.end_s > kMaxBounceGap_s) continue;
    const auto down = atFloor(before.trajectory.movedTo(before.end_s), radius_m, 1.0);
    const auto up = atFloor(after.trajectory, radius_m, -1.0);
    if (!down || !up || down->velocity_mps.z() >= 0.0 || up->velocity_mps.z() <= 0.0) continue;
    if (std::abs(down->time_s - up->time_s) > 0.05 || (down->position_m - up->position_m).norm() > 0.3) continue;
    BounceFit bounce{0.5 * (down->time_s + up->time_s), up->velocity_mps.z() / -down->velocity_mps.z(), {}};
    const double along_in = down->velocity_mps.head<2>().norm();
    if (along_in >= kMinFrictionSpeed_mps) bounce.friction = 1.0 - up->velocity_mps.head<2>().norm() / along_in;
    result.bounces.push_back(bounce);
  }
  std::vector<double> restitutions, frictions;
  for (const BounceFit& b : result.bounces) {
    restitutions.push_back(b.restitution);
    if (b.friction) frictions.push_back(*b.friction);
  }
  meanAndSpread(restitutions, result.restitution, result.restitution_sigma);
  meanAndSpread(frictions, result.bounce_friction, result.bounce_friction_sigma);
  return result;
}

}  // namespace kinect3d
