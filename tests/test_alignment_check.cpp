// The running check that the Kinect still sits where pose_in_robot says, against the omni camera:
// synthetic ball paths in the robot frame, a Kinect turned and shifted by a known amount, and an
// omni camera whose noise, timing error and false balls are drawn across their physical ranges.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fusion/alignment_check.h"
#include "random_draws.h"

namespace {

constexpr double kDeg = M_PI / 180.0;

// A Kinect whose balls need turning by yaw about its position and shifting by offset to be true.
struct Knock {
  double yaw_rad = 0.0;
  Eigen::Vector2d offset_m = Eigen::Vector2d::Zero();
};

// Where the balls go: rolling across the Kinect's view (within 25 degrees of the robot's +y, 1 to
// 5 m away), or inside a narrow patch of it, at up to max_speed_mps.
struct Play {
  double duration_s = 30.0;
  double max_speed_mps = 3.0;
  double half_view_rad = 25.0 * kDeg;
  double min_range_m = 1.0, max_range_m = 5.0;
  double omni_time_error_s = 0.0;  // the omni's stamps are late by this beyond its configured latency ...
  double timing_sigma_s = 0.05;    // ... which fusion.omni.timing_sigma_s says may be this
};

class Scenario {
 public:
  Scenario(unsigned seed, const Knock& knock, const Play& play) : random_(seed), knock_(knock), play_(play) {
    std::uniform_real_distribution<double> mount(-0.15, 0.15);
    kinect_xy_ = drawVector2(mount, random_);
    std::uniform_real_distribution<double> bearing_sigma(0.5 * kDeg, 2.0 * kDeg), distance_fraction(0.02, 0.08),
        kinect_sigma(0.01, 0.03);
    fusion::OmniConfig& omni = config_.omni;
    omni.bearing_sigma_rad = bearing_sigma(random_);
    omni.distance_sigma_m = 0.05;
    omni.distance_sigma_fraction = distance_fraction(random_);
    omni.timing_sigma_s = play.timing_sigma_s;
    kinect_sigma_m_ = kinect_sigma(random_);
  }

  const Eigen::Vector2d& kinectXY() const { return kinect_xy_; }
  const fusion::FusionConfig& config() const { return config_; }

  // Plays the balls into the check at 30 Hz for both sensors (the omni half a frame later, arriving
  // before the Kinect frame that follows it); returns how many alarms it raised.
  int run(fusion::AlignmentCheck& check) {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::normal_distribution<double> normal(0.0, 1.0);
    const double frame_s = 1.0 / 30.0;
    int alarms = 0;
    Eigen::Vector2d ball = newPlace(), velocity = newVelocity();
    for (double t = 0.0; t < play_.duration_s; t += frame_s) {
      // A new roll every second or so, or when the ball leaves the view.
      if (unit(random_) < frame_s || !inView(ball)) {
        ball = newPlace();
        velocity = newVelocity();
      }
      // The omni image half a frame before this Kinect frame, where the ball truly was then.
      const double omni_t = t - 0.5 * frame_s;
      const Eigen::Vector2d omni_truth = ball - 0.5 * frame_s * velocity - play_.omni_time_error_s * velocity;
      std::vector<fw::OmniBallObservation> omni_balls;
      if (unit(random_) > 0.05) omni_balls.push_back(omniView(omni_truth, normal));
      if (unit(random_) < 0.05) omni_balls.push_back(omniView(newPlace(), normal));  // an orange shirt
      check.addOmniFrame(omni_t, omni_balls);

      // The Kinect's ball where its wrong pose puts it.
      const Eigen::Vector2d seen =
          kinect_xy_ + Eigen::Rotation2Dd(-knock_.yaw_rad).toRotationMatrix() * (ball - knock_.offset_m - kinect_xy_);
      const Eigen::Vector3d p_R(seen.x() + kinect_sigma_m_ * normal(random_),
                                seen.y() + kinect_sigma_m_ * normal(random_), 0.11);
      check.addKinectFrame(
          t, {fw::BallObservation::inRobotFrame(p_R, kinect_sigma_m_ * kinect_sigma_m_ * Eigen::Matrix3d::Identity(),
                                                fw::BallState::kGround, "kinect3d", {})});
      if (check.takeAlarm()) ++alarms;
      ball += frame_s * velocity;
    }
    return alarms;
  }

 private:
  bool inView(const Eigen::Vector2d& p) const {
    const double range = p.norm(), bearing = std::atan2(-p.x(), p.y());
    return range >= play_.min_range_m && range <= play_.max_range_m && std::abs(bearing) <= play_.half_view_rad;
  }
  Eigen::Vector2d newPlace() {
    std::uniform_real_distribution<double> bearing(-play_.half_view_rad, play_.half_view_rad),
        range(play_.min_range_m, play_.max_range_m);
    const double b = bearing(random_), r = range(random_);
    return {-r * std::sin(b), r * std::cos(b)};
  }
  Eigen::Vector2d newVelocity() {
    std::uniform_real_distribution<double> direction(-M_PI, M_PI), speed(0.0, play_.max_speed_mps);
    const double a = direction(random_), v = speed(random_);
    return {v * std::cos(a), v * std::sin(a)};
  }
  fw::OmniBallObservation omniView(const Eigen::Vector2d& p, std::normal_distribution<double>& normal) {
    fw::OmniBallObservation omni;
    const double d = p.norm();
    const fusion::OmniConfig& camera = config_.omni;
    omni.bearing_rad = std::atan2(-p.x(), p.y()) + camera.bearing_sigma_rad * normal(random_);
    omni.distance_m = d + (camera.distance_sigma_m + camera.distance_sigma_fraction * d) * normal(random_);
    return omni;
  }

  std::mt19937 random_;
  Knock knock_;
  Play play_;
  Eigen::Vector2d kinect_xy_;
  fusion::FusionConfig config_;
  double kinect_sigma_m_;
};

struct Outcome {
  int alarms = 0;
  std::optional<fusion::KinectMisalignment> fit;
};

Outcome check(unsigned seed, const Knock& knock, const Play& play = {}) {
  Scenario scenario(seed, knock, play);
  fusion::AlignmentCheck check(scenario.config(), scenario.kinectXY());
  Outcome outcome;
  outcome.alarms = scenario.run(check);
  outcome.fit = check.latestFit();
  return outcome;
}

TEST(AlignmentCheck, NoAlarmWhileTheSensorsAgree) {
  for (unsigned seed = 1; seed <= 10; ++seed) {
    const Outcome outcome = check(seed, {});
    ASSERT_TRUE(outcome.fit.has_value()) << "seed " << seed;
    EXPECT_EQ(outcome.alarms, 0) << "seed " << seed;
    const fusion::KinectMisalignment& fit = *outcome.fit;
    EXPECT_LT(std::abs(fit.yaw_rad), 3.0 * fit.yaw_sigma_rad) << "seed " << seed;
    EXPECT_LT(std::sqrt(fit.offset_m.dot(fit.offset_covariance_m2.inverse() * fit.offset_m)), 3.5) << "seed " << seed;
  }
}

TEST(AlignmentCheck, ATurnedAndShiftedKinectIsFoundOnceWithItsCorrection) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> turn(3.0 * kDeg, 6.0 * kDeg), shift(-0.08, 0.08), sign(-1.0, 1.0);
  for (unsigned seed = 1; seed <= 6; ++seed) {
    const double sign_draw = sign(random);
    const double turn_rad = turn(random);
    const Knock knock{std::copysign(turn_rad, sign_draw), drawVector2(shift, random)};
    const Outcome outcome = check(seed, knock);
    ASSERT_TRUE(outcome.fit.has_value()) << "seed " << seed;
    EXPECT_EQ(outcome.alarms, 1) << "seed " << seed;  // once per episode, not once per fit
    // As close as the fit says it is (3 sigma), and that is close.
    const fusion::KinectMisalignment& fit = *outcome.fit;
    EXPECT_NEAR(fit.yaw_rad, knock.yaw_rad, 3.0 * fit.yaw_sigma_rad) << "seed " << seed;
    EXPECT_LT(fit.yaw_sigma_rad, 0.5 * kDeg) << "seed " << seed;
    const Eigen::Vector2d error = fit.offset_m - knock.offset_m;
    EXPECT_LT(std::sqrt(error.dot(fit.offset_covariance_m2.inverse() * error)), 3.5) << "seed " << seed;
    EXPECT_LT(std::sqrt(fit.offset_covariance_m2.trace()), 0.04) << "seed " << seed;
  }
}

TEST(AlignmentCheck, ATurnBelowTheLimitIsNoAlarm) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    EXPECT_EQ(check(seed, {1.0 * kDeg, Eigen::Vector2d::Zero()}).alarms, 0) << "seed " << seed;
  }
}

TEST(AlignmentCheck, ABallInOnePatchOfTheViewStillShowsATurn) {
  // Balls only 2.5 to 3 m ahead within 5 degrees: a turn and a sideways shift look alike there.
  Play patch;
  patch.half_view_rad = 5.0 * kDeg;
  patch.min_range_m = 2.5;
  patch.max_range_m = 3.0;
  patch.max_speed_mps = 0.5;
  const Outcome outcome = check(3, {4.0 * kDeg, Eigen::Vector2d::Zero()}, patch);
  ASSERT_TRUE(outcome.fit.has_value());
  EXPECT_EQ(outcome.alarms, 1);
  EXPECT_NEAR(outcome.fit->yaw_rad, 4.0 * kDeg, 1.0 * kDeg);
}

TEST(AlignmentCheck, FastBallsCountLittleWhileTheOmniTimingIsUncertain) {
  // The omni's stamps 60 ms late beyond its configured latency (which may be 50 ms off): fast balls
  // are moved by up to 30 cm along their motion, which must not read as a moved Kinect.
  Play untimed;
  untimed.max_speed_mps = 5.0;
  untimed.omni_time_error_s = 0.06;
  untimed.timing_sigma_s = 0.05;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    EXPECT_EQ(check(seed, {}, untimed).alarms, 0) << "seed " << seed;
  }
}

TEST(AlignmentCheck, NoFitWithoutPairs) {
  // Balls in the air and frames with two balls pair with nothing.
  fusion::AlignmentCheck check(fusion::FusionConfig{}, Eigen::Vector2d::Zero());
  fw::OmniBallObservation omni;
  omni.distance_m = 3.0;
  const auto ball = [](double x, fw::BallState state) {
    return fw::BallObservation::inRobotFrame({x, 3.0, 0.5}, 1e-4 * Eigen::Matrix3d::Identity(), state, "kinect3d", {});
  };
  for (int i = 0; i < 300; ++i) {
    check.addOmniFrame(i / 30.0 - 0.01, {omni});
    if (i % 2 == 0) {
      check.addKinectFrame(i / 30.0, {ball(0.0, fw::BallState::kAir)});
    } else {
      check.addKinectFrame(i / 30.0, {ball(0.0, fw::BallState::kGround), ball(2.0, fw::BallState::kGround)});
    }
  }
  EXPECT_FALSE(check.latestFit().has_value());
  EXPECT_FALSE(check.takeAlarm().has_value());
}

}  // namespace
