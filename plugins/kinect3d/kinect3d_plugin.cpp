// kinect3d: reads depth frames from the configured source, detects balls and publishes them to
// the world state as observations in the robot frame with covariances from the depth noise model,
// and the ball's trajectory (touchdown, crossing of the robot's line) while it has one. For the
// match log it also publishes each depth frame (when the log wants them), its dropped frames and
// the events a person looks for afterwards (the floor found, the sensor reopened).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "framework_api/pose_history.h"
#include "framework_api/sensor_pose.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/depth_source.h"
#include "kinect3d/sensor_calibration.h"
#include "kinect3d/sim/sim_sources.h"
#include "kinect3d/trajectory.h"
#include "replay.h"

namespace {

class Kinect3dPlugin : public fw::Plugin {
 public:
  explicit Kinect3dPlugin(const fw::PluginContext& context)
      : world_(*context.world),
        source_name_(context.config.path()),
        detector_(kinect3d::readDetectorConfig(context.config), source_name_),
        trajectory_(kinect3d::makeTrajectoryEstimator(kinect3d::readTrajectoryConfig(context.config))) {
    kinect3d::SourceOptions options;
    options.realtime = context.config.getBool("realtime");
    options.wait_for_device = true;  // a Kinect still enumerating at boot is waited for, not fatal
    options.colour = context.config.getBool("colour");
    options.sim_world_start_wall_s = replay::simWorldStart(context);
    options.host_pace = &context.world->replayPace();
    const std::string uri = context.config.getString("source");
    try {
      source_ = kinect3d::sim::sourcesWithSimulator().open(uri, options);
    } catch (const kinect3d::DepthSourceError& e) {
      throw fw::ConfigError(context.config.originOf("source") + ": kinect3d.source: " + e.what());
    }
    fw::logInfo(source_name_, "reading " + source_->describe());
    const kinect3d::DetectorConfig detector_config = kinect3d::readDetectorConfig(context.config);
    calibrated_ = detector_config.ground.pose;
    if (calibrated_) {
      world_.publishSensorPose(source_name_, *calibrated_);
      calibration_check_.emplace(kinect3d::readCalibrationCheckConfig(context.config), *detector_config.ground.pose,
                                 detector_config.ground);
      gravity_check_.emplace(kinect3d::readGravityCheckConfig(context.config), *detector_config.ground.pose);
    }
  }

  fw::StepResult step() override {
    switch (source_->read(frame_)) {
      case kinect3d::ReadResult::kEnd:
        return fw::StepResult::kEndOfStream;
      case kinect3d::ReadResult::kNoFrameYet:
        return fw::StepResult::kIdle;
      case kinect3d::ReadResult::kFrame:
        break;
    }
    const auto started = std::chrono::steady_clock::now();
    // The frame takes its place among the measurements now, with the poses that came before it.
    const fw::WorldState::DepthArrival arrival = world_.arriveDepthFrame(
        world_.journalWantsDepth() ? std::optional<fw::DepthImage>(kinect3d::toDepthImage(frame_, source_name_))
                                   : std::nullopt,
        &pose_cursor_);
    for (const fw::RobotPose& pose : arrival.poses) poses_.add(pose);
    // With a pose from localisation the scene map is kept in the field frame: the pose at the
    // frame's own time.
    std::optional<Eigen::Isometry3d> T_F_R;
    if (!poses_.empty()) T_F_R = poses_.at(frame_.source_time_s).T_F_R();
    const fw::Stamp stamp{frame_.source_time_s, frame_.receive_time_s};
    try {
      detector_.detect(frame_, detections_, T_F_R);
    } catch (...) {
      // The frame's place is filled all the same, without a ball, so the fusion does not wait for it.
      world_.publishBallFrame(arrival.place, {stamp, {}, source_name_});
      throw;
    }
    // Every frame, with or without a ball: the fusion reads a frame without one as evidence.
    world_.publishBallFrame(arrival.place, {stamp, detections_.balls, source_name_});
    if (detections_.aligned && !reported_alignment_) {
      fw::logInfo(source_name_, "sensor aligned with the floor; detecting");
      publishEvent("floor_found", "sensor aligned with the floor; detecting");
      reported_alignment_ = true;
    }
    reportSourceCounters();
    checkCalibration();
    if (const auto trajectory = trajectory_->update(frame_.source_time_s, detections_.balls)) {
      world_.publishTrajectory(*trajectory);
    } else {
      world_.clearTrajectory(source_name_);
    }
    world_.reportProcessingTime(source_name_,
                                std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
    return fw::StepResult::kProcessed;
  }

 private:
  void publishEvent(const std::string& kind, const std::string& message) {
    world_.publishEvent({source_name_, kind, message, {frame_.source_time_s, frame_.receive_time_s}});
  }

  // Dropped frames for the host's health; a reopened device as an event.
  void reportSourceCounters() {
    const kinect3d::SourceCounters& counters = source_->counters();
    world_.reportDroppedFrames(source_name_, counters.dropped);
    if (counters.reconnects > reported_reconnects_) {
      reported_reconnects_ = counters.reconnects;
      publishEvent("sensor_reopened", "the depth sensor was lost and opened again (" +
                                          std::to_string(counters.reconnects) + " times so far)");
    }
  }

  // A sensor knocked since its calibration: loud in the log and in the world state, with the pose
  // the floor (or gravity) now implies.
  void checkCalibration() {
    if (calibration_check_) {
      if (const std::optional<fw::SensorPose> moved = calibration_check_->check(frame_))
        alarm("the floor", *moved, true);
    }
    if (gravity_check_) {
      if (const std::optional<fw::SensorPose> moved = gravity_check_->check(frame_)) alarm("gravity", *moved, false);
    }
  }

  void alarm(const std::string& evidence, const fw::SensorPose& moved, bool with_height) {
    const double deg = 180.0 / M_PI;
    char height[64] = "";
    if (with_height) std::snprintf(height, sizeof height, "z %.3f m, ", moved.z_m);
    char comparison[256];
    std::snprintf(
        comparison, sizeof comparison,
        " puts it at %spitch %.2f deg, roll %.2f deg; pose_in_robot says z %.3f m, pitch %.2f deg, roll %.2f deg",
        height, moved.pitch_rad * deg, moved.roll_rad * deg, calibrated_->z_m, calibrated_->pitch_rad * deg,
        calibrated_->roll_rad * deg);
    const std::string message = "THE SENSOR HAS MOVED since its calibration: " + evidence + comparison +
                                ". Estimated pose_in_robot: " + fw::poseInRobotYaml(moved) +
                                ". Recalibrate (docs/calibration.md)";
    fw::logError(source_name_, message);
    publishEvent("calibration_alarm", message);
  }

  fw::WorldState& world_;
  const std::string source_name_;  // this plugin's block name: what its observations carry
  kinect3d::BallDetector detector_;
  std::unique_ptr<kinect3d::TrajectoryEstimator> trajectory_;
  std::unique_ptr<kinect3d::DepthSource> source_;
  kinect3d::DepthFrame frame_;
  kinect3d::Detections detections_;
  fw::PoseHistory poses_;          // the robot's, from localisation
  std::uint64_t pose_cursor_ = 0;  // what was read of them (fw::WorldState)
  bool reported_alignment_ = false;
  std::optional<fw::SensorPose> calibrated_;  // pose_in_robot, when configured
  std::optional<kinect3d::FloorCalibrationCheck> calibration_check_;
  std::optional<kinect3d::GravityCalibrationCheck> gravity_check_;
  std::uint64_t reported_reconnects_ = 0;
};

}  // namespace

FW_REGISTER_PLUGIN(Kinect3dPlugin, "kinect3d", "0.1.0")
