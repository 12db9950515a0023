// The estimators behind makeTrajectoryEstimator(); the rest of the code sees the interface.
#pragma once

#include "kinect3d/trajectory.h"

namespace kinect3d {

std::unique_ptr<TrajectoryEstimator> makeBallisticEstimator(const TrajectoryConfig& config);
std::unique_ptr<TrajectoryEstimator> makePaperEstimator(const TrajectoryConfig& config);

}  // namespace kinect3d
