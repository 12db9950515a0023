#include "recorded_truth.h"

#include "framework_api/config.h"

namespace kinect3d {

RecordedTruth::RecordedTruth(const fw::RunInfo& run) {
  try {
    const fw::ConfigView root = fw::Config::parseDocument(run.config_yaml, "recorded configuration").root();
    const std::string source = root.child("kinect3d").getString("source");
    if (source.rfind("sim:", 0) != 0) return;
    scene_ = sim::loadScene(source.substr(4));
    if (scene_->ball) motion_.emplace(*scene_->ball, scene_->physics, scene_->duration_s, scene_->objects);
  } catch (const std::exception&) {
    scene_.reset();  // a log without a simulated source, or whose scene is gone: no truth to draw
  }
}

Eigen::Vector3d RecordedTruth::ball_R(double source_time_s) const {
  const double t = source_time_s - scene_->start_time_s;
  return scene_->robot.poseAt(t).T_F_R().inverse() * motion_->positionAt(t);
}

}  // namespace kinect3d
