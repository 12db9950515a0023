#include "fusion/alignment_check.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "fusion/measurements.h"

namespace fusion {

namespace {
// Kinect frames kept for omni images that arrive late.
constexpr double kKinectHistory_s = 1.0;
// The Kinect's ball at an omni image's time: a straight line fitted to its frames within this time
// either side (a difference of two frames 33 ms apart would make the velocity as noisy as 1 m/s),
// from at least this many frames on each side, none without the ball and none farther than this
// off the line (a kick or a bounce in between).
constexpr double kLineHalfSpan_s = 0.1;
constexpr int kMinFramesEachSide = 2;
constexpr double kMaxLineResidual_m = 0.15;
// An omni ball farther than this from the Kinect's is another object (a Kinect turned by 10 degrees
// moves a ball 5 m away by 0.9 m); two omni balls within it make the pair ambiguous.
constexpr double kPairGate_m = 1.0;
// Pairs this far off the first fit (Mahalanobis) are misassociations and the fit is done again.
constexpr double kFitGate_sigma = 4.0;
// What a knock does to a sensor: it turns on its mount far more readily than the mount moves. With
// balls in one part of the view a turn and a sideways shift look alike, and these priors read it as
// the turn; balls across the view tell the two apart whatever the priors say.
constexpr double kTurnPrior_rad = 10.0 * M_PI / 180.0;
constexpr double kShiftPrior_m = 0.05;
// The omni's time offset is never known better than its exposure.
constexpr double kMinTimingSigma_s = 0.005;
// A fit shows a moved sensor only when its correction is this many sigma away from none.
constexpr double kSignificance_sigma = 3.0;

Eigen::Matrix2d turn(double yaw_rad) { return Eigen::Rotation2Dd(yaw_rad).toRotationMatrix(); }
}  // namespace

AlignmentCheck::AlignmentCheck(const FusionConfig& config, const Eigen::Vector2d& kinect_xy_R)
    : config_(config), kinect_xy_R_(kinect_xy_R) {}

void AlignmentCheck::addKinectFrame(double stamp_s, const std::vector<fw::BallObservation>& balls_R) {
  const double t_s = stamp_s - config_.kinect.latency_s;
  switch (kinect_time_line_.next(t_s)) {
    case fw::TimeLine::Step::kNotFinite:
      return;
    case fw::TimeLine::Step::kJump:  // the frames and images held belong to the old time line
      kinect_.clear();
      waiting_.clear();
      break;
    default:
      break;
  }
  KinectFrame frame{t_s, std::nullopt};
  if (balls_R.size() == 1 && balls_R.front().state == fw::BallState::kGround) frame.ball = balls_R.front();
  const auto later =
      std::upper_bound(kinect_.begin(), kinect_.end(), t_s, [](double t, const KinectFrame& f) { return t < f.t_s; });
  kinect_.insert(later, std::move(frame));
  while (kinect_.front().t_s < kinect_.back().t_s - kKinectHistory_s) kinect_.pop_front();
  pairWaitingImages();
}

void AlignmentCheck::addOmniFrame(double stamp_s, const std::vector<fw::OmniBallObservation>& balls) {
  const double t_s = stamp_s - config_.omni.latency_s;
  if (balls.empty() || !std::isfinite(t_s)) return;
  // Only images the Kinect's frames can meet: one off their time line would wait for ever.
  if (!kinect_.empty() && std::abs(t_s - kinect_.back().t_s) > kKinectHistory_s) return;
  waiting_.push_back({t_s, balls});
  pairWaitingImages();
}

void AlignmentCheck::pairWaitingImages() {
  if (kinect_.empty()) return;
  const double newest_s = kinect_.back().t_s;
  for (auto image = waiting_.begin(); image != waiting_.end();) {
    if (image->t_s + kLineHalfSpan_s > newest_s) {  // the Kinect's frames after it are still to come
      ++image;
      continue;
    }
    pair(*image);
    image = waiting_.erase(image);
  }
}

std::optional<AlignmentCheck::KinectLine> AlignmentCheck::kinectLineAt(double t_s) const {
  std::vector<const KinectFrame*> frames;
  int before = 0, after = 0;
  for (const KinectFrame& frame : kinect_) {
    if (std::abs(frame.t_s - t_s) > kLineHalfSpan_s) continue;
    if (!frame.ball) return std::nullopt;
    frames.push_back(&frame);
    ++(frame.t_s <= t_s ? before : after);
  }
  if (before < kMinFramesEachSide || after < kMinFramesEachSide) return std::nullopt;
  // Least squares for p(t) = position + velocity (t - t_s), x and y alike.
  Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
  Eigen::Matrix2d right = Eigen::Matrix2d::Zero();  // columns: x, y
  for (const KinectFrame* frame : frames) {
    const Eigen::Vector2d a(1.0, frame->t_s - t_s);
    normal += a * a.transpose();
    right += a * frame->ball->position_m.head<2>().transpose();
  }
  const Eigen::Matrix2d solution = normal.ldlt().solve(right);
  KinectLine line{solution.row(0).transpose(), solution.row(1).transpose(), Eigen::Matrix2d::Zero()};
  double nearest_s = kLineHalfSpan_s;
  for (const KinectFrame* frame : frames) {
    const Eigen::Vector2d on_line = line.position_m + (frame->t_s - t_s) * line.velocity_mps;
    if ((frame->ball->position_m.head<2>() - on_line).norm() > kMaxLineResidual_m) return std::nullopt;
    // Its covariance: the nearest frame's (the Kinect's error changes slowly across a ball's path,
    // so frames do not average it away).
    if (std::abs(frame->t_s - t_s) <= nearest_s) {
      nearest_s = std::abs(frame->t_s - t_s);
      line.covariance_m2 = frame->ball->covariance_m2.topLeftCorner<2, 2>();
    }
  }
  return line;
}

void AlignmentCheck::pair(const OmniImage& image) {
  const std::optional<KinectLine> line = kinectLineAt(image.t_s);
  if (!line) return;
  const Eigen::Vector2d& kinect = line->position_m;

  const fw::OmniBallObservation* match = nullptr;
  for (const fw::OmniBallObservation& ball : image.balls) {
    if ((ball.groundPoint_R().head<2>() - kinect).norm() > kPairGate_m) continue;
    if (match != nullptr) return;  // two candidates: which is the Kinect's ball is not clear
    match = &ball;
  }
  if (match == nullptr) return;

  // The omni's bearing and distance noise on the floor (the Jacobian of its ground point), at the
  // Kinect's distance: at its own noisy one, short distances would weigh more and pull the fit in.
  const double b = match->bearing_rad, d = kinect.norm();
  Eigen::Matrix2d J;
  J << -d * std::cos(b), -std::sin(b), -d * std::sin(b), std::cos(b);
  const Eigen::Vector2d sigma(omniBearingSigma_rad(*match, config_.omni), omniDistanceSigma_m(*match, config_.omni, d));
  const Eigen::Matrix2d omni_covariance = J * sigma.cwiseAbs2().asDiagonal() * J.transpose();
  pairs_.push_back(
      {kinect, match->groundPoint_R().head<2>(), line->velocity_mps, omni_covariance + line->covariance_m2});
  if (pairs_.size() > static_cast<std::size_t>(config_.alignment_check.window_pairs)) pairs_.pop_front();

  ++new_pairs_;
  if (pairs_.size() < static_cast<std::size_t>(config_.alignment_check.window_pairs) ||
      new_pairs_ < config_.alignment_check.window_pairs / 2)
    return;
  new_pairs_ = 0;
  latest_ = fit();
  if (!beyondLimits(*latest_)) {
    disagreements_ = 0;
    alarmed_ = false;
    return;
  }
  if (++disagreements_ >= config_.alignment_check.confirmations && !alarmed_) {
    alarmed_ = true;
    alarm_ = latest_;
  }
}

// Weighted least squares (Gauss-Newton) for the turn about the Kinect, the shift, and the omni's
// time offset (one for the window: it moves each omni ball back along its motion), with the knock
// priors and the configured timing sigma as the offset's; once with every pair, then without those
// far off that fit.
KinectMisalignment AlignmentCheck::fit() const {
  const double timing_sigma_s = std::max(config_.omni.timing_sigma_s, kMinTimingSigma_s);
  const Eigen::Vector4d prior_information(1.0 / (kTurnPrior_rad * kTurnPrior_rad),
                                          1.0 / (kShiftPrior_m * kShiftPrior_m), 1.0 / (kShiftPrior_m * kShiftPrior_m),
                                          1.0 / (timing_sigma_s * timing_sigma_s));
  const auto residualOf = [&](const Pair& p, const Eigen::Vector4d& x, Eigen::Vector2d* from_kinect) {
    *from_kinect = turn(x[0]) * (p.kinect_m - kinect_xy_R_);
    return Eigen::Vector2d(p.omni_m - (kinect_xy_R_ + *from_kinect + x.segment<2>(1) - x[3] * p.velocity_mps));
  };
  std::vector<bool> used(pairs_.size(), true);
  Eigen::Vector4d x = Eigen::Vector4d::Zero();  // turn, shift x, shift y, time offset
  Eigen::Matrix4d information;
  for (int pass = 0; pass < 2; ++pass) {
    for (int iteration = 0; iteration < 5; ++iteration) {
      information = prior_information.asDiagonal();
      Eigen::Vector4d gradient = -information * x;
      for (std::size_t i = 0; i < pairs_.size(); ++i) {
        if (!used[i]) continue;
        Eigen::Vector2d from_kinect;
        const Eigen::Vector2d residual = residualOf(pairs_[i], x, &from_kinect);
        Eigen::Matrix<double, 2, 4> jacobian;
        jacobian.col(0) = Eigen::Vector2d(-from_kinect.y(), from_kinect.x());
        jacobian.middleCols<2>(1).setIdentity();
        jacobian.col(3) = -pairs_[i].velocity_mps;
        const Eigen::Matrix2d weight = pairs_[i].covariance_m2.inverse();
        information += jacobian.transpose() * weight * jacobian;
        gradient += jacobian.transpose() * weight * residual;
      }
      x += information.ldlt().solve(gradient);
    }
    if (pass == 1) break;
    for (std::size_t i = 0; i < pairs_.size(); ++i) {
      Eigen::Vector2d from_kinect;
      const Eigen::Vector2d residual = residualOf(pairs_[i], x, &from_kinect);
      used[i] = residual.dot(pairs_[i].covariance_m2.inverse() * residual) <= kFitGate_sigma * kFitGate_sigma;
    }
  }

  KinectMisalignment result;
  const Eigen::Matrix4d covariance = information.inverse();
  result.yaw_rad = x[0];
  result.yaw_sigma_rad = std::sqrt(covariance(0, 0));
  result.offset_m = x.segment<2>(1);
  result.offset_covariance_m2 = covariance.block<2, 2>(1, 1);
  result.omni_time_offset_s = x[3];
  double gaps = 0.0;
  for (std::size_t i = 0; i < pairs_.size(); ++i) {
    if (!used[i]) continue;
    ++result.pairs;
    gaps += (pairs_[i].omni_m - pairs_[i].kinect_m).norm();
  }
  result.mean_gap_m = gaps / std::max(result.pairs, 1);
  return result;
}

bool AlignmentCheck::beyondLimits(const KinectMisalignment& fit) const {
  const bool turned = std::abs(fit.yaw_rad) > config_.alignment_check.max_yaw_error_rad &&
                      std::abs(fit.yaw_rad) > kSignificance_sigma * fit.yaw_sigma_rad;
  const double offset_sigmas = std::sqrt(fit.offset_m.dot(fit.offset_covariance_m2.inverse() * fit.offset_m));
  const bool shifted =
      fit.offset_m.norm() > config_.alignment_check.max_offset_error_m && offset_sigmas > kSignificance_sigma;
  return turned || shifted;
}

std::optional<KinectMisalignment> AlignmentCheck::takeAlarm() { return std::exchange(alarm_, std::nullopt); }

}  // namespace fusion
