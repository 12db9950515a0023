#include "framework_api/pose_history.h"

#include <algorithm>
#include <cmath>

namespace fw {

namespace {
double timeOf(const RobotPose& pose) { return pose.stamp.source_time_s; }

// Poses closer in time than this carry no velocity worth using: the later one stands. (Two poses a
// denormal apart once turned a 0.1 s extrapolation into an infinite one.)
constexpr double kMinSpan_s = 1e-3;

RobotPose blend(const RobotPose& a, const RobotPose& b, double t_s) {
  const double span = timeOf(b) - timeOf(a);
  const double w = span >= kMinSpan_s ? (t_s - timeOf(a)) / span : 1.0;
  RobotPose pose = a;
  pose.x_m = a.x_m + w * (b.x_m - a.x_m);
  pose.y_m = a.y_m + w * (b.y_m - a.y_m);
  pose.theta_rad = wrapAngle(a.theta_rad + w * wrapAngle(b.theta_rad - a.theta_rad));
  pose.stamp.source_time_s = t_s;
  return pose;
}
}  // namespace

void PoseHistory::add(const RobotPose& pose) {
  const TimeLine::Step step = time_line_.next(timeOf(pose));
  if (step == TimeLine::Step::kNotFinite) return;
  if (step == TimeLine::Step::kJump) poses_.clear();
  const auto later = std::upper_bound(poses_.begin(), poses_.end(), timeOf(pose),
                                      [](double t, const RobotPose& p) { return t < timeOf(p); });
  poses_.insert(later, pose);
  while (timeOf(poses_.front()) < timeOf(poses_.back()) - kKeep_s) poses_.pop_front();
}

RobotPose PoseHistory::at(double t_s) const {
  if (poses_.empty()) {
    RobotPose origin;
    origin.stamp.source_time_s = t_s;
    return origin;
  }
  if (!std::isfinite(t_s)) return poses_.back();
  if (t_s <= timeOf(poses_.front())) return poses_.front();
  if (t_s >= timeOf(poses_.back())) {
    if (poses_.size() < 2) return poses_.back();
    const RobotPose& a = poses_[poses_.size() - 2];
    const RobotPose& b = poses_.back();
    return blend(a, b, std::min(t_s, timeOf(b) + kMaxExtrapolation_s));
  }
  const auto after =
      std::upper_bound(poses_.begin(), poses_.end(), t_s, [](double t, const RobotPose& p) { return t < timeOf(p); });
  return blend(*(after - 1), *after, t_s);
}

}  // namespace fw
