#include "kinect3d/ball_detector.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

namespace kinect3d {

namespace {
using Clock = std::chrono::steady_clock;
double secondsBetween(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

// The mask's early plausibility cut: a whole ball of radius r covers pi (f r / z)^2 pixels at
// range z, 1/stride^2 of them on the grid. A group needs half the share the refiner later demands
// of the full-resolution pixels (its voxels below the occupancy threshold are not counted).
double minGroupPointsAt1m(const DetectorConfig& config, double focal_px) {
  const double stride = config.points.pixel_stride;
  return 0.5 * config.ball.min_visible_fraction * M_PI * std::pow(focal_px * config.ball.radius_m / stride, 2);
}

// A ball seen twice moved at most this fast in between (MSL shots reach 12-15 m/s), give or take
// its fit's spread at range. A sight confirms one at most kMaxSightGap_s later: one frame missed at
// 30 Hz is bridged (a dark panel, another Kinect's pattern), two are not.
constexpr double kMaxBallSpeed_mps = 20.0;
constexpr double kSightSpread_m = 0.3;
constexpr double kMaxSightGap_s = 0.07;
}  // namespace

const char* StageTimes::name(int stage) {
  static const char* const names[] = {"ground", "points", "grid", "candidates", "refine", "colour", "map"};
  return stage >= 0 && stage < kCount ? names[stage] : "?";
}

double StageTimes::total() const {
  double sum = 0.0;
  for (const double s : seconds) sum += s;
  return sum;
}

BallDetector::BallDetector(const DetectorConfig& config, std::string source)
    : config_(config), source_(std::move(source)), ground_(config.ground), colour_check_(config.colour) {}

BallDetector::~BallDetector() = default;

void BallDetector::detect(const DepthFrame& frame, Detections& out, const std::optional<Eigen::Isometry3d>& T_F_R) {
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

  if (!projector_ || !(frame.intrinsics == projector_->intrinsics())) {
    // Everything that depends on the camera is made for it; a new camera (or a resolution change)
    // starts these stages afresh.
    projector_ = std::make_unique<PointProjector>(config_.points, frame.intrinsics);
    grid_ = std::make_unique<OccupancyGrid>(config_.grid, frame.intrinsics.fx, config_.points.pixel_stride,
                                            config_.points.max_range_m);
    finder_ = std::make_unique<BallCandidateFinder>(config_.mask, minGroupPointsAt1m(config_, frame.intrinsics.fx));
    shell_evidence_ = std::make_unique<ShellEvidence>(
        frame.intrinsics, (config_.mask.mask_voxels - config_.mask.core_voxels) / 2, config_.points);
    refiner_ =
        std::make_unique<BallRefiner>(config_.ball, DepthNoiseModel{frame.intrinsics.fx, config_.points.baseline_m});
  }
  if (!map_) map_ = std::make_unique<SceneMap>(config_.map, config_.points.min_range_m, config_.points.max_range_m);
  if (T_F_R.has_value() != map_in_field_) {
    map_->clear();  // what it and the last sights hold is in the other frame
    recent_sights_.clear();
    map_in_field_ = T_F_R.has_value();
  }
  const Eigen::Isometry3d T_M_R = T_F_R.value_or(Eigen::Isometry3d::Identity());
  const Eigen::Isometry3f T_R_S_f = T_R_S_->cast<float>();
  projector_->project(frame, T_R_S_f, points_);
  // After the projection, which reads every row of the frame from memory: the coverage then finds
  // its samples in the cache (the points stage a tenth faster than the other way round).
  coverage_.update(frame);
  Clock::time_point t2 = Clock::now();
  out.times.seconds[StageTimes::kPoints] = secondsBetween(t1, t2);

  grid_->update(points_, T_R_S_f.translation());
  Clock::time_point t3 = Clock::now();
  out.times.seconds[StageTimes::kGrid] = secondsBetween(t2, t3);

  finder_->find(*grid_, candidates_);
  const Eigen::Isometry3f T_S_R = T_R_S_f.inverse();
  candidates_.erase(std::remove_if(candidates_.begin(), candidates_.end(),
                                   [&](const BallCandidate& candidate) {
                                     return !shell_evidence_->shellObserved(candidate, *grid_, frame, coverage_, T_S_R);
                                   }),
                    candidates_.end());
  out.occupied_voxels = static_cast<int>(grid_->occupiedVoxels().size());
  out.candidates = static_cast<int>(candidates_.size());
  Clock::time_point t4 = Clock::now();
  out.times.seconds[StageTimes::kCandidates] = secondsBetween(t3, t4);

  const fw::Stamp stamp{frame.source_time_s, frame.receive_time_s};
  for (const BallCandidate& candidate : candidates_) {
    const std::optional<BallFit> fit = refiner_->refine(candidate, *grid_, frame, coverage_, *T_R_S_, *projector_);
    if (!fit) continue;
    fw::BallObservation ball =
        fw::BallObservation::inRobotFrame(fit->center_R, fit->covariance_m2, fit->state, source_, stamp);
    ball.support_points = fit->points;
    ball.is_static = insideStaticSpace(candidate, T_M_R);
    out.balls.push_back(ball);
  }
  Clock::time_point t5 = Clock::now();

  if (config_.colour.mode != ColourCheckConfig::Mode::kOff) {
    const Eigen::Isometry3d T_S_R_d = T_R_S_->inverse();
    for (fw::BallObservation& ball : out.balls) {
      const ColourEvidence evidence = colour_check_.check(frame, T_S_R_d * ball.position_m, config_.ball.radius_m);
      ball.colour = evidence.verdict;
      ball.colour_note = evidence.note;
      ball.colour_score = evidence.score;
    }
  }
  Clock::time_point t6 = Clock::now();
  out.times.seconds[StageTimes::kColour] = secondsBetween(t5, t6);

  keepSecondSights(out.balls, T_M_R, frame.source_time_s);
  // The paper looks for flying balls first: report those before balls on the ground. An
  // insertion pass keeps the order otherwise and, unlike std::stable_sort, allocates nothing.
  for (std::size_t i = 1; i < out.balls.size(); ++i) {
    for (std::size_t j = i;
         j > 0 && out.balls[j].state == fw::BallState::kAir && out.balls[j - 1].state != fw::BallState::kAir; --j) {
      std::swap(out.balls[j], out.balls[j - 1]);
    }
  }
  Clock::time_point t7 = Clock::now();
  // Refining the candidates, and choosing which balls to report (after the colour verdict, which
  // the second sight reads).
  out.times.seconds[StageTimes::kRefine] = secondsBetween(t4, t5) + secondsBetween(t6, t7);

  map_->update(frame, T_M_R * *T_R_S_, frame.source_time_s);
  out.times.seconds[StageTimes::kMap] = secondsBetween(t7, Clock::now());
}

void BallDetector::keepSecondSights(std::vector<fw::BallObservation>& balls, const Eigen::Isometry3d& T_M_R,
                                    double time_s) {
  // Sights from later frames (a recording played again) or too long ago cannot confirm this one.
  recent_sights_.erase(std::remove_if(recent_sights_.begin(), recent_sights_.end(),
                                      [&](const Sight& sight) {
                                        return !(sight.time_s < time_s && time_s - sight.time_s <= kMaxSightGap_s);
                                      }),
                       recent_sights_.end());
  const std::size_t earlier = recent_sights_.size();
  for (const fw::BallObservation& ball : balls) recent_sights_.push_back({time_s, T_M_R * ball.position_m});
  std::size_t kept = 0;
  for (std::size_t i = 0; i < balls.size(); ++i) {
    const Eigen::Vector3d& position_M = recent_sights_[earlier + i].position_M;
    const bool near = (balls[i].position_m - T_R_S_->translation()).norm() < config_.second_sight_beyond_m;
    // The colour image tells a ball from a hand in one frame: it has confirmed none of the phantoms
    // it judged (docs/accuracy.md, "The colour check").
    const bool confirmed_by_colour = balls[i].colour == fw::ColourVerdict::kConfirmed;
    const bool seen_before =
        std::any_of(recent_sights_.begin(), recent_sights_.begin() + earlier, [&](const Sight& sight) {
          return (sight.position_M - position_M).norm() <= kMaxBallSpeed_mps * (time_s - sight.time_s) + kSightSpread_m;
        });
    if (!near && !confirmed_by_colour && !seen_before) continue;
    if (kept != i) balls[kept] = std::move(balls[i]);
    ++kept;
  }
  balls.resize(kept);
}

bool BallDetector::insideStaticSpace(const BallCandidate& candidate, const Eigen::Isometry3d& T_M_R) const {
  int occupied = 0, in_static_space = 0;
  for (int z = candidate.min[2]; z <= candidate.max[2]; ++z) {
    for (int y = candidate.min[1]; y <= candidate.max[1]; ++y) {
      for (int x = candidate.min[0]; x <= candidate.max[0]; ++x) {
        if (!grid_->occupied({x, y, z})) continue;
        ++occupied;
        const Eigen::Vector3d centre_R = grid_->centerOf({x, y, z}).cast<double>();
        in_static_space += map_->stateAt(T_M_R * centre_R) == SceneMap::VoxelState::kStatic;
      }
    }
  }
  return occupied > 0 && 2 * in_static_space >= occupied;
}

}  // namespace kinect3d
