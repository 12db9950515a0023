#include "fusion/pose_blend.h"

#include <algorithm>
#include <cmath>

namespace fusion {

void PoseBlend::WheelScale::add(double seen, double said) {
  const double keep = std::exp(-std::abs(said) / memory_);
  seen_ = keep * seen_ + (said < 0.0 ? -seen : seen);
  said_ = keep * said_ + std::abs(said);
}

double PoseBlend::WheelScale::scale() const {
  if (said_ < enough_) return 1.0;
  return std::clamp(seen_ / said_, 1.0 - kMaxScaleError, 1.0 + kMaxScaleError);
}

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
    last_ = last_localisation_ = localisation;
    return localisation;
  }
  // How the wheels moved since the last pose, in the robot frame of then, their learnt scale taken
  // out, applied to the last blend.
  const fw::RobotPose::Odometry& from = *last_->odometry;
  const fw::RobotPose::Odometry& to = *localisation.odometry;
  const Eigen::Vector2d moved_R =
      Eigen::Rotation2Dd(-from.theta_rad) * Eigen::Vector2d(to.x_m - from.x_m, to.y_m - from.y_m);
  const double turned_rad = std::remainder(to.theta_rad - from.theta_rad, 2.0 * M_PI);
  const Eigen::Vector2d moved_F = Eigen::Rotation2Dd(last_->theta_rad) * moved_R;
  const Eigen::Vector2d predicted_F = Eigen::Vector2d(last_->x_m, last_->y_m) + travel_.scale() * moved_F;
  const double predicted_theta_rad = last_->theta_rad + turn_.scale() * turned_rad;

  const Eigen::Vector2d off_F = Eigen::Vector2d(localisation.x_m, localisation.y_m) - predicted_F;
  const double off_theta_rad = std::remainder(localisation.theta_rad - predicted_theta_rad, 2.0 * M_PI);
  fw::RobotPose blended = localisation;
  if (off_F.norm() <= jump_xy_m_ && std::abs(off_theta_rad) <= jump_theta_rad_) {
    // The localisation's step beside the wheels' teaches their scale (not across a jump: a
    // relocalisation, or wheels that restarted their count).
    const Eigen::Vector2d stepped_F(localisation.x_m - last_localisation_->x_m,
                                    localisation.y_m - last_localisation_->y_m);
    const double moved_m = moved_F.norm();
    if (moved_m > 0.0) travel_.add(stepped_F.dot(moved_F) / moved_m, moved_m);
    turn_.add(std::remainder(localisation.theta_rad - last_localisation_->theta_rad, 2.0 * M_PI), turned_rad);

    const double gain = 1.0 - std::exp(-(t_s - last_->stamp.source_time_s) / time_constant_s_);
    const Eigen::Vector2d p_F = predicted_F + gain * off_F;
    blended.x_m = p_F.x();
    blended.y_m = p_F.y();
    // Near the localisation's own angle, so that a consumer comparing the two needs no wrapping.
    blended.theta_rad = localisation.theta_rad - (1.0 - gain) * off_theta_rad;
  }
  last_ = blended;
  last_localisation_ = localisation;
  return blended;
}

}  // namespace fusion
