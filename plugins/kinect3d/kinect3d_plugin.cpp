// kinect3d: reads depth frames from the configured source, detects balls and publishes them to
// the world state as observations in the robot frame with covariances from the depth noise model,
// and the ball's trajectory (touchdown, crossing of the robot's line) while it has one.
#include <memory>

#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/depth_source.h"
#include "kinect3d/sim/sim_sources.h"
#include "kinect3d/trajectory.h"

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
    const std::string uri = context.config.getString("source");
    try {
      source_ = kinect3d::sim::sourcesWithSimulator().open(uri, options);
    } catch (const kinect3d::DepthSourceError& e) {
      throw fw::ConfigError(context.config.originOf("source") + ": kinect3d.source: " + e.what());
    }
    fw::logInfo(source_name_, "reading " + source_->describe());
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
    // With a pose from localisation the scene map is kept in the field frame.
    const std::optional<fw::RobotPose> pose = world_.robotPose();
    detector_.detect(frame_, detections_, pose ? std::optional<Eigen::Isometry3d>(pose->T_F_R()) : std::nullopt);
    if (detections_.aligned && !reported_alignment_) {
      fw::logInfo(source_name_, "sensor aligned with the floor; detecting");
      reported_alignment_ = true;
    }
    if (!detections_.balls.empty()) world_.publishBalls(detections_.balls);
    if (const auto trajectory = trajectory_->update(frame_.source_time_s, detections_.balls)) {
      world_.publishTrajectory(*trajectory);
    } else {
      world_.clearTrajectory(source_name_);
    }
    return fw::StepResult::kProcessed;
  }

 private:
  fw::WorldState& world_;
  const std::string source_name_;  // this plugin's block name: what its observations carry
  kinect3d::BallDetector detector_;
  std::unique_ptr<kinect3d::TrajectoryEstimator> trajectory_;
  std::unique_ptr<kinect3d::DepthSource> source_;
  kinect3d::DepthFrame frame_;
  kinect3d::Detections detections_;
  bool reported_alignment_ = false;
};

}  // namespace

FW_REGISTER_PLUGIN(Kinect3dPlugin, "kinect3d", "0.1.0")
