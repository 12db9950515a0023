#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>

#include "trajectory_estimators.h"

namespace kinect3d {

namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector8d = Eigen::Matrix<double, 8, 1>;
using Matrix8d = Eigen::Matrix<double, 8, 8>;
using Vector2d = Eigen::Vector2d;
using Matrix22d = Eigen::Matrix2d;
using Matrix32d = Eigen::Matrix<double, 3, 2>;
using Matrix62d = Eigen::Matrix<double, 6, 2>;
// Every fit's normal equations (6, 8 or 9 unknowns) are solved by one LDLT of a matrix of up to 9 x 9
// on the stack, for one kind of right-hand side each: an LDLT of each fixed size, and its solve for
// each fixed right-hand side, was compiled on its own, most of this file's compile time.
using NormalMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 9, 9>;
using NormalVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 9, 1>;
using NormalLdlt = Eigen::LDLT<NormalMatrix>;

// Drag per metre is kept inside what a ball can have (a size 5 ball: about 0.011-0.027).
constexpr double kMaxDrag_per_m = 0.06;
// Pseudo-observations that hold the fit's variance factor towards 1 (see solve()).
constexpr double kVarianceFactorPrior = 10.0;
// and never below this: the detections are not better than about half the model error stated.
constexpr double kMinVarianceFactor = 0.3;
// A sidespin's curve is kept inside what a kick can give (10 rev/s bends a shot by about 0.18 rad/s).
constexpr double kMaxCurve_radps = 0.5;
// Steps for the numerical derivatives of the flight by the drag (/m) and the curve (rad/s).
const Vector2d kPhysicsStep(1e-3, 1e-2);
// The step for physics parameter k alone.
Vector2d physicsNudge(int k) { return k == 0 ? Vector2d(kPhysicsStep[0], 0.0) : Vector2d(0.0, kPhysicsStep[1]); }
// The prior weight that holds a parameter not estimated where it is.
constexpr double kPinned = 1e12;

// Faster than any kick in the league (about 10 m/s): a detection that would need more is a new ball.
constexpr double kMaxSpeed_mps = 20.0;

class BallisticEstimator : public TrajectoryEstimator {
 public:
  explicit BallisticEstimator(const TrajectoryConfig& config) : TrajectoryEstimator(config) {}

 private:
  std::optional<fw::BallTrajectory> step(double t_s, const std::vector<fw::BallObservation>& balls) override {
    if (const fw::BallObservation* ball = choose(t_s, balls)) add(*ball);
    return current(t_s);
  }

  std::optional<double> lastDetectionTime() const override {
    if (segment_.empty()) return std::nullopt;
    return segment_.back().stamp.source_time_s;
  }

  void lose() override {
    segment_.clear();
    pending_.clear();
    fitted_ = false;
  }

  // The detection nearest the prediction (Mahalanobis); before a fit, the one nearest the track's
  // last detection; with no track, the first one (the detector lists balls in the air first).
  const fw::BallObservation* choose(double t_s, const std::vector<fw::BallObservation>& balls) const {
    if (balls.empty()) return nullptr;
    if (!fitted_) {
      if (segment_.empty()) return &balls.front();
      const Eigen::Vector3d& last = segment_.back().position_m;
      return &*std::min_element(balls.begin(), balls.end(), [&](const auto& a, const auto& b) {
        return (a.position_m - last).squaredNorm() < (b.position_m - last).squaredNorm();
      });
    }
    const fw::BallObservation* best = &balls.front();
    double best_distance = INFINITY;
    for (const fw::BallObservation& ball : balls) {
      const double distance = mahalanobisSquared(ball, t_s);
      if (distance < best_distance) best_distance = distance, best = &ball;
    }
    return best;
  }

  void add(const fw::BallObservation& ball) {
    const double t = ball.stamp.source_time_s;
    if (!fitted_) {
      if (!segment_.empty()) {
        // A new segment for a ball too far from the last to be the same, and for a ball that left
        // the floor: its resting or rolling detections before the kick are not on the flight.
        const fw::BallObservation& last = segment_.back();
        const double dt = std::max(t - last.stamp.source_time_s, 1e-3);
        const bool kicked = last.state == fw::BallState::kGround && ball.state == fw::BallState::kAir;
        if (kicked || (ball.position_m - last.position_m).norm() > kMaxSpeed_mps * dt + 0.3) segment_.clear();
      }
      push(ball);
      if (segment_.size() >= 3) fit();
      return;
    }
    if (mahalanobisSquared(ball, t) <= config().gate_sigma * config().gate_sigma) {
      pending_.clear();
      push(ball);
      fit();
      return;
    }
    if (airborne_ && bouncedBefore(t)) {
      // Ground contact with the vertical velocity reversing: the flight ends, a new segment starts.
      restartWith({ball});
      return;
    }
    if (!airborne_ && ball.state == fw::BallState::kAir) {
      // A ball on the floor that leaves it was kicked: a flight starts.
      restartWith({ball});
      return;
    }
    // Not supporting: an outlier, unless the next one does not support either; then the ball is
    // doing something else and the track restarts from these two.
    pending_.push_back(ball);
    if (pending_.size() >= 2) {
      countReset();
      restartWith({pending_.begin(), pending_.end()});
    }
  }

  void push(const fw::BallObservation& ball) {
    segment_.push_back(ball);
    while (static_cast<int>(segment_.size()) > config().history) segment_.pop_front();
  }

  void restartWith(const std::vector<fw::BallObservation>& start) {
    segment_.assign(start.begin(), start.end());
    pending_.clear();
    fitted_ = false;
    if (segment_.size() >= 3) fit();
  }

  // The fitted flight reached the floor since the last detection: the centre came down to the
  // ball's radius while falling.
  bool bouncedBefore(double t_s) const {
    const fw::BallTrajectory last = state(segment_.back().stamp.source_time_s);
    const double ground = config().ball_radius_m + 0.03;
    return last.velocity_mps.z() < 0.0 && last.positionAt(t_s).z() < ground;
  }

  // The least-squares flight (or roll) through the segment, each detection weighted by its
  // covariance plus the model error. Without drag and spin the model is linear in (p0, v0) and
  // this is one solve. In the air, the model's departure from the drag-free flight, and how that
  // departure changes with the drag and with the spin's curve, are computed in one pass along the
  // current fit; the solve is repeated on the detections minus the departure, with the drag and
  // the curve as two more unknowns held to their priors (drag_per_m +- drag_sigma_per_m,
  // 0 +- curve_sigma_radps). The departure hardly depends on the fit, so three rounds settle it.
  // A sigma of 0 keeps that parameter at its prior's mean.
  void fit() {
    t_ref_ = segment_.front().stamp.source_time_s;
    airborne_ = false;
    for (const fw::BallObservation& ball : segment_) airborne_ = airborne_ || ball.state == fw::BallState::kAir;
    physics_ = airborne_ ? priorMean() : Vector2d::Zero();
    physics_covariance_ = Eigen::Matrix2d::Zero();
    physics_cross_ = Matrix62d::Zero();
    offsets_.assign(segment_.size(), Eigen::Vector3d::Zero());
    slopes_.assign(segment_.size(), Matrix32d::Zero());
    solve();
    const Vector2d sigma = priorSigma();
    const bool estimate = airborne_ && (sigma.array() > 0.0).any();
    if (airborne_ && (physics_[0] > 0.0 || estimate)) {
      for (int round = 0; round < 3; ++round) {
        fw::BallTrajectory along = model(theta_, physics_);
        std::array<fw::BallTrajectory, 2> nudged{model(theta_, physics_ + physicsNudge(0)),
                                                 model(theta_, physics_ + physicsNudge(1))};
        for (std::size_t i = 0; i < segment_.size(); ++i) {
          const double t = segment_[i].stamp.source_time_s;
          along = along.movedTo(t);
          offsets_[i] = along.position_m - dragFree(theta_, t);
          for (int k = 0; k < 2; ++k) {
            if (sigma[k] <= 0.0) continue;
            nudged[k] = nudged[k].movedTo(t);
            slopes_[i].col(k) = (nudged[k].position_m - along.position_m) / kPhysicsStep[k];
          }
        }
        solve(estimate);
      }
    }
    double squares = 0.0;
    for (std::size_t i = 0; i < segment_.size(); ++i) {
      const double t = segment_[i].stamp.source_time_s;
      squares += (segment_[i].position_m - dragFree(theta_, t) - offsets_[i]).squaredNorm();
    }
    rms_ = std::sqrt(squares / segment_.size());
    fitted_ = true;
  }

  // The priors of (drag, curve): the configured drag and no spin.
  Vector2d priorMean() const { return {config().drag_per_m, 0.0}; }
  Vector2d priorSigma() const { return {config().drag_sigma_per_m, config().curve_sigma_radps}; }

  // p0 + v0 tau + g tau^2 / 2 (g only in the air).
  Eigen::Vector3d dragFree(const Vector6d& theta, double t_s) const {
    const double tau = t_s - t_ref_;
    const double g = airborne_ ? fw::kGravity_mps2 : 0.0;
    return theta.head<3>() + tau * theta.tail<3>() + Eigen::Vector3d(0.0, 0.0, -0.5 * g * tau * tau);
  }

  // Weighted least squares for (p0, v0) against the detections minus the model's offsets, and with
  // estimate for the changes of the drag and the curve too (linearised by the slopes, with their
  // priors; a parameter with a prior sigma of 0 stays where it is).
  void solve(bool estimate = false) {
    const double g = airborne_ ? fw::kGravity_mps2 : 0.0;
    Matrix8d normal = Matrix8d::Zero();
    Vector8d rhs = Vector8d::Zero();
    for (std::size_t i = 0; i < segment_.size(); ++i) {
      const fw::BallObservation& ball = segment_[i];
      const double tau = ball.stamp.source_time_s - t_ref_;
      const Eigen::Matrix3d W = weight(ball);
      Eigen::Matrix<double, 3, 8> A;
      A << Eigen::Matrix3d::Identity(), tau * Eigen::Matrix3d::Identity(), slopes_[i];
      const Eigen::Vector3d target = ball.position_m - offsets_[i] + Eigen::Vector3d(0.0, 0.0, 0.5 * g * tau * tau);
      normal += A.transpose() * W * A;
      rhs += A.transpose() * W * target;
    }
    if (!estimate) {
      const NormalLdlt ldlt{NormalMatrix(normal.topLeftCorner<6, 6>())};
      theta_ = ldlt.solve(NormalVector(rhs.head<6>()));
      covariance_ = ldlt.solve(NormalMatrix::Identity(6, 6));
      return;
    }
    // Each prior as one more equation on the change d: d = prior - current.
    const Vector2d sigma = priorSigma(), mean = priorMean();
    int estimated = 0;
    for (int k = 0; k < 2; ++k) {
      const double prior_weight = sigma[k] > 0.0 ? 1.0 / (sigma[k] * sigma[k]) : kPinned;
      normal(6 + k, 6 + k) += prior_weight;
      rhs[6 + k] += sigma[k] > 0.0 ? prior_weight * (mean[k] - physics_[k]) : 0.0;
      estimated += sigma[k] > 0.0;
    }
    const NormalLdlt ldlt{NormalMatrix(normal)};
    const Vector8d solution = ldlt.solve(NormalVector(rhs));
    // The detections' weights assume model_sigma_m of model error each; how well the fit really
    // meets them rescales its covariance (the least-squares variance factor, held towards 1 by
    // kVarianceFactorPrior pseudo-observations so that five detections cannot talk it into zero).
    double chi2 = 0.0;
    for (std::size_t i = 0; i < segment_.size(); ++i) {
      const fw::BallObservation& ball = segment_[i];
      const double tau = ball.stamp.source_time_s - t_ref_;
      const Eigen::Vector3d predicted = solution.head<3>() + tau * solution.segment<3>(3) + offsets_[i] +
                                        slopes_[i] * solution.tail<2>() -
                                        Eigen::Vector3d(0.0, 0.0, 0.5 * g * tau * tau);
      const Eigen::Vector3d r = ball.position_m - predicted;
      chi2 += r.dot(weight(ball) * r);
    }
    const double dof = 3.0 * segment_.size() - 6.0 - estimated;
    const double variance_factor =
        std::max(kMinVarianceFactor, (chi2 + kVarianceFactorPrior) / (std::max(dof, 0.0) + kVarianceFactorPrior));
    const Matrix8d covariance = variance_factor * ldlt.solve(NormalMatrix::Identity(8, 8));
    theta_ = solution.head<6>();
    physics_[0] = std::clamp(physics_[0] + solution[6], 0.0, kMaxDrag_per_m);
    physics_[1] = std::clamp(physics_[1] + solution[7], -kMaxCurve_radps, kMaxCurve_radps);
    physics_covariance_ = covariance.bottomRightCorner<2, 2>();
    covariance_ = covariance.topLeftCorner<6, 6>();
    physics_cross_ = covariance.topRightCorner<6, 2>();
  }

  Eigen::Matrix3d weight(const fw::BallObservation& ball) const {
    const double model_variance = config().model_sigma_m * config().model_sigma_m;
    return (ball.covariance_m2 + model_variance * Eigen::Matrix3d::Identity()).inverse();
  }

  // The motion model with parameters theta = (p0, v0) at t_ref_ and physics (drag, curve). A roll
  // is fitted as constant velocity over the short history; its slowing only matters for
  // predictions further ahead.
  fw::BallTrajectory model(const Vector6d& theta) const { return model(theta, physics_); }
  fw::BallTrajectory model(const Vector6d& theta, const Vector2d& physics) const {
    fw::BallTrajectory m;
    m.time_s = t_ref_;
    m.position_m = theta.head<3>();
    m.velocity_mps = theta.tail<3>();
    m.state = airborne_ ? fw::BallState::kAir : fw::BallState::kGround;
    m.gravity_mps2 = fw::kGravity_mps2;
    m.drag_per_m = airborne_ ? physics[0] : 0.0;
    m.curve_radps = airborne_ ? physics[1] : 0.0;
    return m;
  }

  // The fitted model moved to time t_s, as a trajectory of its own.
  fw::BallTrajectory state(double t_s) const {
    fw::BallTrajectory at = model(theta_).movedTo(t_s);
    if (!airborne_) at.rolling_decel_mps2 = config().rolling_decel_mps2;
    return at;
  }

  // Covariance of the predicted position at t_s (drag-free propagation of the fit's covariance)
  // plus the model error.
  Eigen::Matrix3d predictionCovariance(double t_s) const {
    const double tau = t_s - t_ref_;
    Eigen::Matrix<double, 3, 6> J;
    J << Eigen::Matrix3d::Identity(), tau * Eigen::Matrix3d::Identity();
    return J * covariance_ * J.transpose() +
           config().model_sigma_m * config().model_sigma_m * Eigen::Matrix3d::Identity();
  }

  double mahalanobisSquared(const fw::BallObservation& ball, double t_s) const {
    const Eigen::Vector3d innovation = ball.position_m - model(theta_).positionAt(t_s);
    const Eigen::Matrix3d S = predictionCovariance(t_s) + ball.covariance_m2;
    return innovation.dot(S.inverse() * innovation);
  }

  // A flight that does not fall with gravity is not a ball (a lamp, a poster, a head): with free
  // acceleration fitted, its vertical part must be near -g.
  bool fallsWithGravity() const {
    const double span = segment_.back().stamp.source_time_s - t_ref_;
    if (static_cast<int>(segment_.size()) < 6 || span < 0.15) return true;  // too short to tell
    Eigen::Matrix<double, 9, 9> normal = Eigen::Matrix<double, 9, 9>::Zero();
    Eigen::Matrix<double, 9, 1> rhs = Eigen::Matrix<double, 9, 1>::Zero();
    for (const fw::BallObservation& ball : segment_) {
      const double tau = ball.stamp.source_time_s - t_ref_;
      Eigen::Matrix<double, 3, 9> A;
      A << Eigen::Matrix3d::Identity(), tau * Eigen::Matrix3d::Identity(),
          0.5 * tau * tau * Eigen::Matrix3d::Identity();
      const Eigen::Matrix3d W = weight(ball);
      normal += A.transpose() * W * A;
      rhs += A.transpose() * W * ball.position_m;
    }
    const double a_z = NormalLdlt(NormalMatrix(normal)).solve(NormalVector(rhs))[8];
    return std::abs(a_z + fw::kGravity_mps2) <= config().max_gravity_error_mps2;
  }

  // Enough detections, moving, and falling with gravity: only then is an airborne track a ball
  // in flight. A ball hung or lying on a robot does not move; a poster carried past does not fall.
  bool isFlight() const {
    if (static_cast<int>(segment_.size()) < config().min_support) return false;
    const fw::BallObservation& first = segment_.front();
    const fw::BallObservation& last = segment_.back();
    const double span = last.stamp.source_time_s - first.stamp.source_time_s;
    if ((last.position_m - first.position_m).norm() < config().min_flight_speed_mps * span) return false;
    return fallsWithGravity();
  }

  std::optional<fw::BallTrajectory> current(double t_s) const {
    if (!fitted_ || (airborne_ && !isFlight())) return std::nullopt;
    fw::BallTrajectory trajectory = state(t_s);
    trajectory.support = static_cast<int>(segment_.size());
    trajectory.rms_m = rms_;
    trajectory.source = segment_.back().source;
    if (airborne_) trajectory.touchdown = touchdown(trajectory);
    trajectory.crossing = crossing(trajectory);
    return trajectory;
  }

  // When the centre comes down to the ball's radius, and where; the 1-sigma radius propagates the
  // fit's covariance through the drag-free touchdown.
  std::optional<fw::Touchdown> touchdown(const fw::BallTrajectory& now) const {
    const double r = config().ball_radius_m, g = fw::kGravity_mps2;
    auto dragFreeLanding = [&](const Vector6d& theta, Eigen::Vector2d& point, double& time) {
      const double z0 = theta[2] - r, vz = theta[5];
      const double disc = vz * vz + 2.0 * g * z0;
      if (disc < 0.0) return false;
      const double tau = (vz + std::sqrt(disc)) / g;
      time = t_ref_ + tau;
      point = theta.head<2>() + tau * theta.segment<2>(3);
      return true;
    };
    Eigen::Vector2d point;
    double time;
    if (!dragFreeLanding(theta_, point, time) || time < now.time_s) return std::nullopt;
    Eigen::Matrix<double, 2, 6> J;
    for (int k = 0; k < 6; ++k) {
      Vector6d nudged = theta_;
      nudged[k] += 1e-5;
      Eigen::Vector2d moved;
      double moved_time;
      if (!dragFreeLanding(nudged, moved, moved_time)) return std::nullopt;
      J.col(k) = (moved - point) / 1e-5;
    }
    fw::Touchdown result;
    Eigen::Matrix2d spread = J * covariance_ * J.transpose();
    result.point_m = point;
    result.time_s = time;
    if (physics_[0] > 0.0 || physics_[1] != 0.0 || physics_covariance_.trace() > 0.0) {
      const auto landing = dragLanding(now);
      if (!landing) return std::nullopt;
      result.point_m = landing->first;
      result.time_s = landing->second;
      // What the uncertainty of the drag and the curve, and their correlation with the launch,
      // move the landing.
      Matrix22d slope = Matrix22d::Zero();
      for (int k = 0; k < 2; ++k) {
        if (physics_covariance_(k, k) <= 0.0) continue;
        const auto nudged = dragLanding(model(theta_, physics_ + physicsNudge(k)).movedTo(now.time_s));
        if (nudged) slope.col(k) = (nudged->first - landing->first) / kPhysicsStep[k];
      }
      const Matrix22d cross = J * physics_cross_;
      spread += slope * physics_covariance_ * slope.transpose() + cross * slope.transpose() + slope * cross.transpose();
    }
    result.sigma_m = std::sqrt(std::max(0.0, fw::largestEigenvalue(spread)));
    return result;
  }

  // With drag there is no closed form: the model stepped down to the floor, 10 ms at a time.
  std::optional<std::pair<Eigen::Vector2d, double>> dragLanding(const fw::BallTrajectory& from) const {
    constexpr double kStep_s = 0.01;
    const double r = config().ball_radius_m;
    fw::BallTrajectory walk = from;
    for (int i = 0; i < 500; ++i) {
      const fw::BallTrajectory next = walk.movedTo(walk.time_s + kStep_s);
      if (next.position_m.z() <= r) {
        const double w = (walk.position_m.z() - r) / (walk.position_m.z() - next.position_m.z());
        return std::make_pair(Eigen::Vector2d((walk.position_m + w * (next.position_m - walk.position_m)).head<2>()),
                              walk.time_s + w * kStep_s);
      }
      walk = next;
    }
    return std::nullopt;
  }

  // Where the ball crosses y = 0 of the robot frame, if it is heading there (before touchdown).
  std::optional<fw::LineCrossing> crossing(const fw::BallTrajectory& now) const {
    if (now.position_m.y() <= 0.0 || now.velocity_mps.y() >= -0.1) return std::nullopt;
    double t = now.time_s - now.position_m.y() / now.velocity_mps.y();  // exact without drag
    for (int i = 0; i < 4; ++i) {  // with drag or rolling friction, a few Newton steps
      const fw::BallTrajectory there = now.movedTo(t);
      const double y = there.position_m.y(), vy = there.velocity_mps.y();
      if (std::abs(y) < 1e-4 || vy >= -1e-3) break;
      t -= y / vy;
    }
    const Eigen::Vector3d p = now.positionAt(t);
    if (std::abs(p.y()) > 0.01 || t < now.time_s || t - now.time_s > 3.0) return std::nullopt;
    if (airborne_ && p.z() < config().ball_radius_m) return std::nullopt;  // lands first
    fw::LineCrossing result;
    result.x_m = p.x();
    result.z_m = p.z();
    result.time_s = t;
    return result;
  }

  std::deque<fw::BallObservation> segment_;
  std::vector<fw::BallObservation> pending_;
  bool fitted_ = false;
  bool airborne_ = false;
  double t_ref_ = 0.0;
  Vector6d theta_ = Vector6d::Zero();
  std::vector<Eigen::Vector3d> offsets_;              // the model minus the drag-free flight, per detection
  std::vector<Matrix32d> slopes_;                     // how that changes with the drag and the curve, per detection
  Vector2d physics_ = Vector2d::Zero();               // the fit's (drag /m, curve rad/s): estimated or configured
  Matrix22d physics_covariance_ = Matrix22d::Zero();  // their covariance (0 where not estimated)
  Matrix62d physics_cross_ = Matrix62d::Zero();       // covariance of (p0, v0) with them
  Matrix6d covariance_ = Matrix6d::Identity();
  double rms_ = 0.0;
};

}  // namespace

std::unique_ptr<TrajectoryEstimator> makeBallisticEstimator(const TrajectoryConfig& config) {
  return std::make_unique<BallisticEstimator>(config);
}

}  // namespace kinect3d
