#include "kinect3d/config_io.h"

#include <cmath>

namespace kinect3d {

fw::SensorPose readSensorPose(const fw::ConfigView& pose) {
  pose.requireOnlyKeys({"x", "y", "z", "yaw_deg", "pitch_deg", "roll_deg"});
  fw::SensorPose result;
  result.x_m = pose.getDouble("x", -5.0, 5.0);
  result.y_m = pose.getDouble("y", -5.0, 5.0);
  result.z_m = pose.getDouble("z", 0.05, 5.0);
  result.yaw_rad = degreesToRadians(pose.getDouble("yaw_deg", -180.0, 180.0));
  result.pitch_rad = degreesToRadians(pose.getDouble("pitch_deg", -89.0, 89.0));
  result.roll_rad = degreesToRadians(pose.getDouble("roll_deg", -180.0, 180.0));
  return result;
}

Intrinsics readIntrinsics(const fw::ConfigView& intrinsics, const std::string& key_prefix) {
  const auto key = [&](const char* name) { return key_prefix + name; };
  Intrinsics result;
  result.width = intrinsics.getInt(key("width"), Intrinsics::kMinSide_px, Intrinsics::kMaxSide_px);
  result.height = intrinsics.getInt(key("height"), Intrinsics::kMinSide_px, Intrinsics::kMaxSide_px);
  result.fx = intrinsics.getDouble(key("fx"), 10.0, 1e5);
  result.fy = intrinsics.getDouble(key("fy"), 10.0, 1e5);
  result.cx = intrinsics.getDouble(key("cx"), 0.0, result.width);
  result.cy = intrinsics.getDouble(key("cy"), 0.0, result.height);
  return result;
}

namespace {
// A lower and an upper bound read from one block: the upper must exceed the lower, and the error
// names both where they were written.
void requireIncreasing(const fw::ConfigView& block, const std::string& lower_key, double lower,
                       const std::string& upper_key, double upper) {
  if (upper > lower) return;
  throw fw::ConfigError(block.originOf(upper_key) + ": " + block.path() + "." + upper_key + " = " +
                        std::to_string(upper) + " must exceed " + block.path() + "." + lower_key + " = " +
                        std::to_string(lower) + " (" + block.originOf(lower_key) + ")");
}
}  // namespace

DetectorConfig readDetectorConfig(const fw::ConfigView& kinect3d) {
  DetectorConfig config;
  const fw::ConfigView sensor = kinect3d.child("sensor");
  if (sensor.has("pose_in_robot")) config.ground.pose = readSensorPose(sensor.child("pose_in_robot"));
  config.points.baseline_m = sensor.getDouble("baseline_m", 0.01, 0.5);

  const fw::ConfigView ground = kinect3d.child("ground");
  config.ground.max_tilt_rad = degreesToRadians(ground.getDouble("max_tilt_deg", 1.0, 89.0));
  config.ground.distance_threshold_m = ground.getDouble("distance_threshold_m", 0.005, 0.5);
  config.ground.max_fit_range_m = ground.getDouble("max_fit_range_m", 1.0, 20.0);
  config.ground.refit_interval_frames = ground.getInt("refit_interval_frames", 1, 100000);
  config.ground.min_inlier_fraction = ground.getDouble("min_inlier_fraction", 0.01, 1.0);
  config.ground.min_height_m = ground.getDouble("min_height_m", 0.0, 10.0);
  config.ground.max_height_m = ground.getDouble("max_height_m", 0.0, 10.0);
  requireIncreasing(ground, "min_height_m", config.ground.min_height_m, "max_height_m", config.ground.max_height_m);

  const fw::ConfigView points = kinect3d.child("points");
  config.points.pixel_stride = points.getInt("pixel_stride", 1, 8);
  config.points.edge_tolerance_steps = points.getDouble("edge_tolerance_steps", 0.5, 100.0);
  config.points.min_range_m = points.getDouble("min_range_m", 0.1, 20.0);
  config.points.max_range_m = points.getDouble("max_range_m", 0.1, 20.0);
  requireIncreasing(points, "min_range_m", config.points.min_range_m, "max_range_m", config.points.max_range_m);
  config.points.floor_margin_m = points.getDouble("floor_margin_m", 0.0, 0.5);

  const fw::ConfigView grid = kinect3d.child("grid");
  config.grid.voxel_m = grid.getDouble("voxel_m", 0.02, 1.0);
  config.mask.core_voxels = grid.getInt("core_voxels", 1, 15);
  config.mask.mask_voxels = grid.getInt("mask_voxels", 3, 31);
  const int shell_both_sides = config.mask.mask_voxels - config.mask.core_voxels;
  if (shell_both_sides < 2 || shell_both_sides % 2 != 0) {
    // Either value may be the wrong one: name both where they were written.
    throw fw::ConfigError(grid.originOf("mask_voxels") +
                          ": kinect3d.grid.mask_voxels = " + std::to_string(config.mask.mask_voxels) +
                          " and kinect3d.grid.core_voxels = " + std::to_string(config.mask.core_voxels) + " (" +
                          grid.originOf("core_voxels") +
                          "): the mask must exceed the core by a positive even number (an equal shell on each side)");
  }
  config.grid.occupied_fraction = grid.getDouble("occupied_fraction", 0.0, 1.0);
  config.grid.min_points = grid.getInt("min_points", 1, 100000);

  const fw::ConfigView map = kinect3d.child("map");
  config.map.voxel_m = map.getDouble("voxel_m", 0.05, 2.0);
  config.map.update_interval_frames = map.getInt("update_interval_frames", 1, 1000);
  config.map.ray_stride_px = map.getInt("ray_stride_px", 1, 64);
  config.map.static_after_s = map.getDouble("static_after_s", 0.1, 600.0);

  const fw::ConfigView ball = kinect3d.child("ball");
  config.ball.radius_m = kinect3d.block("ball").getDouble("radius_m", 0.02, 0.5);
  config.ball.min_visible_fraction = ball.getDouble("min_visible_fraction", 0.0, 1.0);
  config.ball.max_size_ratio = ball.getDouble("max_size_ratio", 1.0, 10.0);
  config.ball.air_min_height_m = ball.getDouble("air_min_height_m", 0.0, 2.0);
  config.second_sight_beyond_m = ball.getDouble("second_sight_beyond_m", 0.0, 100.0);
  config.colour = readColourCheckConfig(kinect3d);
  return config;
}

ColourCheckConfig readColourCheckConfig(const fw::ConfigView& kinect3d) {
  const fw::ConfigView check = kinect3d.child("colour_check");
  ColourCheckConfig config;
  const std::string mode = check.getChoice("mode", {"off", "on", "required"});
  config.mode = mode == "on"         ? ColourCheckConfig::Mode::kOn
                : mode == "required" ? ColourCheckConfig::Mode::kRequired
                                     : ColourCheckConfig::Mode::kOff;
  for (const fw::ConfigView& colour : check.childList("ball_colours")) {
    colour.requireOnlyKeys({"lab", "sigma", "share"});
    const std::vector<double> lab = colour.getDoubleList("lab", 3), sigma = colour.getDoubleList("sigma", 3);
    BallColour c;
    c.lab = {lab[0], lab[1], lab[2]};
    c.sigma = {sigma[0], sigma[1], sigma[2]};
    if (c.lab.x() < 0.0 || c.lab.x() > 100.0 || c.sigma.minCoeff() <= 0.0) {
      throw fw::ConfigError(colour.originOf("lab") + ": " + colour.path() +
                            ": lab is CIE L*a*b* (L 0-100) and every sigma positive");
    }
    c.share = colour.getDouble("share", 0.0, 1.0);
    config.ball_colours.push_back(c);
  }
  config.confirm_score = check.getDouble("confirm_score", 0.0, 1.0);
  config.min_outline = check.getDouble("min_outline", 0.0, 1.0);
  config.reject_score = check.getDouble("reject_score", 0.0, 1.0);
  requireIncreasing(check, "reject_score", config.reject_score, "confirm_score", config.confirm_score);
  if (config.mode != ColourCheckConfig::Mode::kOff) {
    if (config.ball_colours.empty()) {
      throw fw::ConfigError(check.originOf("mode") + ": kinect3d.colour_check.mode is " + mode +
                            " but kinect3d.colour_check.ball_colours is empty: learn the match ball's colours with "
                            "`kinect3d calibrate ball-colour --write` (docs/colour.md)");
    }
    if (!kinect3d.getBool("colour")) {
      throw fw::ConfigError(check.originOf("mode") + ": kinect3d.colour_check.mode is " + mode +
                            " but kinect3d.colour is false (" + kinect3d.originOf("colour") +
                            "): the check needs the colour image");
    }
  }
  return config;
}

TrajectoryConfig readTrajectoryConfig(const fw::ConfigView& kinect3d) {
  TrajectoryConfig config;
  const fw::ConfigView ball = kinect3d.block("ball");
  config.ball_radius_m = ball.getDouble("radius_m", 0.02, 0.5);
  config.drag_per_m = ball.getDouble("drag_per_m", 0.0, 1.0);
  config.drag_sigma_per_m = ball.getDouble("drag_sigma_per_m", 0.0, 1.0);
  config.rolling_decel_mps2 = ball.getDouble("rolling_decel_mps2", 0.0, 10.0);
  const fw::ConfigView trajectory = kinect3d.child("trajectory");
  config.mode = trajectoryModeFromString(trajectory.getChoice("mode", {"ballistic", "paper"}));
  config.curve_sigma_radps = trajectory.getDouble("curve_sigma_radps", 0.0, 1.0);
  config.gate_sigma = trajectory.getDouble("gate_sigma", 1.0, 20.0);
  config.model_sigma_m = trajectory.getDouble("model_sigma_m", 0.0, 1.0);
  config.max_gravity_error_mps2 = trajectory.getDouble("max_gravity_error_mps2", 0.5, 9.81);
  config.min_flight_speed_mps = trajectory.getDouble("min_flight_speed_mps", 0.0, 20.0);
  config.min_support = trajectory.getInt("min_support", 3, 30);
  config.max_gap_s = trajectory.getDouble("max_gap_s", 0.01, 5.0);
  config.history = trajectory.getInt("history", 3, 300);
  return config;
}

FloorCalibrationCheck::Config readCalibrationCheckConfig(const fw::ConfigView& kinect3d) {
  const fw::ConfigView check = kinect3d.child("calibration_check");
  FloorCalibrationCheck::Config config;
  config.interval_frames = check.getInt("interval_frames", 1, 100000);
  config.max_height_error_m = check.getDouble("max_height_error_m", 0.001, 1.0);
  config.max_tilt_error_rad = degreesToRadians(check.getDouble("max_tilt_error_deg", 0.05, 45.0));
  config.confirmations = check.getInt("confirmations", 1, 1000);
  return config;
}

GravityCalibrationCheck::Config readGravityCheckConfig(const fw::ConfigView& kinect3d) {
  const fw::ConfigView check = kinect3d.child("calibration_check");
  GravityCalibrationCheck::Config config;
  config.window_s = check.getDouble("gravity_window_s", 0.1, 60.0);
  config.max_tilt_error_rad = degreesToRadians(check.getDouble("max_tilt_error_deg", 0.05, 45.0));
  config.confirmations = check.getInt("confirmations", 1, 1000);
  return config;
}

}  // namespace kinect3d
