// The pose the fusion maps its sensors with. Self-localisation knows where the robot stands to a few
// centimetres, but its pose jitters from frame to frame; over the third of a second the Kinect sees a
// flight, that jitter reads as 0.1-0.3 m/s of ball velocity (docs/fusion.md, "Accuracy"). The wheels'
// odometry drifts over a match but moves smoothly. Blended, the pose moves as the odometry says and is
// pulled towards the localisation's over a time constant: a complementary filter on the plane. Wheels
// that turn (or travel) a few per cent too far or too short would carry it off a steady turn by that
// share of the turn over the time constant (3 % of 3 rad/s: 5 degrees), so the wheels' scale is learnt
// from the localisation and taken out of each step.
#pragma once

#include <cmath>
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
  // The wheels' scale is learnt over about their last two turns and 20 m, once they have turned half a
  // turn and travelled 5 m: the localisation's own error (a degree, a few centimetres) is then a
  // fraction of a per cent of it. Wheels off by more than a fifth are not followed further.
  static constexpr double kTurnMemory_rad = 4.0 * M_PI, kTurnEnough_rad = M_PI;
  static constexpr double kTravelMemory_m = 20.0, kTravelEnough_m = 5.0;
  static constexpr double kMaxScaleError = 0.2;

  // The blended pose at the localisation's pose's time. A pose without odometry, or older than the
  // last, is returned as it is (the first also restarts the blend).
  fw::RobotPose add(const fw::RobotPose& localisation);

 private:
  // How far the localisation moved for each radian (or metre) the wheels said, over the wheels' recent
  // motion (each step weighed out as more motion follows it).
  class WheelScale {
   public:
    WheelScale(double memory, double enough) : memory_(memory), enough_(enough) {}
    // seen: the localisation's step along the wheels' (signed as theirs); said: the wheels' step.
    void add(double seen, double said);
    double scale() const;

   private:
    double memory_, enough_;
    double seen_ = 0.0, said_ = 0.0;
  };

  double time_constant_s_;
  double jump_xy_m_;
  double jump_theta_rad_;
  std::optional<fw::RobotPose> last_;               // the last blended pose, with the odometry it was blended at
  std::optional<fw::RobotPose> last_localisation_;  // and the localisation's pose then
  WheelScale turn_{kTurnMemory_rad, kTurnEnough_rad}, travel_{kTravelMemory_m, kTravelEnough_m};
};

}  // namespace fusion
