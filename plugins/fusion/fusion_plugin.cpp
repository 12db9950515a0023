// fusion: the world's one ball (fw::FusedBall) from the Kinect's 3D balls, the omni camera's balls
// and the robot's pose in the world state, by the same BallFusion that `kinect3d fuse` runs offline.
// Each step takes what arrived since the last one, oldest first; the fusion itself puts late
// measurements back in order. Beside it runs the check that the Kinect still sits where its
// pose_in_robot says (fusion.alignment_check): an alarm in the log and the world state when its
// ground balls and the omni camera's part.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "fusion/alignment_check.h"
#include "fusion/ball_fusion.h"
#include "kinect3d/config_io.h"
#include "kinect3d/sensor_pose.h"

namespace {

class FusionPlugin : public fw::Plugin {
 public:
  explicit FusionPlugin(const fw::PluginContext& context)
      : world_(*context.world),
        name_(context.config.path()),
        config_(fusion::readFusionConfig(context.config)),
        fusion_(config_) {
    if (!config_.alignment_check.enabled) return;
    kinect_pose_ = kinectPoseInRobot(*context.robot_config);
    const Eigen::Vector2d kinect_xy_R =
        kinect_pose_ ? Eigen::Vector2d(kinect_pose_->x_m, kinect_pose_->y_m) : Eigen::Vector2d::Zero();
    alignment_.emplace(config_, kinect_xy_R);
  }

  fw::StepResult step() override {
    const std::uint64_t version = world_.version();
    if (version == seen_version_) return fw::StepResult::kIdle;
    seen_version_ = version;

    // What arrived since the last step, in the order it was published: a source whose time stamps
    // jump back is still read (the fusion applies the time-line rule to it).
    for (const fw::RobotPose& pose : world_.robotPosesSince(&pose_cursor_)) fusion_.addPose(pose);
    bool updated = false;
    for (const fw::BallFrame& frame : world_.ballFramesSince(config_.kinect.source, &kinect_cursor_)) {
      fusion_.addKinectFrame(frame.stamp.source_time_s, frame.balls);
      if (alignment_) alignment_->addKinectFrame(frame.stamp.source_time_s, frame.balls);
      updated = true;
    }
    for (const fw::OmniFrame& frame : world_.omniFramesSince(config_.omni.source, &omni_cursor_)) {
      fusion_.addOmniFrame(frame.stamp.source_time_s, frame.balls);
      if (alignment_) alignment_->addOmniFrame(frame.stamp.source_time_s, frame.balls);
      updated = true;
    }
    if (!updated) return fw::StepResult::kIdle;
    const fusion::FusionUpdate& update = fusion_.latest();
    if (update.ball) {
      fw::FusedBall ball = *update.ball;
      ball.stamp.receive_time_s = fw::wallClockNow_s();
      world_.publishFusedBall(ball);
    } else {
      world_.clearFusedBall();
    }
    reportLatency();
    checkAlignment(update.time_s);
    return fw::StepResult::kProcessed;
  }

 private:
  // The Kinect plugin's kinect3d.sensor.pose_in_robot, when the robot file gives one (without it
  // the Kinect's balls are placed by the floor fit alone, as if it sat at the robot centre).
  std::optional<kinect3d::SensorPose> kinectPoseInRobot(const fw::Config& robot) const {
    if (!robot.hasBlock(config_.kinect.source)) return std::nullopt;
    const fw::ConfigView kinect = robot.block(config_.kinect.source);
    if (!kinect.has("sensor") || !kinect.child("sensor").has("pose_in_robot")) return std::nullopt;
    return kinect3d::readSensorPose(kinect.child("sensor").child("pose_in_robot"));
  }

  // The Kinect turned or shifted on the robot: loud in the log and in the world state, with the
  // pose_in_robot the omni camera's balls imply.
  void checkAlignment(double t_s) {
    if (!alignment_) return;
    const std::optional<fusion::KinectMisalignment> moved = alignment_->takeAlarm();
    if (!moved) return;
    const double deg = 180.0 / M_PI;
    char comparison[320];
    std::snprintf(comparison, sizeof comparison,
                  "the Kinect's ground balls lie %.2f m from the omni camera's on average (%d pairs); to meet them "
                  "they must turn %.2f +- %.2f deg about the Kinect and shift (%.3f, %.3f) +- (%.3f, %.3f) m",
                  moved->mean_gap_m, moved->pairs, moved->yaw_rad * deg, moved->yaw_sigma_rad * deg,
                  moved->offset_m.x(), moved->offset_m.y(), std::sqrt(moved->offset_covariance_m2(0, 0)),
                  std::sqrt(moved->offset_covariance_m2(1, 1)));
    std::string message =
        "THE SENSOR HAS MOVED since its calibration, or the omni camera has: " + std::string(comparison) + ".";
    if (kinect_pose_) {
      kinect3d::SensorPose estimated = *kinect_pose_;
      estimated.x_m += moved->offset_m.x();
      estimated.y_m += moved->offset_m.y();
      estimated.yaw_rad += moved->yaw_rad;
      message += " Estimated pose_in_robot: " + kinect3d::poseInRobotYaml(estimated) + ".";
    }
    message += " Recalibrate (docs/calibration.md)";
    fw::logError(name_, message);
    world_.publishEvent({name_, "calibration_alarm", message, {t_s, fw::wallClockNow_s()}});
  }

  // Says once when the omni camera's latency has been learnt.
  void reportLatency() {
    if (latency_reported_ || !fusion_.omniLatency_s()) return;
    latency_reported_ = true;
    fw::logInfo(name_, "omni camera's stamps are " + std::to_string(std::lround(1000 * *fusion_.omniLatency_s())) +
                           " ms late against the Kinect's (learnt from " +
                           std::to_string(fusion_.omniLatencyExamples()) + " rolling balls); compensated");
  }

  fw::WorldState& world_;
  const std::string name_;
  const fusion::FusionConfig config_;
  fusion::BallFusion fusion_;
  std::optional<kinect3d::SensorPose> kinect_pose_;  // the Kinect's pose_in_robot, when configured
  std::optional<fusion::AlignmentCheck> alignment_;  // unless fusion.alignment_check.enabled is false
  std::uint64_t seen_version_ = 0;
  std::uint64_t pose_cursor_ = 0, kinect_cursor_ = 0, omni_cursor_ = 0;  // what was read (fw::WorldState)
  bool latency_reported_ = false;
};

}  // namespace

FW_REGISTER_PLUGIN(FusionPlugin, "fusion", "0.1.0")
