// Ball -> trajectory: the ball's motion from its recent detections, and where and when it will
// touch down and cross the robot's line. Two estimators behind one interface:
//   - paper:     the CAMBADA baseline: last 10 positions, a parabola over horizontal distance fitted
//                by SVD without time, support within 0.25 m, restart from the last 3 positions,
//                reset when the last two do not support.
//   - ballistic: p(t) = p0 + v0 t + g t^2 / 2 with known gravity (and optional quadratic drag),
//                fitted by least squares weighted by each detection's covariance; support tested
//                on the Mahalanobis residual; bounces start a new segment; a ball on the floor
//                rolls; a 'flight' that does not fall with g is not a ball.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "framework_api/types.h"

namespace kinect3d {

struct TrajectoryConfig {
  enum class Mode { kBallistic, kPaper };
  Mode mode = Mode::kBallistic;
  double ball_radius_m = 0.11;
  double gravity_mps2 = 9.81;
  double drag_per_m = 0.0;              // ballistic: quadratic drag (0.024 for a size 5 ball); 0 = none
  double rolling_decel_mps2 = 0.4;      // a rolling ball slows by this
  double gate_sigma = 4.0;              // a detection supports the fit within this many sigma
  double model_sigma_m = 0.02;          // model error added to every prediction
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
  virtual std::optional<fw::BallTrajectory> update(double t_s, const std::vector<fw::BallObservation>& balls) = 0;
  // How often the track was thrown away and restarted (bounces and lost balls excluded).
  virtual int resets() const = 0;
};

std::unique_ptr<TrajectoryEstimator> makeTrajectoryEstimator(const TrajectoryConfig& config);

}  // namespace kinect3d
