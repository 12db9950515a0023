// fusion: the world's one ball (fw::FusedBall) from the Kinect's 3D balls, the omni camera's balls
// and the robot's pose in the world state, by the same BallFusion that `kinect3d fuse` runs offline.
// Each step takes what arrived since the last one, oldest first; the fusion itself puts late
// measurements back in order.
#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "fusion/ball_fusion.h"

namespace {

// What arrived after `after_s` (source time), grouped into frames by stamp, oldest first.
template <typename Observation>
std::map<double, std::vector<Observation>> framesAfter(const std::vector<Observation>& newest_first, double after_s) {
  std::map<double, std::vector<Observation>> frames;
  for (const Observation& observation : newest_first) {
    if (observation.stamp.source_time_s > after_s) frames[observation.stamp.source_time_s].push_back(observation);
  }
  return frames;
}

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

    std::vector<fw::RobotPose> poses = world_.recentRobotPoses();
    std::reverse(poses.begin(), poses.end());
    for (const fw::RobotPose& pose : poses) {
      if (pose.stamp.source_time_s <= last_pose_s_) continue;
      fusion_.addPose(pose);
      last_pose_s_ = pose.stamp.source_time_s;
    }
    // Both sources' new frames in stamp order (roughly: each source's own clock).
    bool updated = false;
    for (const auto& [t, balls] : framesAfter(world_.recentBalls(config_.kinect.source), last_kinect_s_)) {
      fusion_.addKinectFrame(t, balls);
      last_kinect_s_ = t;
      updated = true;
    }
    for (const auto& [t, balls] : framesAfter(world_.recentOmniBalls(config_.omni.source), last_omni_s_)) {
      fusion_.addOmniFrame(t, balls);
      last_omni_s_ = t;
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
    return fw::StepResult::kProcessed;
  }

 private:
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
  std::uint64_t seen_version_ = 0;
  double last_pose_s_ = -1.0, last_kinect_s_ = -1.0, last_omni_s_ = -1.0;
  bool latency_reported_ = false;
};

}  // namespace

FW_REGISTER_PLUGIN(FusionPlugin, "fusion", "0.1.0")
