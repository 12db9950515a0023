// The robot's recent poses, so that every measurement is mapped to the field frame with the pose
// at its own time, not the newest one.
#pragma once

#include <deque>

#include "framework_api/time_line.h"
#include "framework_api/types.h"

namespace fw {

class PoseHistory {
 public:
  // How long poses are kept behind the newest one.
  static constexpr double kKeep_s = 2.0;
  // How far past the newest pose it is extrapolated (a pose arriving a little after a measurement).
  static constexpr double kMaxExtrapolation_s = 0.1;

  // Poses may arrive in any order; time is stamp.source_time_s. One whose time is not finite is
  // left out; one whose time jumps (TimeLine, by more than kKeep_s) starts the history again.
  void add(const RobotPose& pose);
  // Interpolated between the poses around t_s; the first before them, extrapolated at constant
  // velocity at most kMaxExtrapolation_s after them (the newest for a time that is not finite).
  // Without any pose: the field origin, facing +y.
  RobotPose at(double t_s) const;
  bool empty() const { return poses_.empty(); }

 private:
  std::deque<RobotPose> poses_;  // by time, oldest first
  TimeLine time_line_{kKeep_s};
};

}  // namespace fw
