#include "kinect3d/config_io.h"

#include <cmath>

namespace kinect3d {

namespace {
double radians(double degrees) { return degrees * M_PI / 180.0; }
}  // namespace

SensorPose readSensorPose(const fw::ConfigView& pose) {
  pose.requireOnlyKeys({"x", "y", "z", "yaw_deg", "pitch_deg", "roll_deg"});
  SensorPose result;
  result.x_m = pose.getDouble("x", -5.0, 5.0);
  result.y_m = pose.getDouble("y", -5.0, 5.0);
  result.z_m = pose.getDouble("z", 0.05, 5.0);
  result.yaw_rad = radians(pose.getDouble("yaw_deg", -180.0, 180.0));
  result.pitch_rad = radians(pose.getDouble("pitch_deg", -89.0, 89.0));
  result.roll_rad = radians(pose.getDouble("roll_deg", -180.0, 180.0));
  return result;
}

Intrinsics readIntrinsics(const fw::ConfigView& intrinsics) {
  Intrinsics result;
  result.width = intrinsics.getInt("width", 8, 4096);
  result.height = intrinsics.getInt("height", 8, 4096);
  result.fx = intrinsics.getDouble("fx", 10.0, 1e5);
  result.fy = intrinsics.getDouble("fy", 10.0, 1e5);
  result.cx = intrinsics.getDouble("cx", 0.0, result.width);
  result.cy = intrinsics.getDouble("cy", 0.0, result.height);
  return result;
}

}  // namespace kinect3d
