#include "match_tools.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <optional>

#include "detect_line.h"
#include "framework_api/config.h"
#include "framework_api/log.h"
#include "fusion/ball_fusion.h"
#include "fusion/json_lines.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/match_log.h"
#include "kinect3d/sim/sequence_writer.h"
#include "kinect3d/trajectory.h"

namespace kinect3d {

namespace {

namespace fs = std::filesystem;

DepthFrame toDepthFrame(const fw::DepthImage& image, const std::string& sensor_id) {
  DepthFrame frame;
  frame.resize({image.width, image.height, image.fx, image.fy, image.cx, image.cy});
  frame.depth_mm = image.depth_mm;
  frame.source_time_s = image.stamp.source_time_s;
  frame.receive_time_s = image.stamp.receive_time_s;
  frame.index = image.index;
  frame.sensor_id = sensor_id;
  return frame;
}

// The log's first depth plugin: the one whose frames are replayed or exported.
std::string depthSource(const MatchLogReader& log) {
  const auto sources = log.depthSources();
  if (sources.empty()) throw MatchLogError(log.folder() + ": the match log holds no depth frames");
  return sources.front().first;
}

// Visits the logged entries and the depth frames of one source together, in the order they were
// logged (by the host's wall clock; a depth frame before anything logged at the same moment).
template <typename OnEntry, typename OnDepth>
void inLoggedOrder(const MatchLogReader& log, const std::string& depth_source, OnEntry on_entry, OnDepth on_depth) {
  const std::vector<fw::JournalEntry> entries = log.entries();
  MatchLogReader::DepthFrames frames(log, depth_source);
  fw::DepthImage image;
  double depth_wall_s = 0.0;
  bool has_depth = frames.next(image, depth_wall_s);
  for (const fw::JournalEntry& entry : entries) {
    while (has_depth && depth_wall_s <= entry.wall_time_s) {
      on_depth(image, depth_wall_s);
      has_depth = frames.next(image, depth_wall_s);
    }
    on_entry(entry);
  }
  while (has_depth) {
    on_depth(image, depth_wall_s);
    has_depth = frames.next(image, depth_wall_s);
  }
}

bool listsPlugin(const fw::Config& config, const std::string& name) {
  const std::vector<std::string> plugins = config.block("host").getStringList("plugins");
  return std::find(plugins.begin(), plugins.end(), name) != plugins.end();
}

}  // namespace

void replayMatch(const std::string& log_folder, const std::string& defaults_dir, const std::string& robot_file,
                 const std::vector<std::string>& overrides, const std::string& output) {
  const MatchLogReader log(log_folder);
  if (fs::exists(fs::path(output) / kMatchLogFile)) {
    throw MatchLogError(output + ": holds a match log already; replay into a new folder");
  }
  std::string robot = robot_file;
  if (robot.empty()) {
    fs::create_directories(output);
    robot = (fs::path(output) / "recorded_config.yaml").string();
    std::ofstream file(robot);
    file << "# The configuration recorded in " << log_folder << " (the run being replayed).\n" << log.run().config_yaml;
    if (!file.flush()) throw std::runtime_error("cannot write '" + robot + "'");
  }
  const fw::Config config = fw::Config::load(defaults_dir, robot, overrides);
  const std::string source = depthSource(log);
  const fw::ConfigView kinect_block = config.block(source);
  BallDetector detector(readDetectorConfig(kinect_block), source);
  const auto trajectory = makeTrajectoryEstimator(readTrajectoryConfig(kinect_block));
  std::optional<fusion::BallFusion> fusion;
  if (listsPlugin(config, "fusion")) fusion.emplace(fusion::readFusionConfig(config.block("fusion")));

  RunInfo run = log.run();
  run.config_yaml = config.toYaml();
  run.replayed_from = log_folder;
  MatchLogWriter writer(output, run);

  // What the plugins would publish, stamped with the moment the robot received the input.
  std::optional<fw::RobotPose> pose;
  bool has_trajectory = false, has_fused = false, aligned = false;
  std::uint64_t frames = 0, with_ball = 0;
  const auto publishFused = [&](const fusion::FusionUpdate& update, double wall_s) {
    if (update.ball) {
      fw::FusedBall ball = *update.ball;
      ball.stamp.receive_time_s = wall_s;
      writer.write({wall_s, ball});
      has_fused = true;
    } else if (has_fused) {
      writer.write({wall_s, fw::FusedBallCleared{}});
      has_fused = false;
    }
  };
  Detections detections;
  inLoggedOrder(
      log, source,
      [&](const fw::JournalEntry& entry) {
        if (const auto* p = std::get_if<fw::RobotPose>(&entry.item)) {
          writer.write(entry);
          pose = *p;
          if (fusion) fusion->addPose(*p);
        } else if (const auto* omni = std::get_if<fw::OmniFrame>(&entry.item)) {
          writer.write(entry);
          if (fusion) publishFused(fusion->addOmniFrame(omni->stamp.source_time_s, omni->balls), entry.wall_time_s);
        }
      },
      [&](const fw::DepthImage& image, double wall_s) {
        writer.write({wall_s, image});
        const DepthFrame frame = toDepthFrame(image, "log:" + log_folder);
        detector.detect(frame, detections, pose ? std::optional<Eigen::Isometry3d>(pose->T_F_R()) : std::nullopt);
        const fw::Stamp stamp{frame.source_time_s, frame.receive_time_s};
        if (detections.aligned && !aligned) {
          aligned = true;
          writer.write({wall_s, fw::Event{source, "floor_found", "sensor aligned with the floor; detecting", stamp}});
        }
        if (!detections.balls.empty()) writer.write({wall_s, fw::BallFrame{stamp, detections.balls}});
        if (const auto fit = trajectory->update(frame.source_time_s, detections.balls)) {
          writer.write({wall_s, *fit});
          has_trajectory = true;
        } else if (has_trajectory) {
          writer.write({wall_s, fw::TrajectoryCleared{source}});
          has_trajectory = false;
        }
        if (fusion) publishFused(fusion->addKinectFrame(frame.source_time_s, detections.balls), wall_s);
        ++frames;
        with_ball += !detections.balls.empty();
      });
  writer.commit();
  fw::logInfo("replay", log_folder + " -> " + output + ": " + std::to_string(frames) + " depth frames, ball in " +
                            std::to_string(with_ball));
}

void exportMatch(const std::string& log_folder, const ExportFiles& files) {
  const MatchLogReader log(log_folder);
  for (const std::string& file : {files.omni, files.pose, files.detections}) {
    if (!file.empty() && fs::path(file).has_parent_path()) fs::create_directories(fs::path(file).parent_path());
  }
  std::vector<fw::OmniFrame> omni;
  std::vector<fw::RobotPose> poses;
  for (const fw::JournalEntry& entry : log.entries()) {
    if (const auto* frame = std::get_if<fw::OmniFrame>(&entry.item)) omni.push_back(*frame);
    if (const auto* pose = std::get_if<fw::RobotPose>(&entry.item)) poses.push_back(*pose);
  }
  if (!files.omni.empty()) fusion::writeOmniFile(files.omni, omni);
  if (!files.pose.empty()) fusion::writePoseFile(files.pose, poses);
  if (files.detections.empty() && files.tum.empty()) return;

  const std::string source = depthSource(log);
  std::ofstream detections;
  if (!files.detections.empty()) {
    detections.open(files.detections);
    if (!detections) throw std::runtime_error("cannot write '" + files.detections + "'");
  }
  std::optional<sim::TumSequenceWriter> tum;
  if (!files.tum.empty()) tum.emplace(files.tum);
  // A frame's line is complete when the next frame arrives: its balls and trajectory follow it.
  struct Pending {
    std::uint64_t index;
    double t_s;
    std::vector<fw::BallObservation> balls;
    std::optional<fw::BallTrajectory> trajectory;
  };
  std::optional<Pending> pending;
  const auto flush = [&] {
    if (!pending || files.detections.empty()) return;
    detections << detectLine(pending->index, pending->t_s, pending->balls, std::nullopt, pending->trajectory) << "\n";
    if (!detections) throw std::runtime_error("cannot write '" + files.detections + "'");
  };
  inLoggedOrder(
      log, source,
      [&](const fw::JournalEntry& entry) {
        if (!pending) return;
        if (const auto* frame = std::get_if<fw::BallFrame>(&entry.item)) {
          if (!frame->balls.empty() && frame->balls.front().source == source) pending->balls = frame->balls;
        } else if (const auto* fit = std::get_if<fw::BallTrajectory>(&entry.item)) {
          if (fit->source == source) pending->trajectory = *fit;
        } else if (const auto* lost = std::get_if<fw::TrajectoryCleared>(&entry.item)) {
          if (lost->source == source) pending->trajectory.reset();
        }
      },
      [&](const fw::DepthImage& image, double) {
        flush();
        // The trajectory stands until the source withdraws it.
        pending = Pending{image.index, image.stamp.source_time_s, {}, pending ? pending->trajectory : std::nullopt};
        if (tum) tum->write(toDepthFrame(image, "log:" + log_folder));
      });
  flush();
  fw::logInfo("export", log_folder + ": " + std::to_string(omni.size()) + " omni images, " +
                            std::to_string(poses.size()) + " poses" +
                            (files.detections.empty() && files.tum.empty() ? "" : ", the depth of '" + source + "'"));
}

}  // namespace kinect3d
