#include "kinect3d/ball_detector.h"

#include <chrono>
#include <cmath>
#include <utility>

namespace kinect3d {

namespace {
using Clock = std::chrono::steady_clock;
double secondsBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

// The mask's early plausibility cut: a whole ball of radius r covers pi (f r / z)^2 pixels at
// range z, 1/stride^2 of them on the grid. A group needs half the share the refiner later demands
// of the full-resolution pixels (its voxels below the occupancy threshold are not counted).
BallCandidateFinder::Config maskConfig(const DetectorConfig& config, double focal_px) {
  BallCandidateFinder::Config mask = config.mask;
  const double stride = config.points.pixel_stride;
  mask.min_points_at_1m = 0.5 * config.ball.min_visible_fraction * M_PI *
                          std::pow(focal_px * config.ball.radius_m / stride, 2);
  return mask;
}
}  // namespace

const char* StageTimes::name(int stage) {
  static const char* const names[] = {"ground", "points", "grid", "candidates", "refine"};
  return stage >= 0 && stage < kCount ? names[stage] : "?";
}

double StageTimes::total() const {
  double sum = 0.0;
  for (const double s : seconds) sum += s;
  return sum;
}

BallDetector::BallDetector(const DetectorConfig& config)
    : config_(config), ground_(config.ground), projector_(config.points) {}

BallDetector::~BallDetector() = default;

void BallDetector::detect(const DepthFrame& frame, Detections& out) {
  out.balls.clear();
  out.times = StageTimes{};
  out.occupied_voxels = 0;
  out.candidates = 0;
  Clock::time_point t0 = Clock::now();

  T_R_S_ = ground_.update(frame);
  Clock::time_point t1 = Clock::now();
  out.times.seconds[StageTimes::kGround] = secondsBetween(t0, t1);
  out.aligned = T_R_S_.has_value();
  if (!T_R_S_) return;

  if (!grid_ || !(frame.intrinsics == projector_.intrinsics())) {
    projector_.setIntrinsics(frame.intrinsics);
    grid_ = std::make_unique<OccupancyGrid>(config_.grid, frame.intrinsics.fx, config_.points.pixel_stride);
    finder_ = std::make_unique<BallCandidateFinder>(maskConfig(config_, frame.intrinsics.fx));
    refiner_ = std::make_unique<BallRefiner>(config_.ball,
                                             DepthNoiseModel{frame.intrinsics.fx, config_.points.baseline_m});
  }
  const Eigen::Isometry3f T_R_S_f = T_R_S_->cast<float>();
  projector_.project(frame, T_R_S_f, points_);
  Clock::time_point t2 = Clock::now();
  out.times.seconds[StageTimes::kPoints] = secondsBetween(t1, t2);

  grid_->update(points_, T_R_S_f.translation());
  Clock::time_point t3 = Clock::now();
  out.times.seconds[StageTimes::kGrid] = secondsBetween(t2, t3);

  finder_->find(*grid_, candidates_);
  out.occupied_voxels = static_cast<int>(grid_->occupiedVoxels().size());
  out.candidates = static_cast<int>(candidates_.size());
  Clock::time_point t4 = Clock::now();
  out.times.seconds[StageTimes::kCandidates] = secondsBetween(t3, t4);

  const fw::Stamp stamp{frame.source_time_s, frame.receive_time_s};
  for (const BallCandidate& candidate : candidates_) {
    const std::optional<BallFit> fit = refiner_->refine(candidate, *grid_, frame, *T_R_S_, projector_);
    if (!fit) continue;
    fw::BallObservation ball =
        fw::BallObservation::inRobotFrame(fit->center_R, fit->covariance_m2, fit->state, "kinect3d", stamp);
    ball.support_points = fit->points;
    out.balls.push_back(ball);
  }
  // The paper looks for flying balls first: report those before balls on the ground. An
  // insertion pass keeps the order otherwise and, unlike std::stable_sort, allocates nothing.
  for (std::size_t i = 1; i < out.balls.size(); ++i) {
    for (std::size_t j = i; j > 0 && out.balls[j].state == fw::BallState::kAir &&
                            out.balls[j - 1].state != fw::BallState::kAir;
         --j) {
      std::swap(out.balls[j], out.balls[j - 1]);
    }
  }
  out.times.seconds[StageTimes::kRefine] = secondsBetween(t4, Clock::now());
}

}  // namespace kinect3d
