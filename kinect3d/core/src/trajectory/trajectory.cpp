#include <stdexcept>

#include "trajectory_estimators.h"

namespace kinect3d {

TrajectoryConfig::Mode trajectoryModeFromString(const std::string& name) {
  if (name == "ballistic") return TrajectoryConfig::Mode::kBallistic;
  if (name == "paper") return TrajectoryConfig::Mode::kPaper;
  throw std::invalid_argument("unknown trajectory mode '" + name + "'; expected 'ballistic' or 'paper'");
}

std::unique_ptr<TrajectoryEstimator> makeTrajectoryEstimator(const TrajectoryConfig& config) {
  return config.mode == TrajectoryConfig::Mode::kPaper ? makePaperEstimator(config) : makeBallisticEstimator(config);
}

}  // namespace kinect3d
