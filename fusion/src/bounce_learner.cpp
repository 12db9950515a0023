#include "fusion/bounce_learner.h"

#include <algorithm>
#include <cmath>

#include "framework_api/types.h"

namespace fusion {

namespace {

// Balls further apart than this are not one flight (the ball was lost in between).
constexpr double kMaxGap_s = 0.1;
// The two fits meet the floor within this of each other, in the gap between the balls either side.
constexpr double kMeetWithin_s = 0.02;
// A fit whose balls lie further off than this (rms) is not a flight: a ball rolling, caught, pushed.
constexpr double kMaxFitRms_m = 0.03;
// Slower onto the floor, a ball says little of its restitution (and hardly hops).
constexpr double kMinImpact_mps = 1.0;
// Slower along the floor, a bounce says little of its friction.
constexpr double kMinFrictionSpeed_mps = 0.5;
// What one bounce's restitution or friction is known to: the spread never learns below it.
constexpr double kOneBounceSigma = 0.03;

struct SideFit {
  double height_m, vz_mps;  // at tau = 0: the height and vertical speed of the flight under gravity
  Eigen::Vector2d along_mps;
  double rms_m;
  // When the flight's centre is at the floor's resting height r: the later root for a fall, the
  // earlier for a rise; none when it never comes down that far.
  bool touchdown(double r, bool falling, double& tau_s) const {
    const double g = fw::kGravity_mps2;
    const double discriminant = vz_mps * vz_mps + 2.0 * g * (height_m - r);
    if (discriminant < 0.0) return false;
    tau_s = (vz_mps + (falling ? 1.0 : -1.0) * std::sqrt(discriminant)) / g;
    return true;
  }
};

// Least squares over the samples [first, last) of height + g tau^2 / 2 = a + b tau and of the
// position along the floor on a line, tau from t0_s.
template <typename Samples>
SideFit fitSide(const Samples& samples, std::size_t first, std::size_t last, double t0_s) {
  const double half_g = 0.5 * fw::kGravity_mps2;
  const double n = static_cast<double>(last - first);
  double st = 0.0, stt = 0.0;
  Eigen::Vector3d sy = Eigen::Vector3d::Zero(), sty = Eigen::Vector3d::Zero();
  for (std::size_t i = first; i < last; ++i) {
    const double tau = samples[i].t_s - t0_s;
    Eigen::Vector3d y = samples[i].p_F;
    y.z() += half_g * tau * tau;
    st += tau;
    stt += tau * tau;
    sy += y;
    sty += tau * y;
  }
  const double denominator = n * stt - st * st;
  const Eigen::Vector3d slope = (n * sty - st * sy) / denominator;
  const Eigen::Vector3d intercept = (sy - slope * st) / n;
  double squares = 0.0;
  for (std::size_t i = first; i < last; ++i) {
    const double tau = samples[i].t_s - t0_s;
    const double fitted = intercept.z() + slope.z() * tau - half_g * tau * tau;
    squares += std::pow(samples[i].p_F.z() - fitted, 2);
  }
  return {intercept.z(), slope.z(), slope.head<2>(), std::sqrt(squares / n)};
}

// The fall before a bounce (samples [first, last)) or the rise after it, fitted over its own hop
// only: the balls before the hop the fall came from left the floor earlier (or after the rise, came
// down again) and are left out. False when fewer than min_samples remain.
template <typename Samples>
bool fitHop(const Samples& samples, std::size_t first, std::size_t last, double t0_s, bool fall, double r,
            std::size_t min_samples, SideFit& fit) {
  constexpr double kOffTheFloor_s = 0.01;  // a ball that close to its other touchdown is near the floor
  if (last - first < min_samples) return false;
  fit = fitSide(samples, first, last, t0_s);
  double other_end = 0.0;
  if (!fit.touchdown(r, !fall, other_end)) return true;  // never that low: the whole window is one hop
  std::size_t kept_first = first, kept_last = last;
  if (fall) {
    while (kept_first < kept_last && samples[kept_first].t_s - t0_s < other_end + kOffTheFloor_s) ++kept_first;
  } else {
    while (kept_last > kept_first && samples[kept_last - 1].t_s - t0_s > other_end - kOffTheFloor_s) --kept_last;
  }
  if (kept_last - kept_first < min_samples) return false;
  if (kept_first != first || kept_last != last) fit = fitSide(samples, kept_first, kept_last, t0_s);
  return true;
}

}  // namespace

void BounceLearner::Tally::add(double value) {
  ++count;
  sum += value;
  sum_of_squares += value * value;
}

void BounceLearner::learnt(const Tally& tally, double configured, double configured_sigma, double& mean,
                           double& sigma) {
  const double n = tally.count;
  mean = (kPriorBounces * configured + tally.sum) / (kPriorBounces + n);
  double spread2 = kOneBounceSigma * kOneBounceSigma;
  if (tally.count >= 2) {
    spread2 = std::max(spread2, (tally.sum_of_squares - tally.sum * tally.sum / n) / (n - 1.0));
  }
  sigma = std::sqrt((kPriorBounces * configured_sigma * configured_sigma + n * spread2) / (kPriorBounces + n));
}

BounceLearner::BounceLearner(const MotionConfig& configured) : configured_(configured), motion_(configured) {}

bool BounceLearner::add(int track_id, double t_s, const Eigen::Vector3d& p_F) {
  if (!std::isfinite(t_s) || !p_F.allFinite()) return false;
  if (track_id != track_id_ || (count_ > 0 && t_s - samples_[count_ - 1].t_s > kMaxGap_s)) count_ = 0;
  track_id_ = track_id;
  if (count_ > 0 && t_s <= samples_[count_ - 1].t_s) return false;
  if (count_ == kKept) {
    std::rotate(samples_.begin(), samples_.begin() + 1, samples_.end());  // the oldest goes
    --count_;
  }
  samples_[count_++] = {t_s, p_F};
  std::size_t lowest = 0;
  for (std::size_t i = 1; i < count_; ++i) {
    if (samples_[i].p_F.z() < samples_[lowest].p_F.z()) lowest = i;
  }
  if (count_ - 1 - lowest != static_cast<std::size_t>(kSideSamples)) return false;
  const bool learnt_one = learnBounceAt(lowest);
  // Judged once: the balls up to the lowest go, those after it may be the next bounce's fall.
  std::rotate(samples_.begin(), samples_.begin() + lowest + 1, samples_.begin() + count_);
  count_ -= lowest + 1;
  return learnt_one;
}

bool BounceLearner::learnBounceAt(std::size_t lowest) {
  const double t_low = samples_[lowest].t_s;
  std::size_t first = lowest;
  while (first > 0 && t_low - samples_[first - 1].t_s <= kSide_s) --first;
  const std::size_t after = lowest + 1, end = count_;
  const double r = configured_.radius_m;
  SideFit fall, rise;
  if (!fitHop(samples_, first, lowest, t_low, true, r, kMinSideSamples, fall) ||
      !fitHop(samples_, after, end, t_low, false, r, kMinSideSamples, rise)) {
    return false;
  }
  // Each check is written so that a number that is not one fails it.
  if (!(fall.rms_m <= kMaxFitRms_m && rise.rms_m <= kMaxFitRms_m)) return false;
  double tau_fall = 0.0, tau_rise = 0.0;
  if (!fall.touchdown(r, true, tau_fall) || !rise.touchdown(r, false, tau_rise)) return false;
  if (!(std::abs(tau_fall - tau_rise) <= kMeetWithin_s)) return false;
  const double tau = 0.5 * (tau_fall + tau_rise);
  if (!(tau >= samples_[lowest - 1].t_s - t_low && tau <= samples_[after].t_s - t_low)) return false;
  const double vz_in = fall.vz_mps - fw::kGravity_mps2 * tau, vz_out = rise.vz_mps - fw::kGravity_mps2 * tau;
  if (!(vz_in <= -kMinImpact_mps && vz_out > 0.0)) return false;
  const double restitution = -vz_out / vz_in;
  if (!(restitution >= 0.1 && restitution <= 0.95)) return false;  // not the floor's bounce
  restitutions_.add(restitution);
  const double along_in = fall.along_mps.norm();
  if (along_in >= kMinFrictionSpeed_mps) {
    // The speed kept along the way it came (a bounce keeps the direction): unlike the rise's own
    // speed, its noise does not lengthen it.
    const double friction = 1.0 - rise.along_mps.dot(fall.along_mps) / (along_in * along_in);
    if (friction > -0.1 && friction < 0.9) frictions_.add(friction);  // false for what is not a number
  }
  learnt(restitutions_, configured_.restitution, configured_.restitution_sigma, motion_.restitution,
         motion_.restitution_sigma);
  learnt(frictions_, configured_.bounce_friction, configured_.bounce_friction_sigma, motion_.bounce_friction,
         motion_.bounce_friction_sigma);
  return true;
}

}  // namespace fusion
