// Ball -> trajectory: the ball's motion from its recent detections, and where and when it will
// touch down and cross the robot's line. Two estimators behind one interface:
//   - paper:     the CAMBADA baseline: last 10 positions, a parabola over horizontal distance fitted
//                by SVD without time, support within 0.25 m, restart from the last 3 positions,
//                reset when the last two do not support.
//   - ballistic: p(t) = p0 + v0 t + g t^2 / 2 with known gravity and quadratic drag (estimated
//                with the flight from a prior), fitted by least squares weighted by each
//                detection's covariance; support tested
//                on the Mahalanobis residual; bounces start a new segment; a ball on the floor
//                rolls; a 'flight' that does not fall with g is not a ball.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "framework_api/time_line.h"
#include "framework_api/types.h"

namespace kinect3d {

struct TrajectoryConfig {
  enum class Mode { kBallistic, kPaper };
  Mode mode = Mode::kBallistic;
  double ball_radius_m = 0.11;      // ball.radius_m, as the detector's
  double drag_per_m = 0.02;         // ballistic: quadratic drag rho Cd A / 2m, the prior's mean (size 5: 0.011-0.027)
  double drag_sigma_per_m = 0.007;  // and its 1-sigma spread; 0 = the drag is drag_per_m, not estimated
  double curve_sigma_radps = 0.15;  // ballistic: a sidespin's Magnus curve, prior 0 +- this; 0 = no curve
  double rolling_decel_mps2 = 0.4;  // a rolling ball slows by this
  double gate_sigma = 4.0;          // a detection supports the fit within this many sigma
  double model_sigma_m = 0.02;      // model error added to every prediction
  double max_gravity_error_mps2 = 4.0;  // a flight must fall with g to within this
  double min_flight_speed_mps = 1.0;    // and move at least this fast (first to last detection)
  int min_support = 4;                  // detections before a flight is reported
  double max_gap_s = 0.3;               // the track is lost after this long without a detection
  int history = 30;                     // detections kept per segment (one second at 30 Hz)
};

// "ballistic" or "paper"; throws std::invalid_argument for anything else.
TrajectoryConfig::Mode trajectoryModeFromString(const std::string& name);

class TrajectoryEstimator {
 public:
  virtual ~TrajectoryEstimator() = default;

  // Feeds one frame: its source time and the balls detected in it (none is fine). Returns the
  // trajectory at t_s with touchdown and line crossing, or nothing while there is no track.
  // The checks every estimator needs live here, once: a frame whose time does not move on or is
  // not finite is not used (the previous answer stands), one whose time jumps (fw::TimeLine) drops
  // the track and starts again from it; balls in the air inside static space (a lamp, a ball on a
  // wire) are not followed; the track is dropped after max_gap_s without a detection.
  std::optional<fw::BallTrajectory> update(double t_s, const std::vector<fw::BallObservation>& balls);
  // How often the track was thrown away and restarted (bounces and lost balls excluded).
  int resets() const { return resets_; }

 protected:
  explicit TrajectoryEstimator(const TrajectoryConfig& config) : config_(config) {}
  const TrajectoryConfig& config() const { return config_; }
  void countReset() { ++resets_; }

 private:
  // The estimator's own step, with time moving on and only balls it may follow.
  virtual std::optional<fw::BallTrajectory> step(double t_s, const std::vector<fw::BallObservation>& balls) = 0;
  // The source time of the newest detection the track holds; nothing without a track.
  virtual std::optional<double> lastDetectionTime() const = 0;
  // Drops the track.
  virtual void lose() = 0;

  TrajectoryConfig config_;
  int resets_ = 0;
  fw::TimeLine time_line_;
  std::optional<fw::BallTrajectory> last_answer_;
  std::vector<fw::BallObservation> followed_;  // this frame's balls the estimator may follow
};

std::unique_ptr<TrajectoryEstimator> makeTrajectoryEstimator(const TrajectoryConfig& config);

}  // namespace kinect3d
