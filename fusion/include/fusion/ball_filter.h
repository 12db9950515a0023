// One ball's state in the field frame, under two motion modes at once: rolling on the ground and
// flying. Each step, every mode hypothesis branches into what can happen next (a ground ball keeps
// rolling, is kicked along the ground or into the air; a flying ball keeps flying, is deflected,
// bounces or lands), each branch is weighted by how likely that is and how well it explains the
// measurement, and the branches are merged per mode (a GPB2 multiple-model filter). A wrong mode
// guess is thus recovered within a few measurements, and a kick or touchdown switches the mode when
// the data shows it, not after a timeout.
#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

#include "framework_api/types.h"
#include "fusion/fusion_config.h"

namespace fusion {

// A hop lower than this (the ball's centre above rest) is a ball rolling on: a bounce that leaves
// the ball too slow to rise this high ends the hops.
constexpr double kNoticeableHop_m = 0.05;

using Vector6d = Eigen::Matrix<double, 6, 1>;  // position (m), velocity (m/s), field frame
using Matrix6d = Eigen::Matrix<double, 6, 6>;

struct Hypothesis {
  fw::BallState mode = fw::BallState::kGround;
  Vector6d x = Vector6d::Zero();
  Matrix6d P = Matrix6d::Identity();
  double weight = 1.0;
};

// A measurement's vector and matrices: sized when it is made (a Kinect's centre has three rows, the
// omni camera's bearing and distance two) but held without the heap, for the fusion innovates
// thousands of them a second once teammates speak.
using MeasurementVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, 3, 1>;
using MeasurementMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 3, 3>;

// A measurement of the ball's centre: its value z, its noise R, and the model h(p_F) that predicts
// it from a centre in the field frame. Only the position enters; Jacobians are numerical. A source
// whose stamps are uncertain by timing_sigma_s adds what that does as the ball and the sensor move:
// (H v + ownMotionRate) sigma_t.
class MeasurementModel {
 public:
  explicit MeasurementModel(double timing_sigma_s = 0.0) : timing_sigma_s_(timing_sigma_s) {}
  virtual ~MeasurementModel() = default;
  double timingSigma_s() const { return timing_sigma_s_; }
  virtual MeasurementVector predict(const Eigen::Vector3d& p_F) const = 0;
  virtual const MeasurementVector& value() const = 0;
  // Measurement noise, evaluated at the predicted centre (noise may grow with distance): what an
  // update moves the ball by. It may hold more than the sensor's own noise, where the model bends
  // too steeply for one linearised step to be trusted.
  virtual MeasurementMatrix noise(const Eigen::Vector3d& p_F) const = 0;
  // The sensor's own noise alone: what a branch's likelihood is judged by. An allowance that keeps
  // the update's steps short is no evidence against the branch that predicted the measurement.
  virtual MeasurementMatrix sensorNoise(const Eigen::Vector3d& p_F) const { return noise(p_F); }
  // z - h; angles wrapped.
  virtual MeasurementVector residual(const MeasurementVector& z, const MeasurementVector& h) const { return z - h; }
  // How fast the prediction for a ball lying still at p_F changes because the sensor moves (a
  // turning robot turns an omni ball's bearing): with the ball's own motion, what a stamp's error
  // does.
  virtual MeasurementVector ownMotionRate(const Eigen::Vector3d&) const {
    return MeasurementVector::Zero(value().size());
  }
  // Whether the sensor can see a ball at p_F at all (an omni camera sees nothing above some height);
  // a branch it cannot see is neither credited with the measurement nor moved by it.
  virtual bool canSee(const Eigen::Vector3d&) const { return true; }

 private:
  double timing_sigma_s_;
};

struct MeasurementFit {
  // The smallest Mahalanobis distance from any branch (the gate: a surprising measurement is
  // exactly the one an unlikely branch, a kick, explains) ...
  double mahalanobis;
  // ... and the log of its density under all branches, each by its weight (the choice between
  // tracks: a track that has been unseen long explains anything a little, its own ball well).
  double log_likelihood;
};

class BallFilter {
 public:
  BallFilter(const MotionConfig& config, double time_s, std::vector<Hypothesis> hypotheses);

  double time() const { return time_s_; }
  // Bounces from now on with motion's restitution and bounce friction (a learnt bounce, BounceLearner).
  void useBounceOf(const MotionConfig& motion);
  // Every mode's successors at t_s, weighted by how likely each transition is (not yet merged).
  std::vector<Hypothesis> branchesAt(double t_s) const;
  // How the measurement fits the branches that are not negligible.
  static MeasurementFit fit(const std::vector<Hypothesis>& branches, const MeasurementModel& measurement);
  // Updates every branch with the measurement, reweights and merges them per mode at t_s.
  void update(std::vector<Hypothesis> branches, double t_s, const MeasurementModel& measurement);
  // Keeps every mode's velocity but not what it believed of it: sigma_mps in each axis, and no link to
  // the position (a velocity derived from a position the filter had lost is a guess).
  void forgetVelocity(double sigma_mps);
  // Moves to t_s without a measurement.
  void predict(double t_s);
  // Where h's ball is dt later if nothing touches it: flying, bouncing with the ball's mean
  // restitution and friction until its hops die out, then rolling (no kick, no deflection).
  Hypothesis untouched(Hypothesis h, double dt) const;
  // A sensor looked at t_s and did not see the ball: each mode loses weight by the chance that the
  // sensor would have seen the ball where that mode puts it now (a ball rolling in the omni
  // camera's view is seldom missed; one above its view always is).
  void notSeen(double t_s, const std::function<double(const Hypothesis&)>& detection_probability);

  // The more probable mode's hypothesis, and the weight of the air mode.
  const Hypothesis& best() const;
  // The branch of most weight.
  static const Hypothesis& likeliest(const std::vector<Hypothesis>& branches);
  // Whether a flying hypothesis rises, now or after its next bounce, higher than kNoticeableHop_m
  // above rest: lower hops are the ball rolling on for any robot, and are reported on the ground.
  bool hopsNoticeably(const Hypothesis& h) const;
  double airProbability() const;
  const std::vector<Hypothesis>& hypotheses() const { return hypotheses_; }

 private:
  // One mode's motion over dt without transitions; returns false if a flight reaches the floor
  // first, leaving the state at the touchdown and dt_left what remains.
  bool flyUntilFloor(Hypothesis& h, double dt, double& dt_left) const;
  void roll(Hypothesis& h, double dt) const;
  // The flight's covariance over dt; its mean is the one flyUntilFloor moved to (moved).
  void fly(Hypothesis& h, double dt, const Vector6d& moved) const;
  void keepOnFloor(Hypothesis& h) const;
  // A flight at the floor after a bounce: the mean restitution and friction, their spread added.
  Hypothesis bounced(const Hypothesis& flying) const;
  void mergePerMode(std::vector<Hypothesis>& branches);

  MotionConfig config_;
  double time_s_;
  std::vector<Hypothesis> hypotheses_;  // at most one per mode
};

}  // namespace fusion
