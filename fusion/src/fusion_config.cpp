#include "fusion/fusion_config.h"

namespace fusion {

FusionConfig readFusionConfig(const fw::ConfigView& block) {
  FusionConfig config;
  config.max_delay_s = block.getDouble("max_delay_s", 0.0, 2.0);

  config.field_length_m = block.block("field").getDouble("length_m", 8.0, 40.0);

  const fw::ConfigView ball = block.block("ball");
  MotionConfig& motion = config.motion;
  motion.radius_m = ball.getDouble("radius_m", 0.02, 0.5);
  motion.drag_per_m = ball.getDouble("drag_per_m", 0.0, 1.0);
  motion.drag_sigma_per_m = ball.getDouble("drag_sigma_per_m", 0.0, 1.0);
  motion.rolling_decel_mps2 = ball.getDouble("rolling_decel_mps2", 0.0, 10.0);
  motion.restitution = ball.getDouble("restitution", 0.0, 1.0);
  motion.restitution_sigma = ball.getDouble("restitution_sigma", 0.0, 1.0);
  motion.bounce_friction = ball.getDouble("bounce_friction", 0.0, 1.0);
  motion.bounce_friction_sigma = ball.getDouble("bounce_friction_sigma", 0.0, 1.0);
  const fw::ConfigView noise = block.child("motion");
  motion.air_accel_sigma_mps2 = noise.getDouble("air_accel_sigma_mps2", 0.01, 100.0);
  motion.ground_accel_sigma_mps2 = noise.getDouble("ground_accel_sigma_mps2", 0.01, 100.0);
  motion.kick_rate_hz = noise.getDouble("kick_rate_hz", 0.0, 10.0);
  motion.deflection_rate_hz = noise.getDouble("deflection_rate_hz", 0.0, 10.0);
  motion.kick_speed_sigma_mps = noise.getDouble("kick_speed_sigma_mps", 0.1, 50.0);
  motion.learn_bounce = noise.getBool("learn_bounce");

  const fw::ConfigView kinect = block.child("kinect");
  config.kinect.source = kinect.getString("source");
  config.kinect.latency_s = kinect.getDouble("latency_s", -1.0, 1.0);

  const fw::ConfigView omni = block.child("omni");
  config.omni.source = omni.getString("source");
  config.omni.latency_s = omni.getDouble("latency_s", -1.0, 1.0);
  config.omni.viewpoint_height_m = omni.getDouble("viewpoint_height_m", 0.2, 3.0);
  config.omni.max_height_m = omni.getDouble("max_height_m", 0.0, 3.0);
  config.omni.detection_probability = omni.getDouble("detection_probability", 0.0, 0.99);
  config.omni.bearing_sigma_rad = fw::degreesToRadians(omni.getDouble("bearing_sigma_deg", 0.01, 45.0));
  config.omni.distance_sigma_m = omni.getDouble("distance_sigma_m", 0.001, 5.0);
  config.omni.distance_sigma_fraction = omni.getDouble("distance_sigma_fraction", 0.0, 1.0);
  config.omni.estimate_latency = omni.getBool("estimate_latency");
  config.omni.timing_sigma_s = omni.getDouble("timing_sigma_s", 0.0, 1.0);
  if (config.omni.viewpoint_height_m <= motion.radius_m) {
    throw fw::ConfigError(omni.originOf("viewpoint_height_m") + ": " + omni.path() +
                          ".viewpoint_height_m must be above the ball's centre at rest (" + ball.path() +
                          ".radius_m = " + std::to_string(motion.radius_m) + ")");
  }
  if (config.omni.max_height_m < motion.radius_m || config.omni.max_height_m >= config.omni.viewpoint_height_m) {
    throw fw::ConfigError(omni.originOf("max_height_m") + ": " + omni.path() +
                          ".max_height_m must lie between the ball's centre at rest (" + ball.path() +
                          ".radius_m = " + std::to_string(motion.radius_m) + ") and the viewpoint (" + omni.path() +
                          ".viewpoint_height_m = " + std::to_string(config.omni.viewpoint_height_m) + ")");
  }

  const fw::ConfigView pose = block.child("pose");
  config.pose.latency_s = pose.getDouble("latency_s", -1.0, 1.0);
  config.pose.sigma_xy_m = pose.getDouble("sigma_xy_m", 0.0, 5.0);
  config.pose.sigma_theta_rad = fw::degreesToRadians(pose.getDouble("sigma_theta_deg", 0.0, 90.0));
  config.pose.odometry_blend_s = pose.getDouble("odometry_blend_s", 0.0, 10.0);
  config.pose.estimate_latency = pose.getBool("estimate_latency");
  config.pose.timing_sigma_s = pose.getDouble("timing_sigma_s", 0.0, 1.0);

  const fw::ConfigView track = block.child("track");
  config.track.gate_sigma = track.getDouble("gate_sigma", 1.0, 100.0);
  config.track.confirm_updates = track.getInt("confirm_updates", 1, 1000);
  config.track.confirm_window_s = track.getDouble("confirm_window_s", 0.01, 60.0);
  config.track.lost_after_s = track.getDouble("lost_after_s", 0.01, 60.0);
  config.track.min_flight_speed_mps = track.getDouble("min_flight_speed_mps", 0.0, 50.0);
  config.track.initial_speed_sigma_mps = track.getDouble("initial_speed_sigma_mps", 0.1, 50.0);

  const fw::ConfigView check = block.child("alignment_check");
  config.alignment_check.enabled = check.getBool("enabled");
  config.alignment_check.window_pairs = check.getInt("window_pairs", 10, 100000);
  config.alignment_check.max_yaw_error_rad = fw::degreesToRadians(check.getDouble("max_yaw_error_deg", 0.1, 90.0));
  config.alignment_check.max_offset_error_m = check.getDouble("max_offset_error_m", 0.005, 5.0);
  config.alignment_check.confirmations = check.getInt("confirmations", 1, 1000);

  const fw::ConfigView team = block.child("team");
  config.team.use = team.getBool("use");
  config.team.max_delay_s = team.getDouble("max_delay_s", 0.0, 2.0);
  config.team.judge_examples = team.getInt("judge_examples", 1, 1000);
  config.team.discount_sigma = team.getDouble("discount_sigma", 1.0, 100.0);
  config.team.prior_max_age_s = team.getDouble("prior_max_age_s", 0.0, 10.0);
  config.team.ignore = team.getStringList("ignore");
  return config;
}

}  // namespace fusion
