// Reading kinect3d's plain structs from configuration views. The YAML itself is parsed by
// framework_api; the algorithms never see configuration, only the structs made here.
#pragma once

#include <cmath>
#include <string>

#include "framework_api/config.h"
#include "framework_api/sensor_pose.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/depth_frame.h"
#include "kinect3d/sensor_calibration.h"
#include "kinect3d/trajectory.h"

namespace kinect3d {

// Configuration writes angles in degrees; code works in radians.
using fw::degreesToRadians;

// The fixed interface {x, y, z (metres), yaw_deg, pitch_deg, roll_deg}; every key is required.
fw::SensorPose readSensorPose(const fw::ConfigView& pose);
// {width, height, fx, fy, cx, cy}; every key is required. The caller checks for unknown keys,
// since files such as a TUM camera.yaml keep other keys beside these.
Intrinsics readIntrinsics(const fw::ConfigView& intrinsics, const std::string& key_prefix = "");

// The detector's settings from the kinect3d block of a robot configuration.
DetectorConfig readDetectorConfig(const fw::ConfigView& kinect3d);
// kinect3d.colour_check; a check that is on needs kinect3d.colour and learnt ball colours.
ColourCheckConfig readColourCheckConfig(const fw::ConfigView& kinect3d);
// The trajectory estimator's, from the same block (kinect3d.trajectory and kinect3d.ball).
TrajectoryConfig readTrajectoryConfig(const fw::ConfigView& kinect3d);
// The running calibration check's, from kinect3d.calibration_check.
FloorCalibrationCheck::Config readCalibrationCheckConfig(const fw::ConfigView& kinect3d);
GravityCalibrationCheck::Config readGravityCheckConfig(const fw::ConfigView& kinect3d);

}  // namespace kinect3d
