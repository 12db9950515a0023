#include "framework_api/types.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace fw {

namespace {
// NaN: the system clock. Atomic: plugin threads read it while a test's host may run beside a replay.
std::atomic<double> replayed_wall_time_s{std::numeric_limits<double>::quiet_NaN()};
}  // namespace

double wallClockNow_s() {
  const double replayed_s = replayed_wall_time_s.load();
  if (!std::isnan(replayed_s)) return replayed_s;
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

void setReplayedWallClock(std::optional<double> wall_time_s) {
  replayed_wall_time_s = wall_time_s.value_or(std::numeric_limits<double>::quiet_NaN());
}

double quantile(std::vector<double> values, double q) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t rank = std::min(values.size() - 1, static_cast<std::size_t>(std::max(0.0, q) * values.size()));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(rank), values.end());
  return values[rank];
}

double largestEigenvalue(const Eigen::Matrix2d& symmetric) {
  const double mean = 0.5 * (symmetric(0, 0) + symmetric(1, 1));
  return mean + std::hypot(0.5 * (symmetric(0, 0) - symmetric(1, 1)), symmetric(0, 1));
}

double wrapAngle(double a_rad) { return a_rad - 2.0 * M_PI * std::floor((a_rad + M_PI) / (2.0 * M_PI)); }

const char* toString(Frame frame) {
  switch (frame) {
    case Frame::kSensor:
      return "sensor";
    case Frame::kRobot:
      return "robot";
    case Frame::kField:
      return "field";
  }
  return "?";
}

const char* toString(BallState state) { return state == BallState::kAir ? "air" : "ground"; }

namespace {
// The words the match log, the detect output and the viewer use, in enum order.
constexpr const char* kVerdictNames[] = {"not_checked", "confirmed", "rejected", "no_evidence"};
constexpr const char* kNoteNames[] = {"none",        "no_image", "outside_image", "too_small", "too_dark",
                                      "overexposed", "blurred",  "weak",          "hidden"};

template <typename Enum, std::size_t N>
Enum enumFrom(const char* const (&names)[N], const std::string& text, const char* what) {
  for (std::size_t i = 0; i < N; ++i) {
    if (text == names[i]) return static_cast<Enum>(i);
  }
  throw std::invalid_argument("'" + text + "' is not a " + what);
}
}  // namespace

const char* toString(ColourVerdict verdict) { return kVerdictNames[static_cast<int>(verdict)]; }
ColourVerdict colourVerdictFrom(const std::string& text) {
  return enumFrom<ColourVerdict>(kVerdictNames, text, "colour verdict");
}
const char* toString(ColourNote note) { return kNoteNames[static_cast<int>(note)]; }
ColourNote colourNoteFrom(const std::string& text) { return enumFrom<ColourNote>(kNoteNames, text, "colour note"); }

Eigen::Vector3d RobotPose::fieldFromRobot(const Eigen::Vector3d& p_R) const {
  const double c = std::cos(theta_rad), s = std::sin(theta_rad);
  return {x_m + c * p_R.x() - s * p_R.y(), y_m + s * p_R.x() + c * p_R.y(), p_R.z()};
}

Eigen::Isometry3d RobotPose::T_F_R() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(theta_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x_m, y_m, 0.0);
  return T;
}

BallObservation BallObservation::inRobotFrame(const Eigen::Vector3d& p_R, const Eigen::Matrix3d& cov_m2,
                                              BallState state, std::string source, Stamp stamp) {
  BallObservation observation;
  observation.position_m = p_R;
  observation.covariance_m2 = cov_m2;
  observation.frame = Frame::kRobot;
  observation.state = state;
  observation.source = std::move(source);
  observation.stamp = stamp;
  return observation;
}

bool BallObservation::isApprox(const BallObservation& other, double tol_m) const {
  return frame == other.frame && state == other.state && source == other.source && is_static == other.is_static &&
         colour == other.colour && colour_note == other.colour_note &&
         (position_m - other.position_m).cwiseAbs().maxCoeff() <= tol_m &&
         (covariance_m2 - other.covariance_m2).cwiseAbs().maxCoeff() <= tol_m * tol_m;
}

namespace {
// Bearing 0 looks along +y; positive turns towards -x (counter-clockwise seen from above).
Eigen::Vector3d omniGroundPoint_R(double bearing_rad, double distance_m) {
  return {-distance_m * std::sin(bearing_rad), distance_m * std::cos(bearing_rad), 0.0};
}
}  // namespace

Eigen::Vector3d OmniBallObservation::groundPoint_R() const { return omniGroundPoint_R(bearing_rad, distance_m); }

Eigen::Vector3d OmniRobotObservation::groundPoint_R() const { return omniGroundPoint_R(bearing_rad, distance_m); }

void BallTrajectory::propagate(double t_s, Eigen::Vector3d& p, Eigen::Vector3d& v) const {
  p = position_m;
  v = velocity_mps;
  const double dt = t_s - time_s;
  if (state == BallState::kGround) {
    // Rolling: constant deceleration along the velocity until the ball stops.
    const double speed = v.head<2>().norm();
    if (speed <= 0.0 || rolling_decel_mps2 <= 0.0) {
      p += v * dt;
      return;
    }
    const double rolling_s = dt > 0.0 ? std::min(dt, speed / rolling_decel_mps2) : dt;
    const Eigen::Vector3d direction = v / speed;
    p += direction * (speed * rolling_s - 0.5 * rolling_decel_mps2 * rolling_s * std::abs(rolling_s));
    v = direction * std::max(0.0, speed - rolling_decel_mps2 * rolling_s);
    return;
  }
  const Eigen::Vector3d g(0.0, 0.0, -gravity_mps2);
  if (drag_per_m <= 0.0 && curve_radps == 0.0) {
    p += v * dt + 0.5 * g * dt * dt;
    v += g * dt;
    return;
  }
  // Quadratic drag and the Magnus curve have no closed form: midpoint steps of at most 20 ms (0.1 mm off after a second
  // of flight at 10 m/s with k = 0.024 /m, against steps a thousand times finer). No flight lasts
  // kMaxFlight_s: past it the ball goes on at the speed it has (a time far off, or a stamp that jumped,
  // costs no more than that), and a time that is not finite gives a position that is not either.
  constexpr double kStep_s = 0.02, kMaxFlight_s = 10.0;
  if (!std::isfinite(dt)) {
    p.setConstant(NAN);
    v.setConstant(NAN);
    return;
  }
  const double flight_s = std::clamp(dt, -kMaxFlight_s, kMaxFlight_s);
  const int steps = std::max(1, static_cast<int>(std::ceil(std::abs(flight_s) / kStep_s)));
  const double h = flight_s / steps;
  auto acceleration = [&](const Eigen::Vector3d& velocity) -> Eigen::Vector3d {
    return g - drag_per_m * velocity.norm() * velocity +
           curve_radps * Eigen::Vector3d(-velocity.y(), velocity.x(), 0.0);
  };
  for (int i = 0; i < steps; ++i) {
    const Eigen::Vector3d v_mid = v + 0.5 * h * acceleration(v);
    p += h * v_mid;
    v += h * acceleration(v_mid);
  }
  p += v * (dt - flight_s);
}

Eigen::Vector3d BallTrajectory::positionAt(double t_s) const {
  Eigen::Vector3d p, v;
  propagate(t_s, p, v);
  return p;
}

Eigen::Vector3d BallTrajectory::velocityAt(double t_s) const {
  Eigen::Vector3d p, v;
  propagate(t_s, p, v);
  return v;
}

BallTrajectory BallTrajectory::movedTo(double t_s) const {
  BallTrajectory moved = *this;
  propagate(t_s, moved.position_m, moved.velocity_mps);
  moved.time_s = t_s;
  return moved;
}

double FusedBall::sigmaHorizontal_m() const {
  return std::sqrt(std::max(0.0, largestEigenvalue(covariance_F.topLeftCorner<2, 2>())));
}

}  // namespace fw
