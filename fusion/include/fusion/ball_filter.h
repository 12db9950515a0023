// One ball's state in the field frame, under two motion modes at once: rolling on the ground and
// flying. Each step, every mode hypothesis branches into what can happen next (a ground ball keeps
// rolling, is kicked along the ground or into the air; a flying ball keeps flying, bounces or
// lands), each branch is weighted by how likely that is and how well it explains the measurement,
// and the branches are merged per mode (a GPB2 multiple-model filter). A wrong mode guess is thus
// recovered within a few measurements, and a kick or touchdown switches the mode when the data
// shows it, not after a timeout.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "framework_api/types.h"
#include "fusion/fusion_config.h"

namespace fusion {

using Vector6d = Eigen::Matrix<double, 6, 1>;  // position (m), velocity (m/s), field frame
using Matrix6d = Eigen::Matrix<double, 6, 6>;

struct Hypothesis {
  fw::BallState mode = fw::BallState::kGround;
  Vector6d x = Vector6d::Zero();
  Matrix6d P = Matrix6d::Identity();
  double weight = 1.0;
};

// A measurement of the ball's centre: its value z, its noise R, and the model h(p_F) that predicts
// it from a centre in the field frame. Only the position enters; Jacobians are numerical. A source
// whose stamps are uncertain by timing_sigma_s adds what that does to a moving ball: H v sigma_t.
class MeasurementModel {
 public:
  explicit MeasurementModel(double timing_sigma_s = 0.0) : timing_sigma_s_(timing_sigma_s) {}
  virtual ~MeasurementModel() = default;
  double timingSigma_s() const { return timing_sigma_s_; }
  virtual Eigen::VectorXd predict(const Eigen::Vector3d& p_F) const = 0;
  virtual const Eigen::VectorXd& value() const = 0;
  // Measurement noise, evaluated at the predicted centre (noise may grow with distance).
  virtual Eigen::MatrixXd noise(const Eigen::Vector3d& p_F) const = 0;
  // z - h; angles wrapped.
  virtual Eigen::VectorXd residual(const Eigen::VectorXd& z, const Eigen::VectorXd& h) const { return z - h; }

 private:
  double timing_sigma_s_;
};

class BallFilter {
 public:
  BallFilter(const MotionConfig& config, double time_s, std::vector<Hypothesis> hypotheses);

  double time() const { return time_s_; }
  // Every mode's successors at t_s, weighted by how likely each transition is (not yet merged).
  std::vector<Hypothesis> branchesAt(double t_s) const;
  // The smallest Mahalanobis distance of the measurement from any branch that is not negligible.
  static double mahalanobis(const std::vector<Hypothesis>& branches, const MeasurementModel& measurement);
  // Updates every branch with the measurement, reweights and merges them per mode at t_s.
  void update(std::vector<Hypothesis> branches, double t_s, const MeasurementModel& measurement);
  // Moves to t_s without a measurement.
  void predict(double t_s);

  // The more probable mode's hypothesis, and the weight of the air mode.
  const Hypothesis& best() const;
  double airProbability() const;
  const std::vector<Hypothesis>& hypotheses() const { return hypotheses_; }

 private:
  // One mode's motion over dt without transitions; returns false if a flight reaches the floor
  // first, leaving the state at the touchdown and dt_left what remains.
  bool flyUntilFloor(Hypothesis& h, double dt, double& dt_left) const;
  void roll(Hypothesis& h, double dt) const;
  void fly(Hypothesis& h, double dt) const;
  void keepOnFloor(Hypothesis& h) const;
  void mergePerMode(std::vector<Hypothesis>& branches);

  MotionConfig config_;
  double time_s_;
  std::vector<Hypothesis> hypotheses_;  // at most one per mode
};

}  // namespace fusion
