#include "fusion/measurements.h"

#include <algorithm>
#include <cmath>

namespace fusion {

namespace {
// Centres closer than this below the viewpoint are out of the camera's view; the model is held
// there so that a hypothesis that high predicts a phantom far away instead of dividing by zero.
constexpr double kMinDepthBelowViewpoint_m = 0.1;
// Over the first this many metres above rest the omni's distance turns from a measurement into a
// hint with an error of this share of the phantom's distance.
constexpr double kAirborneRamp_m = 0.1;
constexpr double kPhantomDistanceFraction = 0.2;
}  // namespace

PositionMeasurement::PositionMeasurement(const Eigen::Vector3d& p_R, const Eigen::Matrix3d& covariance_R,
                                         const fw::RobotPose& pose, const PoseConfig& pose_config,
                                         double timing_sigma_s)
    : MeasurementModel(timing_sigma_s) {
  const Eigen::Isometry3d T_F_R = pose.T_F_R();
  const Eigen::Matrix3d R_F_R = T_F_R.linear();
  const Eigen::Vector3d p_F = T_F_R * p_R;
  z_ = p_F;
  Eigen::Matrix3d R = R_F_R * covariance_R * R_F_R.transpose();
  R(0, 0) += pose_config.sigma_xy_m * pose_config.sigma_xy_m;
  R(1, 1) += pose_config.sigma_xy_m * pose_config.sigma_xy_m;
  // A heading error turns the point about the robot: d p / d theta.
  const Eigen::Vector3d d_dtheta(-(p_F.y() - pose.y_m), p_F.x() - pose.x_m, 0.0);
  R += pose_config.sigma_theta_rad * pose_config.sigma_theta_rad * d_dtheta * d_dtheta.transpose();
  R_ = R;
}

OmniMeasurement::OmniMeasurement(const fw::OmniBallObservation& observation, const fw::RobotPose& pose,
                                 const fw::RobotPose& pose_after, const OmniConfig& omni, const PoseConfig& pose_config,
                                 double ball_radius_m, double timing_sigma_s)
    : MeasurementModel(timing_sigma_s),
      pose_(pose),
      pose_after_(pose_after),
      omni_(omni),
      pose_config_(pose_config),
      radius_m_(ball_radius_m),
      observation_(observation),
      z_(2) {
  z_ << observation.bearing_rad, observation.distance_m;
}

MeasurementVector OmniMeasurement::predict(const Eigen::Vector3d& p_F) const { return predictFrom(pose_, p_F); }

MeasurementVector OmniMeasurement::ownMotionRate(const Eigen::Vector3d& p_F) const {
  return residual(predictFrom(pose_after_, p_F), predictFrom(pose_, p_F)) / kPoseRateStep_s;
}

bool OmniMeasurement::canSee(const Eigen::Vector3d& p_F) const { return omniCanSee(p_F, omni_); }

MeasurementVector OmniMeasurement::predictFrom(const fw::RobotPose& pose, const Eigen::Vector3d& p_F) const {
  return omniView_R(pose.T_F_R().inverse() * p_F, omni_, radius_m_);
}

MeasurementMatrix OmniMeasurement::noise(const Eigen::Vector3d& p_F) const {
  // For a ball in the air the phantom's distance hangs on the height so steeply (46 m per m for a
  // ball half a metre up, 4.5 m away) that a linearised update would throw the ball about: there
  // the omni gives its bearing and a looser hold on the ray.
  const double airborne = std::clamp((p_F.z() - radius_m_) / kAirborneRamp_m, 0.0, 1.0);
  return noiseWith(p_F, airborne * kPhantomDistanceFraction * predict(p_F)[1]);
}

MeasurementMatrix OmniMeasurement::sensorNoise(const Eigen::Vector3d& p_F) const { return noiseWith(p_F, 0.0); }

MeasurementMatrix OmniMeasurement::noiseWith(const Eigen::Vector3d& p_F, double phantom_hold_sigma_m) const {
  const double sigma_d = std::hypot(omniDistanceSigma_m(observation_, omni_, predict(p_F)[1]), phantom_hold_sigma_m);
  MeasurementMatrix R = MeasurementMatrix::Zero(2, 2);
  const double sigma_b = omniBearingSigma_rad(observation_, omni_);
  R(0, 0) = sigma_b * sigma_b + pose_config_.sigma_theta_rad * pose_config_.sigma_theta_rad;
  R(1, 1) = sigma_d * sigma_d + pose_config_.sigma_xy_m * pose_config_.sigma_xy_m;
  return R;
}

MeasurementVector OmniMeasurement::residual(const MeasurementVector& z, const MeasurementVector& h) const {
  MeasurementVector r = z - h;
  r[0] = fw::wrapAngle(r[0]);
  return r;
}

Eigen::Vector3d OmniMeasurement::groundBall_F() const {
  fw::OmniBallObservation ground;
  ground.bearing_rad = z_[0];
  ground.distance_m = z_[1];
  Eigen::Vector3d p_F = pose_.T_F_R() * ground.groundPoint_R();
  p_F.z() = radius_m_;
  return p_F;
}

Eigen::Vector2d omniView_R(const Eigen::Vector3d& p_R, const OmniConfig& omni, double radius_m) {
  const double h = omni.viewpoint_height_m;
  const double below = std::max(h - p_R.z(), kMinDepthBelowViewpoint_m);
  return {std::atan2(-p_R.x(), p_R.y()), p_R.head<2>().norm() * (h - radius_m) / below};
}

Eigen::Matrix<double, 2, 3> omniViewJacobian_R(const Eigen::Vector3d& p_R, const OmniConfig& omni, double radius_m) {
  const double h = omni.viewpoint_height_m;
  const double below = h - p_R.z();
  const bool held = below < kMinDepthBelowViewpoint_m;  // the model is held there: no slope in z
  const double k = (h - radius_m) / std::max(below, kMinDepthBelowViewpoint_m);
  const double rho2 = std::max(p_R.head<2>().squaredNorm(), 1e-12), rho = std::sqrt(rho2);
  Eigen::Matrix<double, 2, 3> J;
  J << -p_R.y() / rho2, p_R.x() / rho2, 0.0,  //
      k * p_R.x() / rho, k * p_R.y() / rho, held ? 0.0 : rho * k / below;
  return J;
}

bool omniCanSee(const Eigen::Vector3d& p_F, const OmniConfig& omni) { return p_F.z() <= omni.max_height_m; }

double omniVisibleProbability(const Hypothesis& h, const OmniConfig& omni) {
  const double sigma_z = std::sqrt(std::max(h.P(2, 2), 1e-12));
  return 0.5 * std::erfc((h.x.z() - omni.max_height_m) / (sigma_z * std::sqrt(2.0)));
}

fw::SeenRobot seenRobot_F(const fw::OmniRobotObservation& robot, const fw::RobotPose& pose, const OmniConfig& omni,
                          double time_s) {
  const Eigen::Vector3d p_F = pose.fieldFromRobot(robot.groundPoint_R());
  const Eigen::Vector2d from(pose.x_m, pose.y_m);
  const double d = robot.distance_m;
  const Eigen::Vector2d along = d > 1e-6 ? Eigen::Vector2d((p_F.head<2>() - from) / d) : Eigen::Vector2d::UnitY();
  const Eigen::Vector2d across(-along.y(), along.x());
  const double sigma_along = omniDistanceSigma_m(robot, omni, d), sigma_across = d * omniBearingSigma_rad(robot, omni);
  const Eigen::Matrix2d covariance =
      sigma_along * sigma_along * along * along.transpose() + sigma_across * sigma_across * across * across.transpose();
  return {p_F.head<2>(), covariance, time_s};
}

fw::BallObservation kinectBall_F(const fw::BallObservation& ball_R, const fw::RobotPose& pose) {
  const Eigen::Matrix3d rotation = pose.T_F_R().linear();
  fw::BallObservation ball = ball_R;
  ball.position_m = pose.fieldFromRobot(ball_R.position_m);
  ball.covariance_m2 = rotation * ball_R.covariance_m2 * rotation.transpose();
  ball.frame = fw::Frame::kField;
  return ball;
}

fw::BallRay omniRay_F(const fw::OmniBallObservation& ball, const fw::RobotPose& pose, const OmniConfig& omni,
                      double radius_m, double time_s) {
  const double h = omni.viewpoint_height_m;
  Eigen::Vector3d centre_R = ball.groundPoint_R();
  centre_R.z() = radius_m;
  fw::BallRay ray;
  ray.origin_F = pose.fieldFromRobot({0.0, 0.0, h});
  ray.direction_F = (pose.fieldFromRobot(centre_R) - ray.origin_F).normalized();
  ray.bearing_sigma_rad = omniBearingSigma_rad(ball, omni);
  // A distance error along the floor turns the ray up or down by this much.
  const double d = ball.distance_m, drop = h - radius_m;
  ray.elevation_sigma_rad = omniDistanceSigma_m(ball, omni, d) * drop / (d * d + drop * drop);
  ray.view_top_m = omni.max_height_m;
  ray.time_s = time_s;
  return ray;
}

double omniSecantRate(const std::function<double(double)>& change_over, double residual, double tangent,
                      double max_offset_s) {
  // residual = -(view(t) - view(t - tau)): the reading shows the ball tau seconds earlier. The
  // search runs from the reading's time towards the side the tangent puts the offset on (beyond the
  // other side a rising phantom may pass the viewpoint, where the view turns back).
  const auto miss = [&](double tau_s) { return change_over(tau_s) + residual; };
  double low = 0.0, high = -residual / tangent > 0.0 ? max_offset_s : -max_offset_s;
  double miss_low = residual;
  if ((miss_low > 0.0) == (miss(high) > 0.0)) return tangent;
  for (int step = 0; step < 40; ++step) {
    const double middle = 0.5 * (low + high), miss_middle = miss(middle);
    if ((miss_middle > 0.0) == (miss_low > 0.0)) {
      low = middle;
      miss_low = miss_middle;
    } else {
      high = middle;
    }
  }
  const double tau_s = 0.5 * (low + high);
  constexpr double kShortestOffset_s = 0.002;  // below, the two rates agree and the division is noise
  if (std::abs(tau_s) < kShortestOffset_s) return tangent;
  const double secant = change_over(tau_s) / tau_s;
  // A secant of the other sign than the tangent is no rate of this reading's (a view that turned).
  return secant * tangent > 0.0 ? secant : tangent;
}

bool omniOffsetIsAmbiguous(const std::function<double(double)>& change_over, double residual, double tangent,
                           double window_s) {
  const double other_side = -residual / tangent > 0.0 ? -1.0 : 1.0;
  constexpr int kSamples = 16;  // a view that turns back and forth within a window this short is noise
  for (int k = 1; k <= kSamples; ++k) {
    const double miss = change_over(other_side * window_s * k / kSamples) + residual;
    if (std::isfinite(miss) && (miss > 0.0) != (residual > 0.0)) return true;
  }
  return false;
}

}  // namespace fusion
