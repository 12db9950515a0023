#include <gtest/gtest.h>

#include <cmath>

#include "framework_api/sensor_pose.h"

namespace {

using fw::SensorPose;

TEST(SensorPose, LevelSensorLooksAlongRobotY) {
  const Eigen::Isometry3d T_R_S = fw::SensorPose{0.1, 0.2, 0.7, 0, 0, 0}.T_R_S();
  // A point 3 m ahead on the optical axis, 0.5 m right and 0.4 m below it in the image.
  const Eigen::Vector3d p_R = T_R_S * Eigen::Vector3d(0.5, 0.4, 3.0);
  EXPECT_TRUE(p_R.isApprox(Eigen::Vector3d(0.6, 3.2, 0.3), 1e-12)) << p_R.transpose();
}

TEST(SensorPose, AnglesFollowTheDocumentedConventions) {
  const double a = 10.0 * M_PI / 180.0;
  const Eigen::Vector3d forward_S(0, 0, 1);
  // Pitch down: the optical axis points below the horizon.
  EXPECT_NEAR((fw::SensorPose{0, 0, 0.7, 0, a, 0}.T_R_S().linear() * forward_S).z(), -std::sin(a), 1e-12);
  // Yaw left: the optical axis turns towards -x.
  EXPECT_NEAR((fw::SensorPose{0, 0, 0.7, a, 0, 0}.T_R_S().linear() * forward_S).x(), -std::sin(a), 1e-12);
  // Roll: right-handed about the optical axis turns the image x axis towards image y (down).
  const Eigen::Vector3d right_R = fw::SensorPose{0, 0, 0.7, 0, 0, a}.T_R_S().linear() * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(right_R.z(), -std::sin(a), 1e-12);
}

TEST(SensorPose, RoundTripsThroughTheTransform) {
  const fw::SensorPose pose{0.12, -0.05, 0.71, 0.3, 0.2, -0.1};
  const fw::SensorPose back = fw::SensorPose::fromTransform(pose.T_R_S());
  EXPECT_NEAR(back.x_m, pose.x_m, 1e-12);
  EXPECT_NEAR(back.z_m, pose.z_m, 1e-12);
  EXPECT_NEAR(back.yaw_rad, pose.yaw_rad, 1e-12);
  EXPECT_NEAR(back.pitch_rad, pose.pitch_rad, 1e-12);
  EXPECT_NEAR(back.roll_rad, pose.roll_rad, 1e-12);
}

}  // namespace
