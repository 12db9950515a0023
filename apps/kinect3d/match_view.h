// What `kinect3d view` shows, read from a match log: the run with its timelines (one JSON for the
// page's charts and slider), and for any depth frame the 3D scene of that moment (decimated depth
// points, the occupied voxels and each candidate's core and mask, every source's balls, the
// trajectory with its touchdown and crossing, the truth) and the depth image with the detections
// drawn on it. Everything 3D is in the robot frame of that moment, as the robot saw it.
//
// The voxels and masks are not in the log: the frame's depth is run through the detector again with
// the recorded configuration (the same grid and mask the robot used; the scene map, which needs the
// frames before, is not involved). A log that is still being written (the live view) is followed as
// it grows: only what was logged since the last look is read, so a poll costs what is new, not the
// whole match.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>

#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "kinect3d/ball_detector.h"
#include "matchlog/match_log.h"
#include "recorded_truth.h"

namespace kinect3d {

class MatchView {
 public:
  // Throws fw::MatchLogError naming the log when it cannot be read, fw::ConfigError when its recorded
  // configuration cannot.
  explicit MatchView(const std::string& log_folder);
  ~MatchView();

  // The run: who and when, the depth frames' times (the slider's steps), the sensor's range, and the
  // timelines (ball height per source and the truth, each source's distance to the fused ball,
  // processing time and dropped frames per plugin, events). Reads the log again if it grew.
  nlohmann::json run();
  // Depth frame `frame` (0-based, in the order of run()'s frames) as a 3D scene; nothing when there
  // is no such frame.
  std::optional<nlohmann::json> frame(std::size_t frame);
  // Its depth image, coloured by range, with every ball the robot saw then drawn on it (PNG).
  std::optional<std::string> depthPng(std::size_t frame);
  // Its colour image with the same balls drawn (PNG); nothing when it has none.
  std::optional<std::string> colourPng(std::size_t frame);

 private:
  struct Published;
  struct Timelines;
  std::uintmax_t logBytes() const;  // the database and its write-ahead log
  void reloadIfGrown();
  void index();  // reads what was logged since the last call
  DepthFrame depthFrame(std::size_t frame) const;
  // The balls the robot saw at the depth frame's time, drawn into an image of `camera`, whose
  // origin is at camera_in_S_m in the depth camera's optical frame.
  void drawSeenBalls(cv::Mat& image, const DepthFrame& depth, const Intrinsics& camera,
                     const Eigen::Vector3d& camera_in_S_m);

  std::string folder_;
  std::unique_ptr<fw::MatchLogReader> log_;
  std::unique_ptr<RecordedTruth> truth_;
  DetectorConfig detector_config_;
  std::unique_ptr<BallDetector> detector_;
  std::string depth_source_;
  std::vector<fw::MatchLogReader::DepthFrameStamp> frames_;
  double t0_ = 0.0;                // the first depth frame's source time: the page's zero
  double wall_to_source_s_ = 0.0;  // the depth sensor's clock minus the host's
  std::unique_ptr<Published> published_;
  std::unique_ptr<Timelines> timelines_;
  std::int64_t last_seq_ = 0;  // the log read up to here
  nlohmann::json run_;
  std::uintmax_t log_bytes_ = 0;
  std::mutex mutex_;  // the HTTP server asks from several threads
};

}  // namespace kinect3d
