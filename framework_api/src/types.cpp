#include "framework_api/types.h"

#include <chrono>
#include <cmath>

namespace fw {

double wallClockNow_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

const char* toString(Frame frame) {
  switch (frame) {
    case Frame::kSensor: return "sensor";
    case Frame::kRobot: return "robot";
    case Frame::kField: return "field";
  }
  return "?";
}

const char* toString(BallState state) { return state == BallState::kAir ? "air" : "ground"; }

Eigen::Vector3d RobotPose::fieldFromRobot(const Eigen::Vector3d& p_R) const {
  const double c = std::cos(theta_rad), s = std::sin(theta_rad);
  return {x_m + c * p_R.x() - s * p_R.y(), y_m + s * p_R.x() + c * p_R.y(), p_R.z()};
}

BallObservation BallObservation::inRobotFrame(const Eigen::Vector3d& p_R,
                                              const Eigen::Matrix3d& cov_m2, BallState state,
                                              std::string source, Stamp stamp) {
  BallObservation observation;
  observation.position_m = p_R;
  observation.covariance_m2 = cov_m2;
  observation.frame = Frame::kRobot;
  observation.state = state;
  observation.source = std::move(source);
  observation.stamp = stamp;
  return observation;
}

bool BallObservation::isApprox(const BallObservation& other, double tol_m) const {
  return frame == other.frame && state == other.state && source == other.source &&
         (position_m - other.position_m).cwiseAbs().maxCoeff() <= tol_m &&
         (covariance_m2 - other.covariance_m2).cwiseAbs().maxCoeff() <= tol_m * tol_m;
}

Eigen::Vector3d OmniBallObservation::groundPoint_R() const {
  // Bearing 0 looks along +y; positive turns towards -x (counter-clockwise seen from above).
  return {-distance_m * std::sin(bearing_rad), distance_m * std::cos(bearing_rad), 0.0};
}

}  // namespace fw
