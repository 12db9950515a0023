// The CAMBADA paper's trajectory estimator (Sec. 4), as the baseline: the last 10 positions; a
// trajectory is a vertical plane through its first supporting position, along the horizontal
// direction of the supporting positions, with the height a parabola over horizontal distance
// fitted by SVD, without time. A new position supports it when the point of the parabola at the
// same horizontal distance is within 0.25 m; otherwise the trajectory restarts from the last 3
// positions, and it is reset when the last two positions do not support it.
//
// The paper predicts no times; so that the report can compare, time comes from a straight-line
// fit of horizontal distance over time (the horizontal speed), and velocity from that speed.
#include <Eigen/Dense>

#include <cmath>
#include <deque>

#include "trajectory_estimators.h"

namespace kinect3d {

namespace {

constexpr std::size_t kHistory = 10;
constexpr double kSupport_m = 0.25;
constexpr std::size_t kRestartFrom = 3;

class PaperEstimator : public TrajectoryEstimator {
 public:
  explicit PaperEstimator(const TrajectoryConfig& config) : TrajectoryEstimator(config) {}

 private:
  std::optional<fw::BallTrajectory> step(double t_s, const std::vector<fw::BallObservation>& balls) override {
    if (!balls.empty()) add(balls.front());
    return current(t_s);
  }

  std::optional<double> lastDetectionTime() const override {
    if (history_.empty()) return std::nullopt;
    return history_.back().stamp.source_time_s;
  }

  void lose() override {
    history_.clear();
    support_.clear();
  }

  void add(const fw::BallObservation& ball) {
    history_.push_back(ball);
    if (history_.size() > kHistory) history_.pop_front();
    const bool supports = support_.size() >= kRestartFrom && distanceToCurve(ball.position_m) < kSupport_m;
    if (supports) {
      support_.push_back(ball);
      if (support_.size() > kHistory) support_.erase(support_.begin());
      fit();
    } else if (history_.size() >= kRestartFrom) {
      // A new trajectory with the last 3 positions.
      if (!support_.empty()) countReset();
      support_.assign(history_.end() - kRestartFrom, history_.end());
      fit();
      if (rms_ > kSupport_m) support_.clear();  // "if trajectory error below threshold"
    }
    last_supported_[0] = last_supported_[1];
    last_supported_[1] = supports;
    if (!last_supported_[0] && !last_supported_[1] && support_.size() > kRestartFrom) {
      countReset();
      support_.clear();  // the last two positions do not support it: reset
    }
  }

  // Direction of the horizontal line through the supporting positions (SVD), the parabola
  // z = a d^2 + b d + c over distance d along it from the first (SVD least squares), and the
  // distance's rate over time.
  void fit() {
    const Eigen::Vector2d first = support_.front().position_m.head<2>();
    Eigen::MatrixXd xy(support_.size(), 2);
    for (std::size_t i = 0; i < support_.size(); ++i)
      xy.row(i) = (support_[i].position_m.head<2>() - first).transpose();
    Eigen::JacobiSVD<Eigen::MatrixXd> line(xy.rowwise() - xy.colwise().mean(), Eigen::ComputeThinV);
    direction_ = line.matrixV().col(0);
    if (direction_.dot(xy.row(xy.rows() - 1).transpose()) < 0.0) direction_ = -direction_;
    origin_ = first;
    Eigen::MatrixXd A(support_.size(), 3);
    Eigen::VectorXd z(support_.size()), d(support_.size()), t(support_.size());
    for (std::size_t i = 0; i < support_.size(); ++i) {
      d[i] = direction_.dot(xy.row(i).transpose());
      A.row(i) << d[i] * d[i], d[i], 1.0;
      z[i] = support_[i].position_m.z();
      t[i] = support_[i].stamp.source_time_s - support_.front().stamp.source_time_s;
    }
    parabola_ = A.jacobiSvd(Eigen::ComputeThinU | Eigen::ComputeThinV).solve(z);
    Eigen::MatrixXd T(support_.size(), 2);
    T.col(0) = Eigen::VectorXd::Ones(support_.size());
    T.col(1) = t;
    const Eigen::Vector2d line_in_time = T.jacobiSvd(Eigen::ComputeThinU | Eigen::ComputeThinV).solve(d);
    d0_ = line_in_time[0];
    speed_ = line_in_time[1];
    t0_ = support_.front().stamp.source_time_s;
    double squares = 0.0;
    for (const fw::BallObservation& ball : support_) squares += std::pow(distanceToCurve(ball.position_m), 2);
    rms_ = std::sqrt(squares / support_.size());
  }

  double heightAt(double d) const { return parabola_[0] * d * d + parabola_[1] * d + parabola_[2]; }
  Eigen::Vector3d pointAt(double d) const {
    const Eigen::Vector2d xy = origin_ + d * direction_;
    return {xy.x(), xy.y(), heightAt(d)};
  }
  double distanceToCurve(const Eigen::Vector3d& p) const {
    return (p - pointAt((p.head<2>() - origin_).norm())).norm();
  }
  double timeAtDistance(double d) const { return t0_ + (d - d0_) / speed_; }

  std::optional<fw::BallTrajectory> current(double t_s) const {
    if (support_.size() < kRestartFrom || std::abs(speed_) < 1e-3) return std::nullopt;
    const double d_now = d0_ + speed_ * (t_s - t0_);
    fw::BallTrajectory trajectory;
    trajectory.time_s = t_s;
    trajectory.position_m = pointAt(d_now);
    const double dz_dd = 2.0 * parabola_[0] * d_now + parabola_[1];
    trajectory.velocity_mps << speed_ * direction_, speed_ * dz_dd;
    trajectory.state = fw::BallState::kAir;
    trajectory.gravity_mps2 = fw::kGravity_mps2;
    trajectory.support = static_cast<int>(support_.size());
    trajectory.rms_m = rms_;
    trajectory.source = support_.back().source;
    // Touchdown: where the parabola comes down to the ball's radius, ahead of the ball.
    const double a = parabola_[0], b = parabola_[1], c = parabola_[2] - config().ball_radius_m;
    const double disc = b * b - 4.0 * a * c;
    if (a < 0.0 && disc >= 0.0) {
      const double d_land = (-b - std::sqrt(disc)) / (2.0 * a);  // the far root of a downward parabola
      if (d_land > d_now) {
        fw::Touchdown touchdown;
        touchdown.point_m = origin_ + d_land * direction_;
        touchdown.time_s = timeAtDistance(d_land);
        touchdown.sigma_m = rms_;  // the paper gives no uncertainty; its fit residual stands in
        trajectory.touchdown = touchdown;
      }
    }
    // Crossing the robot's line y = 0 along the plane of the trajectory.
    if (std::abs(direction_.y()) > 1e-6) {
      const double d_cross = -origin_.y() / direction_.y();
      if (d_cross > d_now && (!trajectory.touchdown || timeAtDistance(d_cross) < trajectory.touchdown->time_s)) {
        const Eigen::Vector3d p = pointAt(d_cross);
        trajectory.crossing = fw::LineCrossing{p.x(), p.z(), timeAtDistance(d_cross)};
      }
    }
    return trajectory;
  }

  std::deque<fw::BallObservation> history_;
  std::vector<fw::BallObservation> support_;
  bool last_supported_[2] = {true, true};
  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d direction_ = Eigen::Vector2d::UnitY();
  Eigen::Vector3d parabola_ = Eigen::Vector3d::Zero();
  double d0_ = 0.0, speed_ = 0.0, t0_ = 0.0, rms_ = 0.0;
};

}  // namespace

std::unique_ptr<TrajectoryEstimator> makePaperEstimator(const TrajectoryConfig& config) {
  return std::make_unique<PaperEstimator>(config);
}

}  // namespace kinect3d
