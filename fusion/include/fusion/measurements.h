// The measurement models the fusion uses, in the field frame: what each sensor would report for a
// ball centre p_F, given where the robot stood when the sensor looked.
#pragma once

#include <functional>

#include "framework_api/team_message.h"
#include "framework_api/types.h"
#include "fusion/ball_filter.h"

namespace fusion {

// The Kinect's 3D ball: the centre itself. Its covariance (mostly along the viewing ray) is turned
// into the field frame, plus what the pose's own error does to a point that far from the robot.
class PositionMeasurement : public MeasurementModel {
 public:
  // timing_sigma_s: how far the measurement's time may be off (a teammate's clock offset's bound).
  PositionMeasurement(const Eigen::Vector3d& p_R, const Eigen::Matrix3d& covariance_R, const fw::RobotPose& pose,
                      const PoseConfig& pose_config, double timing_sigma_s = 0.0);

  MeasurementVector predict(const Eigen::Vector3d& p_F) const override { return p_F; }
  const MeasurementVector& value() const override { return z_; }
  MeasurementMatrix noise(const Eigen::Vector3d&) const override { return R_; }

 private:
  MeasurementVector z_;
  MeasurementMatrix R_;
};

// The omni camera's ball: a bearing and a distance on the floor. The camera's ray from its viewpoint
// (height h above the robot centre) through a centre at height z meets the plane of resting centres
// (height r) at d (h - r) / (h - z) for a horizontal distance d. On the floor that is d itself; a
// ball in the air appears farther out along the same bearing, and the model says by how much, so
// the phantom constrains the ray instead of pulling the ball to the wrong place.
class OmniMeasurement : public MeasurementModel {
 public:
  // pose: where the robot stood when the camera looked; pose_after: kPoseRateStep_s later.
  OmniMeasurement(const fw::OmniBallObservation& observation, const fw::RobotPose& pose,
                  const fw::RobotPose& pose_after, const OmniConfig& omni, const PoseConfig& pose_config,
                  double ball_radius_m, double timing_sigma_s);
  static constexpr double kPoseRateStep_s = 0.02;

  MeasurementVector predict(const Eigen::Vector3d& p_F) const override;
  const MeasurementVector& value() const override { return z_; }
  MeasurementMatrix noise(const Eigen::Vector3d& p_F) const override;
  MeasurementMatrix sensorNoise(const Eigen::Vector3d& p_F) const override;
  MeasurementVector residual(const MeasurementVector& z, const MeasurementVector& h) const override;
  MeasurementVector ownMotionRate(const Eigen::Vector3d& p_F) const override;
  bool canSee(const Eigen::Vector3d& p_F) const override;

  // Where a ball on the floor would be for this observation, in the field frame (z = radius).
  Eigen::Vector3d groundBall_F() const;

 private:
  MeasurementVector predictFrom(const fw::RobotPose& pose, const Eigen::Vector3d& p_F) const;
  // The bearing's and distance's noise at p_F, the distance's widened by phantom_hold_sigma_m.
  MeasurementMatrix noiseWith(const Eigen::Vector3d& p_F, double phantom_hold_sigma_m) const;

  fw::RobotPose pose_, pose_after_;
  OmniConfig omni_;
  PoseConfig pose_config_;
  double radius_m_;
  fw::OmniBallObservation observation_;
  MeasurementVector z_;
};

// What the omni camera reports for a ball centre p_R in the robot frame: its bearing (from +y,
// counter-clockwise) and its distance on the floor, farther out for a ball in the air (the ray from
// the viewpoint through the centre meets the plane of resting centres); and their derivatives by p_R.
Eigen::Vector2d omniView_R(const Eigen::Vector3d& p_R, const OmniConfig& omni, double radius_m);
Eigen::Matrix<double, 2, 3> omniViewJacobian_R(const Eigen::Vector3d& p_R, const OmniConfig& omni, double radius_m);

// The rate to read an omni reading's time offset by: how fast its view changed over that offset (the
// secant), not at its end (the tangent). change_over(tau) is what the view gained over the tau seconds
// before the reading's time; the offset is where it equals -residual. A phantom's distance grows
// ever faster as the ball rises towards the mirror's viewpoint, so the tangent at the reading, the
// steepest point, read a rising lob's 20-60 ms offset as 0.6-0.85 of it. Where no offset within
// max_offset_s explains the residual (its noise), or the offset is too short to tell, the tangent.
double omniSecantRate(const std::function<double(double)>& change_over, double residual, double tangent,
                      double max_offset_s);
// Whether an offset on the other side of the reading's time than the tangent puts it, within window_s,
// explains the residual as well: the view turned back (a ball passing closest to the camera's axis,
// its distance at a minimum), so the reading cannot say which way its time is off. change_over as
// above, for negative tau too; NaN where the camera could not have seen the ball.
bool omniOffsetIsAmbiguous(const std::function<double(double)>& change_over, double residual, double tangent,
                           double window_s);

// Whether the omni camera can see a ball centre at p_F: below the top of its mirror's view.
bool omniCanSee(const Eigen::Vector3d& p_F, const OmniConfig& omni);
// The chance that the ball of hypothesis h is below the top of the omni camera's view.
double omniVisibleProbability(const Hypothesis& h, const OmniConfig& omni);

// The omni camera's noise for a ground ball distance_m away: the observation's own sigmas where it
// carries them, else the configured model (the distance's growing with the distance).
// (A robot the camera sees is measured alike.)
template <typename OmniObservation>
double omniBearingSigma_rad(const OmniObservation& observation, const OmniConfig& omni) {
  return observation.bearing_sigma_rad > 0.0 ? observation.bearing_sigma_rad : omni.bearing_sigma_rad;
}
template <typename OmniObservation>
double omniDistanceSigma_m(const OmniObservation& observation, const OmniConfig& omni, double distance_m) {
  return observation.distance_sigma_m > 0.0 ? observation.distance_sigma_m
                                            : omni.distance_sigma_m + omni.distance_sigma_fraction * distance_m;
}

// A robot the omni camera saw, placed in the field frame from pose (the robot's own at the image's
// time), its covariance from the camera's noise alone, at time_s.
fw::SeenRobot seenRobot_F(const fw::OmniRobotObservation& robot, const fw::RobotPose& pose, const OmniConfig& omni,
                          double time_s);

// This robot's Kinect ball placed in the field frame, as a teammate is told it: its position and
// covariance moved by pose (the robot's own when the Kinect saw it), without the pose's own error.
fw::BallObservation kinectBall_F(const fw::BallObservation& ball_R, const fw::RobotPose& pose);

// The omni camera's ray through a ball it reported, as a teammate is told it: from the camera's
// viewpoint (pose: the robot's own at the image's time) to where the ball's centre is if it rests on
// the floor (a ball of radius_m), with the camera's noise as angles, at time_s.
fw::BallRay omniRay_F(const fw::OmniBallObservation& ball, const fw::RobotPose& pose, const OmniConfig& omni,
                      double radius_m, double time_s);

}  // namespace fusion
