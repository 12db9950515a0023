#include "fusion/pose_blend.h"

#include <cmath>

namespace fusion {

PoseBlend::PoseBlend(double time_constant_s, double sigma_xy_m, double sigma_theta_rad)
    : time_constant_s_(time_constant_s),
      jump_xy_m_(kJumpSigmas * sigma_xy_m),
      jump_theta_rad_(kJumpSigmas * sigma_theta_rad) {}

fw::RobotPose PoseBlend::add(const fw::RobotPose& localisation) {
  const double t_s = localisation.stamp.source_time_s;
  if (!localisation.odometry || time_constant_s_ <= 0.0) {
    last_.reset();
    return localisation;
  }
  if (last_ && t_s <= last_->stamp.source_time_s) return localisation;
  if (!last_ || t_s - last_->stamp.source_time_s > kMaxGap_s) {
    last_ = localisation;
    return localisation;
  }
  // How the wheels moved since the last pose, in the robot frame of then, applied to the last blend.
  const fw::RobotPose::Odometry& from = *last_->odometry;
  const fw::RobotPose::Odometry& to = *localisation.odometry;
  const Eigen::Vector2d moved_R =
      Eigen::Rotation2Dd(-from.theta_rad) * Eigen::Vector2d(to.x_m - from.x_m, to.y_m - from.y_m);
  const Eigen::Vector2d predicted_F =
      Eigen::Vector2d(last_->x_m, last_->y_m) + Eigen::Rotation2Dd(last_->theta_rad) * moved_R;
  const double predicted_theta_rad = last_->theta_rad + std::remainder(to.theta_rad - from.theta_rad, 2.0 * M_PI);

  const Eigen::Vector2d off_F = Eigen::Vector2d(localisation.x_m, localisation.y_m) - predicted_F;
  const double off_theta_rad = std::remainder(localisation.theta_rad - predicted_theta_rad, 2.0 * M_PI);
  fw::RobotPose blended = localisation;
  if (off_F.norm() <= jump_xy_m_ && std::abs(off_theta_rad) <= jump_theta_rad_) {
    const double gain = 1.0 - std::exp(-(t_s - last_->stamp.source_time_s) / time_constant_s_);
    const Eigen::Vector2d p_F = predicted_F + gain * off_F;
    blended.x_m = p_F.x();
    blended.y_m = p_F.y();
    // Near the localisation's own angle, so that a consumer comparing the two needs no wrapping.
    blended.theta_rad = localisation.theta_rad - (1.0 - gain) * off_theta_rad;
  }
  last_ = blended;
  return blended;
}

}  // namespace fusion
