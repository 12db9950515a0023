// Where the depth sensor sits on the robot, and the transform it implies.
#pragma once

#include <string>

#include <Eigen/Geometry>

namespace fw {

// The pose of the sensor's optical frame in the robot frame, in the form teams write in
// kinect3d.sensor.pose_in_robot (angles in radians here, degrees in YAML).
//  - yaw: 0 looks along the robot's +y; positive turns left (about +z).
//  - pitch: positive tilts the optical axis down towards the floor.
//  - roll: right-handed about the optical axis.
struct SensorPose {
  double x_m = 0.0;
  double y_m = 0.0;
  double z_m = 0.7;
  double yaw_rad = 0.0;
  double pitch_rad = 0.0;
  double roll_rad = 0.0;

  // T_R_S maps a point in the sensor optical frame (x right, y down, z forward) to the robot
  // frame (x right, y forward, z up).
  Eigen::Isometry3d T_R_S() const;
  // The inverse of T_R_S, recovering yaw, pitch and roll; the sensor must not look straight up or
  // down (|pitch| < 90 deg).
  static SensorPose fromTransform(const Eigen::Isometry3d& T_R_S);
};

// "{x: .., y: .., z: .., yaw_deg: .., pitch_deg: .., roll_deg: ..}": pose_in_robot's value as a
// robot file, a message or a page shows it (0.1 mm, 0.001 deg).
std::string poseInRobotYaml(const SensorPose& pose);

}  // namespace fw
