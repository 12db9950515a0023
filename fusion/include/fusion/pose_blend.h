// The pose the fusion maps its sensors with. Self-localisation knows where the robot stands to a few
// centimetres, but its pose jitters from frame to frame; over the third of a second the Kinect sees a
// flight, that jitter reads as 0.1-0.3 m/s of ball velocity (docs/fusion.md, "Accuracy"). The wheels'
// odometry drifts over a match but moves smoothly. Blended, the pose moves as the odometry says and is
// pulled towards the localisation's over a time constant: a complementary filter on the plane.
#pragma once

#include <optional>

#include "framework_api/types.h"

namespace fusion {

class PoseBlend {
 public:
  // The localisation's pose is followed over about time_constant_s (0: taken as it comes). A
  // localisation that jumps from the blend by more than kJumpSigmas of its error (sigma_xy_m,
  // sigma_theta_rad: a relocalisation) is taken at once.
  PoseBlend(double time_constant_s, double sigma_xy_m, double sigma_theta_rad);

  static constexpr double kJumpSigmas = 6.0;
  // Longer without a pose than this, the blend starts again from the localisation's.
  static constexpr double kMaxGap_s = 1.0;

  // The blended pose at the localisation's pose's time. A pose without odometry, or older than the
  // last, is returned as it is (the first also restarts the blend).
  fw::RobotPose add(const fw::RobotPose& localisation);

 private:
  double time_constant_s_;
  double jump_xy_m_;
  double jump_theta_rad_;
  std::optional<fw::RobotPose> last_;  // the last blended pose, with the odometry it was blended at
};

}  // namespace fusion
