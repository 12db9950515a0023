// The ball's true path when a match log comes from the simulator (kinect3d.source = sim:<scene> in
// the recorded configuration): what the match report and the viewer draw beside what the robot saw.
#pragma once

#include <optional>

#include <Eigen/Core>

#include "kinect3d/sim/ball_motion.h"
#include "kinect3d/sim/scene.h"
#include "matchlog/match_log.h"

namespace kinect3d {

class RecordedTruth {
 public:
  // Nothing known for a log without a simulated source, or whose scene cannot be loaded any more.
  explicit RecordedTruth(const fw::RunInfo& run);

  bool known() const { return motion_.has_value(); }
  // The ball's centre in the robot frame at a source time of the depth sensor; only when known().
  Eigen::Vector3d ball_R(double source_time_s) const;

 private:
  std::optional<sim::Scene> scene_;
  std::optional<sim::BallMotion> motion_;
};

}  // namespace kinect3d
