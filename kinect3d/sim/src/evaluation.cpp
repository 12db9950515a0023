#include "kinect3d/sim/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "kinect3d/depth_source.h"

namespace kinect3d::sim {

std::vector<EvaluatedFrame> runDetectorOnScene(const Scene& scene, const DetectorConfig& config) {
  KinectSimulator simulator(scene);
  BallDetector detector(config, "kinect3d");
  DepthFrame frame;
  Detections detections;
  std::vector<EvaluatedFrame> results(simulator.frameCount());
  for (int i = 0; i < simulator.frameCount(); ++i) {
    simulator.render(i, frame, results[i].truth);
    detector.detect(frame, detections);
    results[i].balls = detections.balls;
    results[i].process_s = detections.times.total();
  }
  return results;
}

bool shouldBeFound(const GroundTruth& truth, const Scene& scene, const EvaluationCriteria& criteria) {
  if (!truth.has_ball) return false;
  const double range = (truth.ball_center_R - scene.sensor_pose.T_R_S().translation()).norm();
  const double whole_ball_px = M_PI * std::pow(scene.intrinsics.fx * scene.physics.radius_m / range, 2);
  return range >= criteria.min_range_m && range <= criteria.max_range_m &&
         truth.visible_pixels >= criteria.min_visible_fraction * whole_ball_px &&
         truth.clearance_m >= criteria.min_clearance_m;
}

DetectionScore scoreFrames(const std::vector<EvaluatedFrame>& frames, const Scene& scene,
                           const EvaluationCriteria& criteria) {
  DetectionScore score;
  for (const EvaluatedFrame& f : frames) {
    ++score.frames;
    double nearest = INFINITY;
    for (const fw::BallObservation& ball : f.balls) {
      ++score.reported;
      const double error = f.truth.has_ball ? (ball.position_m - f.truth.ball_center_R).norm() : INFINITY;
      nearest = std::min(nearest, error);
      score.off_truth += error > criteria.match_m;
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
}

RealFramesResult detectOnDepthImages(const std::vector<std::string>& images, double cx, double cy,
                                     const DetectorConfig& config, int units_per_m) {
  std::string dir = (std::filesystem::temp_directory_path() / "kinect3d_real_frames_XXXXXX").string();
  if (mkdtemp(dir.data()) == nullptr) throw std::runtime_error("cannot create a folder like " + dir);
  std::ofstream list(dir + "/depth.txt");
  for (std::size_t i = 0; i < 2 * images.size(); ++i) list << i / 30.0 << " " << images[i % images.size()] << "\n";
  list.close();
  std::ofstream(dir + "/camera.yaml") << "width: 640\nheight: 480\nfx: 525\nfy: 525\ncx: " << cx << "\ncy: " << cy
                                      << "\ndepth_scale: " << units_per_m << "\n";
  RealFramesResult result;
  try {
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
  } catch (...) {
    std::filesystem::remove_all(dir);
    throw;
  }
  std::filesystem::remove_all(dir);
  return result;
}

}  // namespace kinect3d::sim
