#include "kinect3d/sim/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "kinect3d/ball_colour_calibration.h"
#include "kinect3d/depth_source.h"
#include "kinect3d/sim/calibration_scene.h"

namespace kinect3d::sim {

namespace {
// A fresh folder under the system's temporary one, removed with everything in it at scope exit.
struct TemporaryFolder {
  explicit TemporaryFolder(const std::string& prefix)
      : path((std::filesystem::temp_directory_path() / (prefix + "_XXXXXX")).string()) {
    if (mkdtemp(path.data()) == nullptr) throw std::runtime_error("cannot create a folder like " + path);
  }
  ~TemporaryFolder() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
  std::string path;
};
}  // namespace

std::vector<EvaluatedFrame> runDetectorOnScene(const Scene& scene, const DetectorConfig& config) {
  KinectSimulator simulator(scene);
  simulator.setColour(config.colour.mode != ColourCheckConfig::Mode::kOff);
  BallDetector detector(config, "kinect3d");
  DepthFrame frame;
  Detections detections;
  std::vector<EvaluatedFrame> results(simulator.frameCount());
  for (int i = 0; i < simulator.frameCount(); ++i) {
    simulator.render(i, frame, results[i].truth);
    detector.detect(frame, detections);
    results[i].balls = detections.balls;
    results[i].process_s = detections.times.total();
    results[i].colour_s = detections.times.seconds[StageTimes::kColour];
  }
  return results;
}

std::vector<EvaluatedFrame> followedOnly(std::vector<EvaluatedFrame> frames) {
  for (EvaluatedFrame& f : frames) {
    f.balls.erase(
        std::remove_if(f.balls.begin(), f.balls.end(), [](const fw::BallObservation& b) { return !b.followed(); }),
        f.balls.end());
  }
  return frames;
}

BallColourFit learnBallColourInSession(const CalibrationSession& session, const DetectorConfig& config) {
  const TemporaryFolder dir("kinect3d_ball_colour");
  writeCalibrationSession(session, dir.path);
  DetectorConfig detector = config;
  detector.ground.pose = session.pose;
  SourceOptions options;
  options.colour = true;
  const auto source = DepthSourceTable::core().open("tum:" + dir.path, options);
  return calibrateBallColour(*source, detector);
}

bool shouldBeFound(const GroundTruth& truth, const Scene& scene, const EvaluationCriteria& criteria) {
  if (!truth.has_ball) return false;
  const Eigen::Vector3d centre_S = scene.sensorPoseAt(truth.time_s).T_R_S().inverse() * truth.ball_center_R;
  const double range = centre_S.norm();
  const double radius_px = scene.intrinsics.fx * scene.physics.radius_m / range;
  const double whole_ball_px = M_PI * radius_px * radius_px;
  const Eigen::Vector2d centre_px = scene.intrinsics.project(centre_S);
  const double inside_px = criteria.min_centre_inside_r * radius_px;
  const bool centre_inside = centre_S.z() > 0.0 && centre_px.x() >= inside_px &&
                             centre_px.x() <= scene.intrinsics.width - 1 - inside_px && centre_px.y() >= inside_px &&
                             centre_px.y() <= scene.intrinsics.height - 1 - inside_px;
  return range >= criteria.min_range_m && range <= criteria.max_range_m && centre_inside &&
         truth.visible_pixels >= criteria.min_visible_fraction * whole_ball_px &&
         truth.clearance_m >= criteria.min_clearance_m;
}

DetectionScore scoreFrames(const std::vector<EvaluatedFrame>& frames, const Scene& scene,
                           const EvaluationCriteria& criteria) {
  DetectionScore score;
  for (const EvaluatedFrame& f : frames) {
    ++score.frames;
    double nearest = INFINITY;
    const Eigen::Vector3d sensor_R = scene.sensorPoseAt(f.truth.time_s).T_R_S().translation();
    for (const fw::BallObservation& ball : f.balls) {
      ++score.reported;
      const double error = f.truth.has_ball ? (ball.position_m - f.truth.ball_center_R).norm() : INFINITY;
      nearest = std::min(nearest, error);
      if (error > criteria.match_m) {
        ++score.off_truth;
        score.off_truth_ranges_m.push_back((ball.position_m - sensor_R).norm());
      }
    }
    if (!shouldBeFound(f.truth, scene, criteria)) continue;
    ++score.eligible;
    if (nearest <= criteria.match_m) {
      ++score.found;
      score.errors_m.push_back(nearest);
    }
  }
  return score;
}

void DetectionScore::add(const DetectionScore& other) {
  frames += other.frames;
  eligible += other.eligible;
  found += other.found;
  reported += other.reported;
  off_truth += other.off_truth;
  errors_m.insert(errors_m.end(), other.errors_m.begin(), other.errors_m.end());
  off_truth_ranges_m.insert(off_truth_ranges_m.end(), other.off_truth_ranges_m.begin(), other.off_truth_ranges_m.end());
}

RealFramesResult detectOnDepthImages(const std::vector<std::string>& images, double cx, double cy,
                                     const DetectorConfig& config, int units_per_m) {
  const TemporaryFolder folder("kinect3d_real_frames");
  const std::string& dir = folder.path;
  std::ofstream list(dir + "/depth.txt");
  for (std::size_t i = 0; i < 2 * images.size(); ++i) list << i / 30.0 << " " << images[i % images.size()] << "\n";
  list.close();
  std::ofstream(dir + "/camera.yaml") << "width: 640\nheight: 480\nfx: 525\nfy: 525\ncx: " << cx << "\ncy: " << cy
                                      << "\ndepth_scale: " << units_per_m << "\n";
  RealFramesResult result;
  auto source = DepthSourceTable::core().open("tum:" + dir);
  BallDetector detector(config, "kinect3d");
  Detections detections;
  DepthFrame frame;
  while (source->read(frame) == ReadResult::kFrame) {
    detector.detect(frame, detections);
    result.balls += static_cast<int>(detections.balls.size());
    result.aligned = detections.aligned;
    ++result.frames;
  }
  return result;
}

RealColourCheck checkEverywhere(const std::string& depth_image, const std::string& colour_image, double cx, double cy,
                                const BallColourModel& model, double radius_m) {
  const cv::Mat depth = cv::imread(depth_image, cv::IMREAD_ANYDEPTH);
  const cv::Mat bgr = cv::imread(colour_image, cv::IMREAD_COLOR);
  if (depth.empty() || depth.type() != CV_16U) throw std::runtime_error(depth_image + ": not a 16-bit depth image");
  if (bgr.empty() || bgr.size() != depth.size()) {
    throw std::runtime_error(colour_image + ": not a colour image of the depth image's size");
  }
  constexpr double kFocal_px = 525.0;
  DepthFrame frame;
  frame.resize(Intrinsics{depth.cols, depth.rows, kFocal_px, kFocal_px, cx, cy});
  std::copy(depth.begin<std::uint16_t>(), depth.end<std::uint16_t>(), frame.depth_mm.begin());
  fw::ColourImage image;
  image.width = bgr.cols;
  image.height = bgr.rows;
  image.fx = image.fy = kFocal_px;
  image.cx = cx;
  image.cy = cy;
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  image.rgb.assign(rgb.data, rgb.data + rgb.total() * 3);
  ColourCheckConfig config;
  config.mode = ColourCheckConfig::Mode::kOn;
  config.ball_colours = model;
  const ColourCheck check(config);
  frame.colour = std::move(image);
  RealColourCheck result;
  for (int v = 8; v < depth.rows; v += 16) {
    for (int u = 8; u < depth.cols; u += 16) {
      const double z = depth.at<std::uint16_t>(v, u) * 1e-3;
      if (z <= 0.0) continue;
      const Eigen::Vector3d surface((u - cx) / kFocal_px * z, (v - cy) / kFocal_px * z, z);
      const ColourEvidence evidence = check.check(frame, surface * (1.0 + radius_m / surface.norm()), radius_m);
      ++result.places;
      result.confirmed += evidence.verdict == fw::ColourVerdict::kConfirmed;
      result.no_evidence += evidence.verdict == fw::ColourVerdict::kNoEvidence;
      result.rejected += evidence.verdict == fw::ColourVerdict::kRejected;
    }
  }
  return result;
}

}  // namespace kinect3d::sim
