// What the fusion knows about the ball, the sensors and its own tracking: the `fusion` block of a
// robot file (config/defaults/fusion.yaml documents every key), as structs with the shipped defaults.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "framework_api/config.h"

namespace fusion {

// The ball's physics and how much the motion models may be wrong.
struct MotionConfig {
  double radius_m = 0.11;
  double drag_per_m = 0.02;              // quadratic air drag rho Cd A / 2m (as fw::BallTrajectory)
  double drag_sigma_per_m = 0.007;       // how far this ball's drag may be off drag_per_m
  double rolling_decel_mps2 = 0.4;       // a rolling ball slows by this
  double restitution = 0.6;              // vertical speed kept at a bounce
  double restitution_sigma = 0.07;       // its spread from bounce to bounce
  double bounce_friction = 0.2;          // share of horizontal speed lost at a bounce
  double bounce_friction_sigma = 0.1;    // its spread from bounce to bounce
  double air_accel_sigma_mps2 = 0.4;     // unmodelled acceleration in flight beyond the drag's spread (spin)
  double ground_accel_sigma_mps2 = 1.0;  // on the ground (dribbling, nudges, uneven carpet)
  double kick_rate_hz = 0.5;             // how often a ball on the ground is expected to be kicked
  double deflection_rate_hz = 0.02;      // how often a flying ball is deflected (a robot's hull, a head, a post)
  double kick_speed_sigma_mps = 6.0;     // spread of the velocity a kick gives
  bool learn_bounce = true;              // restitution and bounce friction learnt from the bounces the Kinect sees
};

struct KinectConfig {
  std::string source = "kinect3d";  // world-state source name of the 3D balls
  double latency_s = 0.0;           // its stamps are this much later than the capture
};

struct OmniConfig {
  std::string source = "omni";
  double latency_s = 0.0;
  double viewpoint_height_m = 0.75;       // height of the omni mirror's viewpoint above the floor
  double max_height_m = 0.6;              // a ball centre higher than this is above its mirror's view
  double detection_probability = 0.8;     // of a ball in its view (robots and people hide some)
  double bearing_sigma_rad = 0.0262;      // when the observation carries none
  double distance_sigma_m = 0.05;         // at the robot ...
  double distance_sigma_fraction = 0.05;  // ... growing with distance
  bool estimate_latency = true;           // learn the omni's latency relative to the Kinect online
  double timing_sigma_s = 0.05;           // how far its stamps may be off until the latency is learnt
};

struct PoseConfig {
  double latency_s = 0.0;
  double sigma_xy_m = 0.03;  // localisation error, added to every measurement mapped by the pose
  double sigma_theta_rad = 0.0175;
  double odometry_blend_s = 1.0;  // with the wheels' odometry: the localisation followed over this (PoseBlend)
  bool estimate_latency = true;   // learn the pose's latency relative to the Kinect online (the robot's turns)
  double timing_sigma_s = 0.05;   // how far its stamps may be off until the latency is learnt
};

// The time lines' two conventions for what the fusion learns of its inputs' lateness beyond the
// configured latencies (docs/fusion.md, "Time"), for every stage that places the same measurements
// (the fusion, and the team plugin for what it sends):
// - the time the omni camera took the image it stamped stamp_s;
inline double omniSeen_s(double stamp_s, const OmniConfig& omni, double learnt_s) {
  return stamp_s - omni.latency_s - learnt_s;
}
// - the stamp, less fusion.pose.latency_s, of the pose that shows the robot at t_s: a pose stamped
//   late shows the robot of an earlier time.
inline double poseStampFor_s(double t_s, double learnt_pose_s) { return t_s + learnt_pose_s; }

struct TrackConfig {
  double gate_sigma = 4.0;               // a measurement joins a track within this Mahalanobis distance
  int confirm_updates = 3;               // measurements before a track may become the world's ball
  double confirm_window_s = 0.5;         // a track not confirmed this long after its start is dropped
  double lost_after_s = 1.0;             // a track without support this long is dropped
  double min_flight_speed_mps = 1.0;     // a track born in the air must move this fast (lamps do not)
  double initial_speed_sigma_mps = 3.0;  // velocity uncertainty of a new track
};

// Do the Kinect's ground balls still lie where the omni camera sees them? (AlignmentCheck)
struct AlignmentCheckConfig {
  bool enabled = true;
  int window_pairs = 150;                         // ball pairs one fit uses; a fit every half window
  double max_yaw_error_rad = 2.0 * M_PI / 180.0;  // an alarm beyond these ...
  double max_offset_error_m = 0.05;
  int confirmations = 2;  // ... in this many fits in a row
};

// Teammates' Kinect balls and omni rays (plugins/team): measurements of the world's ball like this
// robot's own, with the teammate's localisation error added, as long as they agree with what this
// robot sees.
struct TeamConfig {
  bool use = true;
  double max_delay_s = 0.3;     // they come over Wi-Fi: later than this behind the newest, dropped
  int judge_examples = 10;      // a teammate is judged on this many observations beside this robot's own view ...
  double discount_sigma = 4.0;  // ... and discounted while their median Mahalanobis distance is beyond this
  // A teammate's world ball is this robot's, as a weak prior, while nothing else gives it one, up to
  // this long after the last measurement that supported it (0: never).
  double prior_max_age_s = 1.0;
  // Teammates (their host.robot_name) whose observations are never used, as if discounted from the
  // start: one known to be broken, or a replay asking what one teammate changed (the team report's
  // "moved by the keeper").
  std::vector<std::string> ignore;
};

struct FusionConfig {
  MotionConfig motion;
  KinectConfig kinect;
  OmniConfig omni;
  PoseConfig pose;
  TrackConfig track;
  AlignmentCheckConfig alignment_check;
  TeamConfig team;
  double max_delay_s = 0.15;     // this robot's measurements later than this behind the newest are dropped
  double field_length_m = 22.0;  // between the goal lines (the shared `field` block)
};

// Reads the `fusion` block; throws fw::ConfigError naming file, line and key.
FusionConfig readFusionConfig(const fw::ConfigView& block);

}  // namespace fusion
