// fusion: the world's one ball (fw::FusedBall) from the Kinect's 3D balls, the omni camera's balls,
// the robot's pose and the teammates' Kinect balls (plugins/team) in the world state, by the same
// BallFusion that `kinect3d fuse` runs offline. Each step takes what arrived since the last one, in the order it
// arrived; the fusion itself puts late measurements back in order of time. Beside it runs the check that the Kinect
// still sits where its pose_in_robot says (fusion.alignment_check): an alarm in the log and the world state when its
// ground balls and the omni camera's part.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <variant>
#include <vector>

#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "framework_api/sensor_pose.h"
#include "fusion/alignment_check.h"
#include "fusion/ball_fusion.h"

namespace {

class FusionPlugin : public fw::Plugin {
 public:
  explicit FusionPlugin(const fw::PluginContext& context)
      : world_(*context.world),
        name_(context.config.path()),
        config_(fusion::readFusionConfig(context.config)),
        fusion_(config_) {}

  fw::StepResult step() override {
    const std::uint64_t version = world_.version();
    if (version == seen_version_) return fw::StepResult::kIdle;
    seen_version_ = version;

    // What arrived since the last step, in the order it arrived (fw::WorldState::measurementsSince),
    // one world ball for each image: the world balls are the same however the steps fall. A source
    // whose time stamps jump back is still read (the fusion applies the time-line rule to it).
    bool updated = false;
    for (const fw::WorldState::Measurement& measurement : world_.measurementsSince(&cursor_)) {
      if (const auto* pose = std::get_if<fw::RobotPose>(&measurement)) {
        fusion_.addPose(*pose);
      } else if (const auto* frame = std::get_if<fw::BallFrame>(&measurement)) {
        if (frame->source != config_.kinect.source) continue;
        if (alignmentCheck()) alignment_->addKinectFrame(frame->stamp.source_time_s, frame->balls);
        publish(fusion_.addKinectFrame(frame->stamp.source_time_s, frame->balls));
        // The robot's latency: from the depth frame's arrival on this host to its world ball.
        world_.reportLatency(name_, fw::wallClockNow_s() - frame->stamp.receive_time_s);
        updated = true;
      } else if (const auto* omni = std::get_if<fw::OmniFrame>(&measurement)) {
        if (omni->source != config_.omni.source) continue;
        if (alignmentCheck()) alignment_->addOmniFrame(omni->stamp.source_time_s, omni->balls);
        publish(fusion_.addOmniFrame(omni->stamp.source_time_s, omni->balls, omni->robots));
        updated = true;
      } else if (const auto* message = std::get_if<fw::TeamMessage>(&measurement)) {
        if (fusion_.ignores(message->robot_name) && said_ignored_.insert(message->robot_id).second) {
          fw::logInfo(name_, "teammate " + message->robot_name + " (robot " + std::to_string(message->robot_id) +
                                 ") heard; its observations are not used (fusion.team.ignore)");
        }
        const fusion::FusionUpdate& update = fusion_.addTeamMessage(*message);
        publish(update);
        reportTeammate(message->robot_id, update.time_s);
        updated = true;
      }
    }
    return updated ? fw::StepResult::kProcessed : fw::StepResult::kIdle;
  }

 private:
  // The world ball after one image, and what the image told the checks: per image, not per step.
  void publish(const fusion::FusionUpdate& update) {
    if (update.ball) {
      fw::FusedBall ball = *update.ball;
      ball.stamp.receive_time_s = fw::wallClockNow_s();
      world_.publishFusedBall(ball);
    } else {
      world_.clearFusedBall({update.time_s, fw::wallClockNow_s()});
    }
    reportLatency(update.time_s);
    reportBounce(update.time_s);
    checkAlignment(update.time_s);
  }

  // The check that the Kinect still sits where its pose_in_robot says, made when its first
  // measurement comes (the Kinect's plugin has published its pose by then, when it has one: without
  // one its balls are placed by the floor fit alone, as if it sat at the robot centre). False when
  // fusion.alignment_check.enabled is false.
  bool alignmentCheck() {
    if (!config_.alignment_check.enabled) return false;
    if (!alignment_) {
      kinect_pose_ = world_.sensorPose(config_.kinect.source);
      const Eigen::Vector2d kinect_xy_R =
          kinect_pose_ ? Eigen::Vector2d(kinect_pose_->x_m, kinect_pose_->y_m) : Eigen::Vector2d::Zero();
      alignment_.emplace(config_, kinect_xy_R);
    }
    return true;
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
      fw::SensorPose estimated = *kinect_pose_;
      estimated.x_m += moved->offset_m.x();
      estimated.y_m += moved->offset_m.y();
      estimated.yaw_rad += moved->yaw_rad;
      message += " Estimated pose_in_robot: " + fw::poseInRobotYaml(estimated) + ".";
    }
    message += " Recalibrate (docs/calibration.md)";
    fw::logError(name_, message);
    world_.publishEvent({name_, "calibration_alarm", message, {t_s, fw::wallClockNow_s()}});
  }

  // Says when a teammate's balls stop agreeing with what this robot sees (its localisation is off)
  // and when they agree again, stamped with the fusion's time (a replay says it at the same time).
  void reportTeammate(int robot_id, double t_s) {
    const auto found = fusion_.teammates().find(robot_id);
    if (found == fusion_.teammates().end()) return;
    const fusion::TeammateStanding& standing = found->second;
    bool& said_discounted = teammate_discounted_[robot_id];
    if (standing.discounted == said_discounted) return;
    said_discounted = standing.discounted;
    char text[320];
    std::snprintf(
        text, sizeof text,
        standing.discounted
            ? "teammate %s (robot %d) puts the ball or the robots it sees %.2f m from where this robot sees them "
              "(median of its last %d observations, %.1f sigma): its localisation is off; its observations are not "
              "used"
            : "teammate %s (robot %d) agrees again with this robot (median %.2f m of its last %d observations, "
              "%.1f sigma): its observations are used",
        standing.name.c_str(), robot_id, standing.median_gap_m, standing.examples, standing.median_mahalanobis);
    if (standing.discounted) {
      fw::logWarn(name_, text);
    } else {
      fw::logInfo(name_, text);
    }
    world_.publishEvent(
        {name_, standing.discounted ? "teammate_discounted" : "teammate_trusted", text, {t_s, fw::wallClockNow_s()}});
  }

  // Follows the omni camera's and the pose's latencies as they are learnt: an event "omni_latency" or
  // "pose_latency" with the latency as its value whenever it has moved by a millisecond (the match log
  // keeps its course), stamped with the update that learnt it, and the two in the world state (the
  // team plugin places this robot's measurements with them). The console is told once, when the
  // standard error has come to half its prior's (timing_sigma_s): the first estimates, from a few
  // readings, are mostly the configured latency and that prior.
  void reportLatency(double t_s) {
    bool moved = false;
    const auto news = [&](const char* kind, const std::optional<fusion::LatencyEstimator::Fit>& latency,
                          const std::string& what, const std::string& from, double prior_sigma_s,
                          std::optional<double>& said_s, bool& told) {
      static constexpr double kLatencyNews_s = 0.001;
      if (!latency) return;
      const bool moved_enough = !said_s || std::abs(latency->latency_s - *said_s) >= kLatencyNews_s;
      const bool tell = !told && latency->sigma_s <= 0.5 * prior_sigma_s;
      if (!moved_enough && !tell) return;
      const std::string message = what + " stamps are " + std::to_string(std::lround(1000 * latency->latency_s)) +
                                  " +- " + std::to_string(std::lround(1000 * latency->sigma_s)) +
                                  " ms late against the Kinect's (learnt from " + from + "); compensated";
      if (tell) {
        fw::logInfo(name_, message);
        told = true;
      }
      if (!moved_enough) return;
      said_s = latency->latency_s;
      moved = true;
      world_.publishEvent({name_, kind, message, {t_s, fw::wallClockNow_s()}, latency->latency_s});
    };
    news("omni_latency", fusion_.omniLatency(), "omni camera's",
         std::to_string(fusion_.omniLatencyExamples()) + " bearings and distances of a ball both sensors saw",
         config_.omni.timing_sigma_s, said_omni_latency_s_, told_omni_latency_);
    news("pose_latency", fusion_.poseLatency(), "pose's",
         std::to_string(fusion_.poseLatencyExamples()) +
             " bearings of a ball at rest the Kinect saw while the robot turned",
         config_.pose.timing_sigma_s, said_pose_latency_s_, told_pose_latency_);
    if (moved) world_.publishLearntLatencies({said_omni_latency_s_, said_pose_latency_s_});
  }

  // Follows the ball's bounce as it is learnt (fusion.motion.learn_bounce): an event "ball_bounce"
  // with the restitution as its value at every bounce learnt, stamped with the update that learnt
  // it; the console is told of the first.
  void reportBounce(double t_s) {
    if (fusion_.bouncesLearnt() == said_bounces_) return;
    const fusion::MotionConfig& bounce = fusion_.bounce();
    char message[240];
    std::snprintf(message, sizeof message,
                  "the ball bounces with restitution %.2f +- %.2f and bounce friction %.2f +- %.2f (learnt from %d "
                  "bounce%s the Kinect saw, from the configured %.2f and %.2f)",
                  bounce.restitution, bounce.restitution_sigma, bounce.bounce_friction, bounce.bounce_friction_sigma,
                  fusion_.bouncesLearnt(), fusion_.bouncesLearnt() == 1 ? "" : "s", config_.motion.restitution,
                  config_.motion.bounce_friction);
    if (said_bounces_ == 0) fw::logInfo(name_, message);
    said_bounces_ = fusion_.bouncesLearnt();
    world_.publishEvent({name_, "ball_bounce", message, {t_s, fw::wallClockNow_s()}, bounce.restitution});
  }

  fw::WorldState& world_;
  const std::string name_;
  const fusion::FusionConfig config_;
  fusion::BallFusion fusion_;
  std::optional<fw::SensorPose> kinect_pose_;        // the Kinect's pose_in_robot, when configured
  std::optional<fusion::AlignmentCheck> alignment_;  // once alignmentCheck() made it
  std::uint64_t seen_version_ = 0;
  std::uint64_t cursor_ = 0;                   // what was read of the measurements (fw::WorldState)
  std::map<int, bool> teammate_discounted_;    // as last said, by robot id
  std::set<int> said_ignored_;                 // teammates fusion.team.ignore names, heard and said so
  std::optional<double> said_omni_latency_s_;  // the omni latency last said
  std::optional<double> said_pose_latency_s_;  // the pose's
  bool told_omni_latency_ = false;             // whether the console was told of it
  bool told_pose_latency_ = false;             // of the pose's
  int said_bounces_ = 0;                       // the bounces learnt when last said
};

}  // namespace

FW_REGISTER_PLUGIN(FusionPlugin, "fusion", "0.1.0")
