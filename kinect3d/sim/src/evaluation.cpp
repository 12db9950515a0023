#include "kinect3d/sim/evaluation.h"

#include <algorithm>
#include <cmath>

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

double quantile(std::vector<double> values, double q) {
  if (values.empty()) return NAN;
  std::sort(values.begin(), values.end());
  return values[std::min(values.size() - 1, static_cast<std::size_t>(q * values.size()))];
}

void DetectionScore::add(const DetectionScore& other) {
  frames += other.frames;
  eligible += other.eligible;
  found += other.found;
  reported += other.reported;
  off_truth += other.off_truth;
  errors_m.insert(errors_m.end(), other.errors_m.begin(), other.errors_m.end());
}

}  // namespace kinect3d::sim
