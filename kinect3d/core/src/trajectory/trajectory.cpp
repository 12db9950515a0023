#include <algorithm>
#include <stdexcept>

#include "trajectory_estimators.h"

namespace kinect3d {

TrajectoryConfig::Mode trajectoryModeFromString(const std::string& name) {
  if (name == "ballistic") return TrajectoryConfig::Mode::kBallistic;
  if (name == "paper") return TrajectoryConfig::Mode::kPaper;
  throw std::invalid_argument("unknown trajectory mode '" + name + "'; expected 'ballistic' or 'paper'");
}

std::optional<fw::BallTrajectory> TrajectoryEstimator::update(double t_s,
                                                              const std::vector<fw::BallObservation>& balls) {
  switch (time_line_.next(t_s)) {
    case fw::TimeLine::Step::kNotFinite:
    case fw::TimeLine::Step::kLate:
      return last_answer_;  // not used: the previous answer stands
    case fw::TimeLine::Step::kJump:
      lose();  // a new time line: the track's detections belong to another
      break;
    case fw::TimeLine::Step::kFirst:
    case fw::TimeLine::Step::kOnward:
      if (const auto last_s = lastDetectionTime(); last_s && t_s - *last_s > config_.max_gap_s) lose();
      break;
  }
  // Not a ball the colour image rejected, nor one floating in static space; a ball the colour image
  // confirmed first, so that a new track starts on it.
  followed_.clear();
  for (const fw::BallObservation& ball : balls) {
    if (ball.followed() && !(ball.is_static && ball.state == fw::BallState::kAir)) followed_.push_back(ball);
  }
  std::stable_partition(followed_.begin(), followed_.end(),
                        [](const fw::BallObservation& ball) { return ball.colour == fw::ColourVerdict::kConfirmed; });
  last_answer_ = step(t_s, followed_);
  return last_answer_;
}

std::unique_ptr<TrajectoryEstimator> makeTrajectoryEstimator(const TrajectoryConfig& config) {
  return config.mode == TrajectoryConfig::Mode::kPaper ? makePaperEstimator(config) : makeBallisticEstimator(config);
}

}  // namespace kinect3d
