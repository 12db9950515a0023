#include "fusion_report.h"

#include <unistd.h>
#include <algorithm>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>

#include "fusion/fusion_config.h"
#include "fusion/json_lines.h"
#include "fusion/pose_blend.h"
#include "kinect3d/sim/ball_motion.h"
#include "kinect3d/sim/field_sensors.h"
#include "kinect3d/sim/sequence_writer.h"
#include "offline_fusion.h"
#include "report_text.h"

namespace kinect3d {

namespace {

namespace fs = std::filesystem;

const std::vector<std::string> kScenes = {"lob_over_robot",    "lob_landing_behind", "chip_bounces_behind",
                                          "lob_while_turning", "ball_hits_robot",    "lob_past_robot",
                                          "chip_and_roll",     "pass_on_ground",     "leaves_view",
                                          "lamp_in_view",      "turn_at_rest",       "swing_at_rest"};
constexpr double kAirborneAbove_m = 0.01;  // truth: in the air when the centre is this far above rest
constexpr double kHopAbove_m =
    0.05;  // hops lower than this are the ball rolling on: the landing is after the last higher one
constexpr double kPhantomNear_m = 0.3;   // a world ball this close to the omni phantom sits on it ...
constexpr double kPhantomApart_m = 0.5;  // ... when the phantom is this far from the ball
constexpr double kFrame_s = 1.0 / 30.0;
// How far a calibration of the ball from a few flights leaves its drag, restitution and bounce
// friction (one sigma; tests/test_calibrate_drag.cpp holds one lob to 0.003 /m, 0.08 and 0.05).
constexpr double kCalibratedDragSigma_per_m = 0.002;
constexpr double kCalibratedBounceSigma = 0.03;
constexpr double kLatencyWithin_s = 0.01;  // the omni latency counts as learnt this close to the truth

struct Scored {
  std::vector<double> air_errors, ground_errors;
  // In the air: how far a perfect sensor's ball would be off, mapped through the pose the fusion maps
  // with instead of the true one (what no filter of one robot's sensors removes).
  std::vector<double> air_pose_floor;
  std::vector<double> ground_errors_kinect_sees;  // on the ground, while the Kinect sees the ball
  int updates = 0, with_ball = 0, on_phantom = 0;
  std::vector<double> kick_delays_frames, landing_delays_frames;

  void add(const Scored& other) {
    air_errors.insert(air_errors.end(), other.air_errors.begin(), other.air_errors.end());
    air_pose_floor.insert(air_pose_floor.end(), other.air_pose_floor.begin(), other.air_pose_floor.end());
    ground_errors.insert(ground_errors.end(), other.ground_errors.begin(), other.ground_errors.end());
    ground_errors_kinect_sees.insert(ground_errors_kinect_sees.end(), other.ground_errors_kinect_sees.begin(),
                                     other.ground_errors_kinect_sees.end());
    updates += other.updates;
    with_ball += other.with_ball;
    on_phantom += other.on_phantom;
    kick_delays_frames.insert(kick_delays_frames.end(), other.kick_delays_frames.begin(),
                              other.kick_delays_frames.end());
    landing_delays_frames.insert(landing_delays_frames.end(), other.landing_delays_frames.begin(),
                                 other.landing_delays_frames.end());
  }
};

// A scene with its physics and the omni's stamp error drawn for this seed, and the ball block a
// robot that calibrated this ball would run with.
struct Case {
  sim::Scene scene;
  sim::OmniCameraModel omni;
  sim::LocalisationModel localisation;
  std::vector<std::string> calibrated_ball;  // configuration overrides
};

Case makeCase(const std::string& name, int seed) {
  Case c{sim::loadScene(name), {}, {}, {}};
  std::mt19937 random(static_cast<unsigned>(seed * 7919 + std::hash<std::string>{}(name) % 1000));
  auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(random); };
  c.scene.noise.seed = static_cast<std::uint64_t>(seed);
  c.scene.physics.drag_per_m = uniform(0.012, 0.035);
  c.scene.physics.restitution = uniform(0.5, 0.7);
  c.scene.physics.bounce_friction = uniform(0.1, 0.3);
  c.scene.physics.rolling_decel_mps2 = uniform(0.25, 0.6);
  c.omni.stamp_late_s = uniform(0.02, 0.06);
  c.omni.max_height_m = uniform(0.5, 0.7);  // the mirror's view ends where the fusion does not know exactly
  c.omni.seed = c.localisation.seed = static_cast<std::uint64_t>(seed);
  if (name == "lob_landing_behind") {
    // Over the robot to 1-6 m behind it: the flight time of the kick's rise and fall, without drag
    // (drag shortens it a little), over the distance from the ball to the landing point.
    sim::BallLaunch& ball = *c.scene.ball;
    const double landing_y = -uniform(1.0, 6.0);
    const double flight_s = 2.0 * ball.velocity_mps.z() / c.scene.physics.gravity_mps2;
    ball.velocity_mps.y() = (landing_y - ball.position_m.y()) / flight_s;
  }
  // Drawn last, so that the draws above are those of the seeds before they were.
  c.omni.max_distance_m = uniform(6.0, 10.0);  // the mirror's reach, which the fusion does not know
  // The ball as `kinect3d calibrate drag` measures it from a few of its flights: drag, restitution
  // and bounce friction, each off by a calibration's error (one sigma). It does not measure rolling.
  auto calibrated = [&](const std::string& key, double truth, double sigma, double lo, double hi) {
    const double value = std::clamp(truth + std::normal_distribution<double>(0.0, sigma)(random), lo, hi);
    c.calibrated_ball.push_back("ball." + key + "=" + std::to_string(value));
  };
  calibrated("drag_per_m", c.scene.physics.drag_per_m, kCalibratedDragSigma_per_m, 0.001, 0.1);
  calibrated("restitution", c.scene.physics.restitution, kCalibratedBounceSigma, 0.05, 0.95);
  calibrated("bounce_friction", c.scene.physics.bounce_friction, kCalibratedBounceSigma, 0.0, 0.9);
  c.localisation.odometry_error = uniform(0.005, 0.05);  // the wheels' scale error and noise (one sigma)
  c.omni.distance_scale = uniform(0.97, 1.03);           // the mirror's distance map, calibrated a few per cent off
  c.localisation.stamp_late_s = uniform(0.0, 0.04);      // a localisation that stamps its pose when it is done
  return c;
}

// The poses the fusion maps its sensors with: the simulated localisation's, blended with the wheels'
// odometry as the fusion blends them.
std::vector<fw::RobotPose> mappedPoses(const Case& c, const fusion::PoseConfig& pose) {
  const sim::LocalisationSimulator localisation(c.scene, c.localisation);
  fusion::PoseBlend blend(pose.odometry_blend_s, pose.sigma_xy_m, pose.sigma_theta_rad);
  std::vector<fw::RobotPose> poses;
  for (int i = 0; i < localisation.frameCount(); ++i) poses.push_back(blend.add(localisation.pose(i)));
  return poses;
}

// Whether the Kinect saw the ball at time t: the Kinect-only run's last update at or before t had a
// ball measured in that frame (not one coasting on its prediction).
bool kinectSawBall(const FusionRun& kinect_only, double t_s) {
  const auto after = std::upper_bound(kinect_only.updates.begin(), kinect_only.updates.end(), t_s,
                                      [](double t, const fusion::FusionUpdate& update) { return t < update.time_s; });
  if (after == kinect_only.updates.begin()) return false;
  const std::optional<fw::FusedBall>& ball = (after - 1)->ball;
  return ball && ball->age_s < 0.5 * kFrame_s;
}

Scored score(const Case& c, const FusionRun& run, const FusionRun& kinect_only,
             const std::vector<fw::RobotPose>& mapped_poses) {
  const sim::Scene& scene = c.scene;
  const sim::BallMotion motion(*scene.ball, scene.physics, scene.duration_s + 1.0, scene.objects);
  const double r = scene.physics.radius_m;
  auto airborne = [&](double t) { return motion.positionAt(t).z() > r + kAirborneAbove_m; };
  // The kick and the final landing, on the scene clock.
  auto hopping = [&](double t) { return motion.positionAt(t).z() > r + kHopAbove_m; };
  double kick_t = -1.0, landing_t = -1.0;
  for (double t = 0.0; t < scene.duration_s; t += 0.001) {
    if (kick_t < 0.0 && airborne(t)) kick_t = t;
    if (kick_t >= 0.0 && hopping(t) && !hopping(t + 0.001)) landing_t = t;
  }
  Scored s;
  double kick_seen = -1.0, landing_seen = -1.0;
  for (const fusion::FusionUpdate& update : run.updates) {
    const double t = update.time_s - scene.start_time_s;
    if (t < 0.0 || t > scene.duration_s) continue;
    ++s.updates;
    if (!update.ball) continue;
    ++s.with_ball;
    const Eigen::Vector3d truth = motion.positionAt(t);
    const double error = (update.ball->position_F - truth).norm();
    (airborne(t) ? s.air_errors : s.ground_errors).push_back(error);
    if (airborne(t)) {
      const int index = std::clamp(static_cast<int>(std::lround(t * c.localisation.rate_hz)), 0,
                                   static_cast<int>(mapped_poses.size()) - 1);
      const Eigen::Vector3d seen = mapped_poses[index].T_F_R() * (scene.robot.poseAt(t).T_F_R().inverse() * truth);
      s.air_pose_floor.push_back((seen - truth).norm());
    }
    if (!airborne(t) && kinectSawBall(kinect_only, update.time_s)) s.ground_errors_kinect_sees.push_back(error);
    const fw::RobotPose pose = scene.robot.poseAt(t);
    const Eigen::Vector2d robot(pose.x_m, pose.y_m);
    if (airborne(t) && truth.z() < c.omni.viewpoint_height_m) {
      const Eigen::Vector2d out = truth.head<2>() - robot;
      const Eigen::Vector2d phantom =
          robot + out * (c.omni.viewpoint_height_m - r) / (c.omni.viewpoint_height_m - truth.z());
      if ((phantom - truth.head<2>()).norm() > kPhantomApart_m &&
          (update.ball->position_F.head<2>() - phantom).norm() < kPhantomNear_m) {
        ++s.on_phantom;
      }
    }
    if (kick_t >= 0.0 && kick_seen < 0.0 && t >= kick_t && update.ball->state == fw::BallState::kAir) kick_seen = t;
    if (landing_t >= 0.0 && landing_seen < 0.0 && t >= landing_t && update.ball->state == fw::BallState::kGround) {
      landing_seen = t;
    }
  }
  if (kick_seen >= 0.0) s.kick_delays_frames.push_back((kick_seen - kick_t) / kFrame_s);
  if (landing_seen >= 0.0) s.landing_delays_frames.push_back((landing_seen - landing_t) / kFrame_s);
  return s;
}

std::string row(const std::string& name, const std::string& run, const Scored& s) {
  char text[512];
  std::snprintf(
      text, sizeof text, "| %s | %s | %s | %s | %s | %s | %s | %.0f %% | %d | %s | %s |\n", name.c_str(), run.c_str(),
      metres(fw::quantile(s.air_errors, 0.5)).c_str(), metres(fw::quantile(s.air_errors, 0.95)).c_str(),
      metres(fw::quantile(s.ground_errors, 0.5)).c_str(), metres(fw::quantile(s.ground_errors, 0.95)).c_str(),
      metres(fw::quantile(s.ground_errors_kinect_sees, 0.5)).c_str(), s.updates ? 100.0 * s.with_ball / s.updates : 0.0,
      s.on_phantom, metres(fw::quantile(s.kick_delays_frames, 1.0)).c_str(),
      metres(fw::quantile(s.landing_delays_frames, 1.0)).c_str());
  return text;
}

}  // namespace

std::string fusionReportScenes() { return joined(kScenes); }

void writeFusionReport(const fw::Config& config, int seeds, const std::string& out_path, const std::string& keep_dir,
                       const std::vector<std::string>& scenes) {
  for (const std::string& name : scenes) {
    if (std::find(kScenes.begin(), kScenes.end(), name) == kScenes.end()) {
      throw std::runtime_error("--scenes: '" + name + "' is not a scene of the fusion report (" + fusionReportScenes() +
                               ")");
    }
  }
  // The inputs of every case go to disk; kept where asked, else in a folder removed at the end.
  const fs::path inputs_dir = keep_dir.empty()
                                  ? fs::temp_directory_path() / ("kinect3d-fusion-report-" + std::to_string(::getpid()))
                                  : fs::path(keep_dir);
  const char* runs[] = {"fused", "fused, ball calibrated", "fused, no odometry", "omni only", "Kinect only"};
  constexpr int kRuns = 5;
  const fusion::PoseConfig pose_config = fusion::readFusionConfig(config.block("fusion")).pose;
  std::string table, latency;
  int latency_runs = 0, latency_within = 0;  // runs, and those whose learnt omni latency is within kLatencyWithin_s
  int pose_latency_runs = 0, pose_latency_within = 0;  // runs that learnt the pose's latency, and those within
  Scored overall[kRuns];
  for (const std::string& name : scenes.empty() ? kScenes : scenes) {
    Scored per_scene[kRuns];
    for (int seed = 1; seed <= seeds; ++seed) {
      // Through files, exactly as `kinect3d fuse` reads them.
      const Case c = makeCase(name, seed);
      const std::string dir = (inputs_dir / (name + "-" + std::to_string(seed))).string();
      sim::writeTumSequence(c.scene, dir);
      writeFieldSensorFiles(c.scene, c.omni, c.localisation, dir);
      const std::string depth = "tum:" + dir, omni = dir + "/omni.jsonl", pose = dir + "/pose.jsonl";
      const FusionRun fused = fuseRecorded(config, {depth, omni, pose});
      const FusionRun calibrated = fuseRecorded(config.with(c.calibrated_ball), {depth, omni, pose});
      const FusionRun no_odometry = fuseRecorded(config.with({"fusion.pose.odometry_blend_s=0"}), {depth, omni, pose});
      const FusionRun omni_only = fuseRecorded(config, {"", omni, pose});
      const FusionRun kinect_only = fuseRecorded(config, {depth, "", pose});
      fusion::writeFusedFile(dir + "/fused.jsonl", fused.updates);
      const std::vector<fw::RobotPose> mapped_poses = mappedPoses(c, pose_config);
      const FusionRun* run_of[kRuns] = {&fused, &calibrated, &no_odometry, &omni_only, &kinect_only};
      for (int k = 0; k < kRuns; ++k) per_scene[k].add(score(c, *run_of[k], kinect_only, mapped_poses));
      char text[256];
      const auto ms = [](const std::optional<double>& s) {
        return s ? std::to_string(std::lround(1000 * *s)) : std::string("-");
      };
      std::snprintf(text, sizeof text, "| %s | %d | %.0f | %s | %.0f | %s |\n", name.c_str(), seed,
                    1000 * c.omni.stamp_late_s, ms(fused.omni_latency_s).c_str(), 1000 * c.localisation.stamp_late_s,
                    ms(fused.pose_latency_s).c_str());
      latency += text;
      ++latency_runs;
      if (fused.omni_latency_s && std::abs(*fused.omni_latency_s - c.omni.stamp_late_s) <= kLatencyWithin_s) {
        ++latency_within;
      }
      if (fused.pose_latency_s) {
        ++pose_latency_runs;
        pose_latency_within += std::abs(*fused.pose_latency_s - c.localisation.stamp_late_s) <= kLatencyWithin_s;
      }
    }
    for (int k = 0; k < kRuns; ++k) {
      table += row(name, runs[k], per_scene[k]);
      overall[k].add(per_scene[k]);
    }
  }
  for (int k = 0; k < kRuns; ++k) table += row("**all**", runs[k], overall[k]);

  std::ofstream out(out_path);
  if (!out) throw std::runtime_error(out_path + ": cannot open for writing");
  out << "# Fusion: the world's ball against each sensor alone\n\n"
      << "Generated by `kinect3d report fusion --out " << out_path << " --seeds " << seeds
      << (scenes.empty() ? "" : " --scenes " + joined(scenes)) << " --keep <dir>`"
      << " (docs/fusion.md explains the filter). `--keep` leaves each case's inputs in `<dir>/<scene>-<seed>/` (depth "
         "as "
         "a TUM sequence, omni.jsonl, pose.jsonl, truth.json) with the fused output, fused.jsonl, which `kinect3d fuse "
         "--depth tum:<case> --omni <case>/omni.jsonl --pose <case>/pose.jsonl --output out.jsonl` reproduces line for "
         "line. Each run is the robot's own plugins (localisation, kinect3d, omni, fusion) in the host's deterministic "
         "mode, every input handed out at its time stamp, as on a robot that receives each the moment it is taken. "
         "Each scene runs with "
      << seeds
      << " seeds; per seed the ball's drag (0.012-0.035 /m), restitution (0.5-0.7), bounce friction (0.1-0.3) "
         "and rolling deceleration (0.25-0.6 m/s^2) and the omni camera's stamp error (20-60 ms late) and the top of "
         "its view (a ball centre "
         "0.5-0.7 m up; the fusion assumes 0.6), its reach (6-10 m, which the fusion does not know) and the "
         "scale of its distances (0.97-1.03: a mirror calibrated a few per cent off) "
         "are drawn anew, and in lob_landing_behind the kick, to land 1-6 m "
         "behind the robot, so the filter is never tuned to one physics or one flight: it runs with the shipped ball "
         "block (*fused*), and once more with the ball calibrated (*fused, ball calibrated*: its drag, restitution and "
         "bounce friction as `kinect3d calibrate drag` would measure them from a few flights, each off by a drawn "
         "error of 0.002 /m, 0.03 and 0.03, one sigma; rolling is not calibrated), and once more with the pose as the "
         "localisation gives it, without the wheels' odometry (*fused, no odometry*). The robot carrying the sensors "
         "stands, drives, turns or swings its heading (pass_on_ground, lob_while_turning, turn_at_rest, "
         "swing_at_rest); the ball bounces off robots (ball_hits_robot). The robot's pose comes from simulated "
         "localisation (3 cm, 1 degree, correlated over 1 s), its stamps 0-40 ms late (drawn per seed, unknown to the "
         "fusion), with the wheels' odometry beside it (off by a scale error and noise of 0.5-5 %, drawn per seed), "
         "which the fusion blends (fusion.pose.odometry_blend_s). "
         "The omni camera misses 5 % of images, "
         "is blocked by robots and people, and sees an orange false ball about every 2 s.\n\n"
      << "Errors are 3D distances in the field frame between the world's ball and the truth at each update (both "
         "sensors' frames), split by whether the true ball is in the air; the ground median is also given over the "
         "updates at which the Kinect alone has a ball, where the fused ball competes with the better sensor. *With "
         "ball*: share of updates that have a "
         "world ball. *On phantom*: updates whose world ball sat within 0.3 m of the omni camera's phantom of a ball "
         "in the air (the phantom at least 0.5 m from the ball). *Kick* and *landing*: frames (1/30 s) from the kick, "
         "and from the end of the bounces (the last hop higher than 5 cm: lower ones are the ball rolling on), to the "
         "first update in the air or on the ground mode (worst over seeds).\n\n"
      << "| scene | run | air median (m) | air p95 (m) | ground median (m) | ground p95 (m) | ground median where "
         "the Kinect sees it (m) | with ball | on phantom | kick (frames) | landing (frames) |\n"
      << "|---|---|---|---|---|---|---|---|---|---|---|\n"
      << table << "\nThe localisation's share: a perfect sensor's ball in the air, mapped through the pose the "
      << "fusion maps with (the simulated localisation's at its true time, blended with the odometry) instead of the "
         "true one, would be "
         "off by "
      << metres(fw::quantile(overall[0].air_pose_floor, 0.5)) << " m (median) and "
      << metres(fw::quantile(overall[0].air_pose_floor, 0.95))
      << " m (p95) at the fused run's updates; no filter of one robot's own sensors removes that.\n"
      << "\n## Latencies learnt online\n\nThe omni camera's stamps are late by a simulated amount unknown to the "
         "fusion; it learns the offset from the bearings and distances of a ball the Kinect sees, on the floor or in "
         "the air, while they change (the ball crossing the view, flying past or rolling away, its phantom running "
         "out as it rises, or the robot turning), the distances' scale error a second unknown beside the time. The "
         "localisation's poses are stamped late too (0-40 ms, as by a localisation that stamps a pose when it is "
         "done), which the fusion learns only from a ball at rest that the Kinect sees while the robot turns; "
         "until then it maps by the pose as stamped. *Estimated*: what the fusion plugin last said (its events "
         "omni_latency and pose_latency, said again whenever an estimate has moved by 1 ms; - where it learnt "
         "none).\n\n"
      << "| scene | seed | omni simulated (ms) | omni estimated (ms) | pose simulated (ms) | pose estimated (ms) |\n"
         "|---|---|---|---|---|---|\n"
      << latency << "\nOmni latency within 10 ms: " << latency_within << " of " << latency_runs
      << " runs. Pose latency learnt in " << pose_latency_runs << " runs, within 10 ms in " << pose_latency_within
      << " of them.\n";
  if (!out.flush()) throw std::runtime_error(out_path + ": write failed");
  if (keep_dir.empty()) fs::remove_all(inputs_dir);
}

}  // namespace kinect3d
