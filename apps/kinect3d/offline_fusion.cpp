#include "offline_fusion.h"

#include <algorithm>

#include "cli_sources.h"
#include "fusion/json_lines.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"

namespace kinect3d {

FusionRun fuseFiles(const fw::Config& config, const std::string& depth_uri, const std::string& omni_file,
                    const std::string& pose_file) {
  const fw::ConfigView fusion_block = config.block("fusion");
  fusion::BallFusion fusion(fusion::readFusionConfig(fusion_block));
  const std::vector<fw::OmniFrame> omni = omni_file.empty()
                                              ? std::vector<fw::OmniFrame>{}
                                              : fusion::readOmniFile(omni_file, fusion_block.getString("omni.source"));
  const std::vector<fw::RobotPose> poses =
      pose_file.empty() ? std::vector<fw::RobotPose>{} : fusion::readPoseFile(pose_file);
  fw::PoseHistory pose_history;
  for (const fw::RobotPose& pose : poses) pose_history.add(pose);

  // Every input as an event on its source clock; at equal times poses go first, then the Kinect.
  struct Event {
    double t_s;
    int order;  // 0 pose, 1 Kinect, 2 omni
    std::size_t index;
  };
  std::vector<Event> events;
  for (std::size_t i = 0; i < poses.size(); ++i) events.push_back({poses[i].stamp.source_time_s, 0, i});
  for (std::size_t i = 0; i < omni.size(); ++i) events.push_back({omni[i].stamp.source_time_s, 2, i});

  std::vector<std::pair<double, std::vector<fw::BallObservation>>> kinect_frames;
  if (!depth_uri.empty()) {
    const fw::ConfigView kinect3d = config.block("kinect3d");
    BallDetector detector(readDetectorConfig(kinect3d), kinect3d.path());
    const auto source = cliSources().open(depth_uri);
    DepthFrame frame;
    Detections detections;
    for (ReadResult result; (result = source->read(frame)) != ReadResult::kEnd;) {
      if (result == ReadResult::kNoFrameYet) continue;
      const std::optional<Eigen::Isometry3d> T_F_R =
          poses.empty() ? std::nullopt : std::optional<Eigen::Isometry3d>(pose_history.at(frame.source_time_s).T_F_R());
      detector.detect(frame, detections, T_F_R);
      events.push_back({frame.source_time_s, 1, kinect_frames.size()});
      kinect_frames.emplace_back(frame.source_time_s, detections.balls);
    }
  }
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) {
    return a.t_s < b.t_s || (a.t_s == b.t_s && a.order < b.order);
  });

  FusionRun run;
  for (const Event& event : events) {
    if (event.order == 0) {
      fusion.addPose(poses[event.index]);
    } else if (event.order == 1) {
      const auto& [t_s, balls] = kinect_frames[event.index];
      run.updates.push_back(fusion.addKinectFrame(t_s, balls));
    } else {
      run.updates.push_back(fusion.addOmniFrame(omni[event.index].stamp.source_time_s, omni[event.index].balls));
    }
  }
  run.omni_latency_s = fusion.omniLatency_s();
  run.latency_examples = fusion.omniLatencyExamples();
  return run;
}

void writeFieldSensorFiles(const sim::Scene& scene, const sim::OmniCameraModel& omni_model,
                           const sim::LocalisationModel& localisation_model, const std::string& dir) {
  const sim::OmniCameraSimulator omni(scene, omni_model);
  std::vector<fw::OmniFrame> frames;
  for (int i = 0; i < omni.frameCount(); ++i) frames.push_back(omni.frame(i));
  fusion::writeOmniFile(dir + "/omni.jsonl", frames);
  const sim::LocalisationSimulator localisation(scene, localisation_model);
  std::vector<fw::RobotPose> poses;
  for (int i = 0; i < localisation.frameCount(); ++i) poses.push_back(localisation.pose(i));
  fusion::writePoseFile(dir + "/pose.jsonl", poses);
}

}  // namespace kinect3d
