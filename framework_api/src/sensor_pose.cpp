#include "framework_api/sensor_pose.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace fw {

namespace {
// The optical frame's axes in the robot frame when yaw = pitch = roll = 0: optical x (right) is
// robot +x, optical y (down) is robot -z, optical z (forward) is robot +y.
Eigen::Matrix3d levelSensorToRobot() {
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  return R;
}

Eigen::Matrix3d yawPitch(double yaw_rad, double pitch_rad) {
  // Pitch down is a negative rotation about the robot's x axis (it turns +y towards -z).
  return (Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(-pitch_rad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}
}  // namespace

Eigen::Isometry3d SensorPose::T_R_S() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = yawPitch(yaw_rad, pitch_rad) * levelSensorToRobot() *
               Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x_m, y_m, z_m);
  return T;
}

SensorPose SensorPose::fromTransform(const Eigen::Isometry3d& T_R_S) {
  SensorPose pose;
  pose.x_m = T_R_S.translation().x();
  pose.y_m = T_R_S.translation().y();
  pose.z_m = T_R_S.translation().z();
  const Eigen::Vector3d axis_R = T_R_S.linear().col(2);  // optical axis in the robot frame
  pose.pitch_rad = std::asin(std::clamp(-axis_R.z(), -1.0, 1.0));
  pose.yaw_rad = std::atan2(-axis_R.x(), axis_R.y());
  const Eigen::Matrix3d roll =
      (yawPitch(pose.yaw_rad, pose.pitch_rad) * levelSensorToRobot()).transpose() * T_R_S.linear();
  pose.roll_rad = std::atan2(roll(1, 0), roll(0, 0));
  return pose;
}

std::string poseInRobotYaml(const SensorPose& pose) {
  const double deg = 180.0 / M_PI;
  char text[160];
  std::snprintf(text, sizeof text, "{x: %.4f, y: %.4f, z: %.4f, yaw_deg: %.3f, pitch_deg: %.3f, roll_deg: %.3f}",
                pose.x_m, pose.y_m, pose.z_m, pose.yaw_rad * deg, pose.pitch_rad * deg, pose.roll_rad * deg);
  return text;
}

}  // namespace fw
