#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "framework_api/config.h"
#include "kinect3d/config_io.h"
#include "kinect3d/sim/ball_motion.h"
#include "kinect3d/sim/evaluation.h"
#include "kinect3d/trajectory.h"
#include "random_draws.h"

namespace {

using kinect3d::TrajectoryConfig;

constexpr double kFrame_s = 1.0 / 30.0;

fw::BallObservation observe(double t, const Eigen::Vector3d& p, double sigma_m = 0.001) {
  const fw::BallState state = p.z() > 0.11 + 0.08 ? fw::BallState::kAir : fw::BallState::kGround;
  return fw::BallObservation::inRobotFrame(p, sigma_m * sigma_m * Eigen::Matrix3d::Identity(), state, "kinect3d",
                                           fw::Stamp{t, t});
}

// A drag-free flight from p0 with v0 at t = 0.
Eigen::Vector3d flight(const Eigen::Vector3d& p0, const Eigen::Vector3d& v0, double t) {
  return p0 + v0 * t + Eigen::Vector3d(0, 0, -0.5 * 9.81 * t * t);
}

// Drag- and spin-free and not estimated, as the flights built here by flight().
TrajectoryConfig ballistic() {
  TrajectoryConfig config;
  config.drag_per_m = 0.0;
  config.drag_sigma_per_m = 0.0;
  config.curve_sigma_radps = 0.0;
  return config;
}

TEST(BallisticTrajectory, RecoversANoiseFreeFlightExactly) {
  const Eigen::Vector3d p0(0.2, 2.0, 0.3), v0(0.5, 6.0, 4.5);
  auto estimator = kinect3d::makeTrajectoryEstimator(ballistic());
  std::optional<fw::BallTrajectory> trajectory;
  for (int i = 0; i < 8; ++i)
    trajectory = estimator->update(i * kFrame_s, {observe(i * kFrame_s, flight(p0, v0, i * kFrame_s), 1e-4)});
  ASSERT_TRUE(trajectory);
  const double t = 7 * kFrame_s;
  EXPECT_LT((trajectory->position_m - flight(p0, v0, t)).norm(), 1e-6);
  EXPECT_LT((trajectory->velocity_mps - (v0 + Eigen::Vector3d(0, 0, -9.81 * t))).norm(), 1e-5);
  EXPECT_EQ(trajectory->support, 8);
  // Touchdown: 0.3 + 4.5 t - 4.905 t^2 = 0.11.
  const double t_land = (4.5 + std::sqrt(4.5 * 4.5 + 2 * 9.81 * (0.3 - 0.11))) / 9.81;
  ASSERT_TRUE(trajectory->touchdown);
  EXPECT_NEAR(trajectory->touchdown->time_s, t_land, 1e-6);
  EXPECT_LT((trajectory->touchdown->point_m - flight(p0, v0, t_land).head<2>()).norm(), 1e-5);
  EXPECT_FALSE(trajectory->crossing) << "flying away from the robot's line";
  EXPECT_LT((trajectory->positionAt(0.5) - flight(p0, v0, 0.5)).norm(), 1e-5);
}

TEST(BallisticTrajectory, StaysWithinItsUncertaintyWithNoise) {
  const Eigen::Vector3d p0(-0.3, 6.0, 0.5), v0(0.4, -7.0, 4.5);  // a chip at the goalkeeper
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  auto estimator = kinect3d::makeTrajectoryEstimator(ballistic());
  std::optional<fw::BallTrajectory> trajectory;
  for (int i = 0; i < 12; ++i) {
    const double t = i * kFrame_s;
    trajectory = estimator->update(t, {observe(t, flight(p0, v0, t) + drawVector3(noise, rng), 0.01)});
  }
  ASSERT_TRUE(trajectory && trajectory->touchdown && trajectory->crossing);
  const double t_land = (4.5 + std::sqrt(4.5 * 4.5 + 2 * 9.81 * 0.39)) / 9.81;
  const double error = (trajectory->touchdown->point_m - flight(p0, v0, t_land).head<2>()).norm();
  EXPECT_LT(error, 0.10);
  EXPECT_LT(error, 3.0 * trajectory->touchdown->sigma_m + 0.02);
  const double t_cross = 6.0 / 7.0;
  EXPECT_NEAR(trajectory->crossing->time_s, t_cross, 0.03);
  EXPECT_NEAR(trajectory->crossing->z_m, flight(p0, v0, t_cross).z(), 0.08);
  EXPECT_NEAR(trajectory->crossing->x_m, flight(p0, v0, t_cross).x(), 0.08);
}

TEST(BallisticTrajectory, RejectsAnOutlierWithoutRestarting) {
  const Eigen::Vector3d p0(0.0, 2.0, 0.4), v0(0.0, 6.0, 4.0);
  auto estimator = kinect3d::makeTrajectoryEstimator(ballistic());
  std::optional<fw::BallTrajectory> trajectory;
  for (int i = 0; i < 10; ++i) {
    const double t = i * kFrame_s;
    Eigen::Vector3d p = flight(p0, v0, t);
    if (i == 6) p += Eigen::Vector3d(0.6, -0.4, 0.5);  // a phantom
    trajectory = estimator->update(t, {observe(t, p, 0.01)});
  }
  ASSERT_TRUE(trajectory);
  EXPECT_EQ(trajectory->support, 9);
  EXPECT_EQ(estimator->resets(), 0);
  EXPECT_LT((trajectory->position_m - flight(p0, v0, 9 * kFrame_s)).norm(), 0.02);
}

TEST(BallisticTrajectory, ABounceStartsANewSegment) {
  kinect3d::sim::BallPhysics physics;
  physics.drag_per_m = 0.0;
  const kinect3d::sim::BallMotion motion({{0, 2, 0.11}, {0, 5, 3.0}, 0.0, false}, physics, 2.0, {});
  const double first_bounce = 2 * 3.0 / 9.81;
  auto estimator = kinect3d::makeTrajectoryEstimator(ballistic());
  std::optional<fw::BallTrajectory> before, after;
  for (int i = 1; i < 45; ++i) {
    const double t = i * kFrame_s;
    const auto trajectory = estimator->update(t, {observe(t, motion.positionAt(t), 0.005)});
    if (t < first_bounce) before = trajectory;
    if (t > first_bounce + 8 * kFrame_s && !after) after = trajectory;
  }
  ASSERT_TRUE(before && after);
  EXPECT_GE(before->support, 15);
  EXPECT_LE(after->support, 9) << "the segment restarted at the bounce";
  EXPECT_EQ(estimator->resets(), 0) << "a bounce is not a reset";
  EXPECT_NEAR(after->velocity_mps.z(), motion.velocityAt(after->time_s).z(), 0.3);
  EXPECT_LT((after->position_m - motion.positionAt(after->time_s)).norm(), 0.03);
}

TEST(BallisticTrajectory, TheBallRestingBeforeAKickIsNotPartOfTheFlight) {
  // A chip at the goalkeeper from a ball seen resting 6 m away in one frame (far away, a ball is
  // reported only in the frames a second one confirms), kicked between that frame and its first
  // flying one. Taken into the flight's first fit, the resting ball bent it: in lob_goalkeeper the
  // flight went unreported for 10 frames.
  const Eigen::Vector3d p0(0.8, 6.0, 0.11), v0(-0.6, -6.3, 5.0);
  const double kick_s = 0.2;
  const TrajectoryConfig config = ballistic();
  auto estimator = kinect3d::makeTrajectoryEstimator(config);
  estimator->update(0.133, {observe(0.133, p0)});
  int air_detections = 0;
  for (int i = 8; i < 24; ++i) {
    const double t = i * kFrame_s;
    const Eigen::Vector3d p = flight(p0, v0, t - kick_s);
    ASSERT_GT(p.z(), 0.11 + 0.08) << "the test's flight is in the air";
    const std::optional<fw::BallTrajectory> trajectory = estimator->update(t, {observe(t, p)});
    ++air_detections;
    if (air_detections < config.min_support) continue;
    SCOPED_TRACE("flying detection " + std::to_string(air_detections));
    ASSERT_TRUE(trajectory);
    EXPECT_EQ(trajectory->state, fw::BallState::kAir);
    EXPECT_EQ(trajectory->support, air_detections);
    EXPECT_LT((trajectory->position_m - p).norm(), 0.01);
  }
}

TEST(BallisticTrajectory, HungBallIsNotReportedAsFlying) {
  auto estimator = kinect3d::makeTrajectoryEstimator(ballistic());
  for (int i = 0; i < 60; ++i) {
    const double t = i * kFrame_s;
    const auto trajectory = estimator->update(t, {observe(t, {0.0, 3.0, 1.0}, 0.005)});
    EXPECT_FALSE(trajectory.has_value()) << "frame " << i;
  }
}

TEST(BallisticTrajectory, FakeFlyingObjectIsRejected) {
  // Something ball-sized gliding level through the air at 2 m/s (a poster on a moving person).
  auto estimator = kinect3d::makeTrajectoryEstimator(ballistic());
  std::optional<fw::BallTrajectory> trajectory;
  for (int i = 0; i < 30; ++i) {
    const double t = i * kFrame_s;
    trajectory = estimator->update(t, {observe(t, {-1.0 + 2.0 * t, 4.0, 1.5}, 0.01)});
  }
  EXPECT_FALSE(trajectory.has_value());
}

TEST(BallisticTrajectory, RollingBallSlowsAndCrossesTheLine) {
  TrajectoryConfig config = ballistic();
  config.rolling_decel_mps2 = 0.4;
  auto estimator = kinect3d::makeTrajectoryEstimator(config);
  std::optional<fw::BallTrajectory> trajectory;
  for (int i = 0; i < 10; ++i) {
    const double t = i * kFrame_s;
    trajectory = estimator->update(t, {observe(t, {0.3 - 0.2 * t, 3.0 - 3.0 * t, 0.11}, 0.01)});
  }
  ASSERT_TRUE(trajectory);
  EXPECT_EQ(trajectory->state, fw::BallState::kGround);
  EXPECT_FALSE(trajectory->touchdown);
  EXPECT_NEAR(trajectory->velocity_mps.y(), -3.0, 0.05);
  ASSERT_TRUE(trajectory->crossing);
  // At the last frame (t = 0.3 s) y = 2.1 m, closing at 3 m/s and slowing by 0.4 m/s^2 along
  // the velocity, (3 / |v|) of it along y: 2.1 = 3 tau - a_y tau^2 / 2.
  const double a_y = 0.4 * 3.0 / std::hypot(0.2, 3.0);
  const double tau = (3.0 - std::sqrt(9.0 - 2.0 * a_y * 2.1)) / a_y;
  EXPECT_NEAR(trajectory->crossing->time_s - trajectory->time_s, tau, 0.03);
  EXPECT_NEAR(trajectory->crossing->z_m, 0.11, 0.01);
}

TEST(BallisticTrajectory, DragOptionFitsDraggedFlights) {
  kinect3d::sim::BallPhysics physics;  // drag 0.024 per metre
  const kinect3d::sim::BallMotion motion({{0, 1.5, 0.11}, {0, 9, 5.0}, 0.0, false}, physics, 2.0, {});
  double t_land = 0.5;  // the first time the centre comes down to the radius
  while (t_land < 2.0 && motion.positionAt(t_land).z() > 0.11 + 1e-6) t_land += 0.0005;
  ASSERT_LT(t_land, 2.0);
  auto touchdownError = [&](double drag) {
    TrajectoryConfig config = ballistic();
    config.drag_per_m = drag;
    auto estimator = kinect3d::makeTrajectoryEstimator(config);
    std::optional<fw::BallTrajectory> trajectory;
    for (int i = 1; i <= 12; ++i)
      trajectory = estimator->update(i * kFrame_s, {observe(i * kFrame_s, motion.positionAt(i * kFrame_s), 0.002)});
    return (trajectory->touchdown->point_m - motion.positionAt(t_land).head<2>()).norm();
  };
  EXPECT_LT(touchdownError(0.024), 0.03);
  EXPECT_GT(touchdownError(0.0), 2.0 * touchdownError(0.024));
}

TEST(BallisticTrajectory, EstimatesTheDragOfABallItWasNotToldAbout) {
  // Balls at both ends of the physical range; the estimator's prior is the shipped 0.02 +- 0.007.
  // Half a second of flight pins the drag only loosely (the fit allows 2 cm of model error per
  // detection), so the estimate moves from the prior towards the truth and the touchdown's sigma
  // says how far it may still be off.
  for (const double true_drag : {0.010, 0.030}) {
    SCOPED_TRACE("drag " + std::to_string(true_drag));
    kinect3d::sim::BallPhysics physics;
    physics.drag_per_m = true_drag;
    const kinect3d::sim::BallMotion motion({{0, 1.5, 0.11}, {0.5, 9, 5.0}, 0.0, false}, physics, 2.0, {});
    double t_land = 0.5;
    while (t_land < 2.0 && motion.positionAt(t_land).z() > 0.11 + 1e-6) t_land += 0.0005;
    ASSERT_LT(t_land, 2.0);
    const Eigen::Vector2d landing = motion.positionAt(t_land).head<2>();
    const TrajectoryConfig shipped;
    auto estimator = kinect3d::makeTrajectoryEstimator(shipped);
    std::optional<fw::BallTrajectory> trajectory;
    for (int i = 1; i <= 15; ++i)
      trajectory = estimator->update(i * kFrame_s, {observe(i * kFrame_s, motion.positionAt(i * kFrame_s), 0.003)});
    ASSERT_TRUE(trajectory && trajectory->touchdown);
    EXPECT_LT(std::abs(trajectory->drag_per_m - true_drag), 0.7 * std::abs(shipped.drag_per_m - true_drag));
    const double error = (trajectory->touchdown->point_m - landing).norm();
    EXPECT_LT(error, 0.12);
    EXPECT_LT(error, 2.0 * trajectory->touchdown->sigma_m) << "the sigma owns the drag's uncertainty";
  }
}

TEST(BallisticTrajectory, DroppedLateAndJitteredFramesNeitherResetNorBiasTheFlight) {
  // A ball of unknown drag; 1 cm detection noise. The same flight seen cleanly, and with 20 % of
  // frames dropped, stamps jittered by up to 3 ms and every tenth frame delivered after the next.
  kinect3d::sim::BallPhysics physics;
  physics.drag_per_m = 0.015;
  const kinect3d::sim::BallMotion motion({{0.3, 1.5, 0.11}, {-0.4, 7.5, 5.0}, 0.0, false}, physics, 2.0, {});
  double t_land = 0.5;
  while (motion.positionAt(t_land).z() > 0.11 + 1e-6) t_land += 0.0005;
  const Eigen::Vector2d landing = motion.positionAt(t_land).head<2>();
  struct Outcome {
    double touchdown_error_m;
    int resets;
  };
  auto run = [&](bool degraded) {
    std::mt19937 rng(11);
    std::normal_distribution<double> noise(0.0, 0.01);
    std::uniform_real_distribution<double> unit(0.0, 1.0), jitter(-0.003, 0.003);
    auto estimator = kinect3d::makeTrajectoryEstimator(TrajectoryConfig{});
    std::optional<fw::BallTrajectory> last;
    std::vector<std::pair<double, Eigen::Vector3d>> frames;
    for (int i = 1; i <= 16; ++i) {
      const double t = i * kFrame_s;
      const Eigen::Vector3d seen = motion.positionAt(t) + drawVector3(noise, rng);
      if (degraded && unit(rng) < 0.2) continue;
      frames.emplace_back(degraded ? t + jitter(rng) : t, seen);
    }
    if (degraded) {
      for (std::size_t i = 9; i + 1 < frames.size(); i += 10) std::swap(frames[i], frames[i + 1]);
    }
    for (const auto& [t, p] : frames) {
      if (auto trajectory = estimator->update(t, {observe(t, p, 0.01)})) last = trajectory;
    }
    EXPECT_TRUE(last && last->touchdown);
    return Outcome{(last->touchdown->point_m - landing).norm(), estimator->resets()};
  };
  const Outcome clean = run(false), degraded = run(true);
  EXPECT_EQ(clean.resets, 0);
  EXPECT_EQ(degraded.resets, 0);
  EXPECT_LT(clean.touchdown_error_m, 0.25);
  EXPECT_LT(degraded.touchdown_error_m, 0.25);
  EXPECT_LT(degraded.touchdown_error_m, clean.touchdown_error_m + 0.1) << "no bias from the degraded stream";
}

TEST(BallisticTrajectory, FollowsACurvingShotAndItsCrossing) {
  // A shot at the goalkeeper with 10 rev/s of sidespin (1.6 m/s^2 sideways at 9 m/s, 0.25 m of
  // bend by the line); 1 cm detection noise. The curve is fitted with the flight: the track holds,
  // and the crossing predicted 0.3 s before arrival lands within the target, where a fit that
  // does not know spin misses by the bend.
  kinect3d::sim::BallPhysics physics;
  physics.drag_per_m = 0.02;
  physics.spin_rps = 10.0;
  const kinect3d::sim::BallMotion motion({{0.3, 6.0, 0.11}, {-0.2, -9.0, 4.4}, 0.0, false}, physics, 2.0, {});
  double t_cross = 0.0;
  while (motion.positionAt(t_cross).y() > 0.0) t_cross += 0.0005;
  const Eigen::Vector3d crossing = motion.positionAt(t_cross);
  ASSERT_GT(crossing.z(), 0.3) << "crosses the line in flight";
  auto run = [&](double curve_sigma_radps, double& crossing_error_m, int& resets) {
    TrajectoryConfig config;
    config.curve_sigma_radps = curve_sigma_radps;
    auto estimator = kinect3d::makeTrajectoryEstimator(config);
    std::mt19937 rng(5);
    std::normal_distribution<double> noise(0.0, 0.01);
    std::optional<fw::BallTrajectory> trajectory;
    for (int i = 1; i * kFrame_s <= t_cross - 0.3; ++i) {
      const double t = i * kFrame_s;
      const Eigen::Vector3d seen = motion.positionAt(t) + drawVector3(noise, rng);
      trajectory = estimator->update(t, {observe(t, seen, 0.01)});
    }
    EXPECT_TRUE(trajectory && trajectory->crossing);
    crossing_error_m =
        trajectory && trajectory->crossing
            ? Eigen::Vector2d(trajectory->crossing->x_m - crossing.x(), trajectory->crossing->z_m - crossing.z()).norm()
            : INFINITY;
    resets = estimator->resets();
    return trajectory ? trajectory->curve_radps : 0.0;
  };
  double fitted_error = 0.0, straight_error = 0.0;
  int fitted_resets = 0, straight_resets = 0;
  const double curve = run(TrajectoryConfig{}.curve_sigma_radps, fitted_error, fitted_resets);
  run(0.0, straight_error, straight_resets);
  EXPECT_EQ(fitted_resets, 0);
  EXPECT_LT(fitted_error, 0.15);
  EXPECT_LT(fitted_error, 0.5 * straight_error);
  EXPECT_NEAR(curve, physics.magnus_m * 2.0 * M_PI * physics.spin_rps, 0.1) << "curves the right way";
}

TEST(PaperTrajectory, FitsANoiseFreeParabola) {
  TrajectoryConfig config;
  config.mode = TrajectoryConfig::Mode::kPaper;
  const Eigen::Vector3d p0(0.2, 2.0, 0.3), v0(0.5, 6.0, 4.5);
  auto estimator = kinect3d::makeTrajectoryEstimator(config);
  std::optional<fw::BallTrajectory> trajectory;
  for (int i = 0; i < 8; ++i)
    trajectory = estimator->update(i * kFrame_s, {observe(i * kFrame_s, flight(p0, v0, i * kFrame_s), 1e-4)});
  ASSERT_TRUE(trajectory && trajectory->touchdown);
  const double t_land = (4.5 + std::sqrt(4.5 * 4.5 + 2 * 9.81 * 0.19)) / 9.81;
  EXPECT_LT((trajectory->touchdown->point_m - flight(p0, v0, t_land).head<2>()).norm(), 0.01);
  EXPECT_NEAR(trajectory->touchdown->time_s, t_land, 0.01);
  EXPECT_EQ(trajectory->support, 8);
}

TEST(TrajectoryScenario, GoalkeeperSeesWhereAShotCrossesItsLine) {
  // Shipped settings end to end: simulated Kinect frames -> detector -> trajectory, on the
  // goalkeeper's shot kicked by four balls whose physics is drawn across the physical ranges
  // (seeded): drag, restitution, bounce friction and sidespin.
  const fw::Config config = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", "", {});
  std::mt19937 rng(2026);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto between = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  std::vector<double> errors_m;
  for (int ball = 0; ball < 4; ++ball) {
    kinect3d::sim::Scene scene = kinect3d::sim::loadScene("shot_goalkeeper");
    scene.physics.drag_per_m = between(0.010, 0.030);
    scene.physics.restitution = between(0.5, 0.8);
    scene.physics.bounce_friction = between(0.1, 0.3);
    scene.physics.spin_rps = between(-10.0, 10.0);
    scene.noise.seed = 10 + ball;
    SCOPED_TRACE("noise seed " + std::to_string(scene.noise.seed) + ", drag " +
                 std::to_string(scene.physics.drag_per_m) + ", spin " + std::to_string(scene.physics.spin_rps) +
                 " rev/s");
    kinect3d::DetectorConfig detector = kinect3d::readDetectorConfig(config.block("kinect3d"));
    detector.ground.pose = scene.sensor_pose;
    const auto frames = kinect3d::sim::runDetectorOnScene(scene, detector);
    const kinect3d::sim::BallMotion motion(*scene.ball, scene.physics, scene.duration_s, scene.objects);
    double t_cross = scene.ball->launch_time_s;
    while (motion.positionAt(t_cross).y() > 0.0) t_cross += 0.0005;
    const Eigen::Vector3d truth = motion.positionAt(t_cross);

    auto estimator = kinect3d::makeTrajectoryEstimator(kinect3d::readTrajectoryConfig(config.block("kinect3d")));
    // Resets count from the first reported flight (the kick itself restarts the resting ball's track).
    int early_predictions = 0, resets_when_flying = -1, resets_before_crossing = 0;
    for (const auto& frame : frames) {
      const double t = scene.start_time_s + frame.truth.time_s;  // the source clock the detections carry
      const auto trajectory = estimator->update(t, frame.balls);
      if (resets_when_flying < 0 && trajectory && trajectory->state == fw::BallState::kAir) {
        resets_when_flying = estimator->resets();
      }
      if (frame.truth.time_s < t_cross) resets_before_crossing = estimator->resets();
      if (!trajectory || !trajectory->crossing || t_cross - frame.truth.time_s < 0.3) continue;
      ++early_predictions;
      errors_m.push_back(
          Eigen::Vector2d(trajectory->crossing->x_m - truth.x(), trajectory->crossing->z_m - truth.z()).norm());
      EXPECT_NEAR(trajectory->crossing->time_s - scene.start_time_s, t_cross, 0.05);
    }
    EXPECT_GE(early_predictions, 3) << "the crossing is known at least 0.3 s ahead";
    EXPECT_EQ(resets_before_crossing, resets_when_flying) << "the track holds from the kick to the line";
  }
  EXPECT_LE(fw::quantile(errors_m, 0.5), 0.15) << "the crossing target, on balls it was not told about";
}

TEST(Trajectory, RepeatedTimestampsNeverProduceNaN) {
  for (const auto mode : {TrajectoryConfig::Mode::kBallistic, TrajectoryConfig::Mode::kPaper}) {
    TrajectoryConfig config;
    config.mode = mode;
    auto estimator = kinect3d::makeTrajectoryEstimator(config);
    int answers = 0, finite = 0;
    for (int i = 0; i < 20; ++i) {
      // A recording whose stamps are all zero, then one that moves on.
      const double t = i < 10 ? 0.0 : (i - 9) * kFrame_s;
      const auto trajectory = estimator->update(t, {observe(t, flight({0, 2, 0.5}, {0, 6, 4}, i * kFrame_s), 0.01)});
      if (i < 10) continue;
      answers += trajectory.has_value();
      finite += trajectory && trajectory->position_m.allFinite() && trajectory->velocity_mps.allFinite();
    }
    EXPECT_GE(answers, 5) << "the flight is followed once time moves on";
    EXPECT_EQ(finite, answers);
  }
}

TEST(Trajectory, AClockThatJumpsBackStartsTheTrackAgainInsteadOfFreezingIt) {
  for (const auto mode : {TrajectoryConfig::Mode::kBallistic, TrajectoryConfig::Mode::kPaper}) {
    TrajectoryConfig config;
    config.mode = mode;
    auto estimator = kinect3d::makeTrajectoryEstimator(config);
    const Eigen::Vector3d p0(0.0, 2.0, 0.5), v0(0.0, 5.0, 4.0);
    std::optional<fw::BallTrajectory> before, after;
    for (int i = 0; i < 24; ++i) {
      const double flight_s = i * kFrame_s;
      // From the 12th frame on the stamps are a million seconds earlier (a clock set back).
      const double stamp_s = 1000.0 + flight_s - (i >= 12 ? 1e6 : 0.0);
      const auto trajectory = estimator->update(stamp_s, {observe(stamp_s, flight(p0, v0, flight_s), 0.01)});
      (i < 12 ? before : after) = trajectory;
    }
    ASSERT_TRUE(before.has_value());
    ASSERT_TRUE(after.has_value()) << "the flight is followed on the new time line";
    EXPECT_LT(after->time_s, 0.0) << "its answer is on the new time line, not the frozen old one";
    EXPECT_TRUE(after->position_m.allFinite());
    // A stamp that is not finite changes nothing.
    const auto unchanged = estimator->update(std::numeric_limits<double>::quiet_NaN(), {});
    ASSERT_TRUE(unchanged.has_value());
    EXPECT_DOUBLE_EQ(unchanged->time_s, after->time_s);
  }
}

TEST(BallisticTrajectory, FollowsTheFlightAmongSeveralBalls) {
  // Each frame holds the flying ball, a second ball resting on the floor, and, listed first in
  // half the frames, a ball rolling past: once a flight is fitted the estimator follows the
  // detection nearest its prediction, whatever the order.
  auto estimator = kinect3d::makeTrajectoryEstimator(ballistic());
  const Eigen::Vector3d p0(0.2, 2.0, 0.3), v0(0.5, 6.0, 4.5);
  std::optional<fw::BallTrajectory> last;
  for (int i = 0; i < 20; ++i) {
    const double t = i * kFrame_s;
    const fw::BallObservation flying = observe(t, flight(p0, v0, t));
    const fw::BallObservation resting = observe(t, {-1.0, 3.0, 0.11});
    const fw::BallObservation rolling = observe(t, {1.5 - 2.0 * t, 4.0, 0.11});
    std::vector<fw::BallObservation> balls{flying, resting, rolling};
    if (i % 2 == 1) std::swap(balls[0], balls[2]);
    last = estimator->update(t, balls);
  }
  ASSERT_TRUE(last.has_value());
  EXPECT_EQ(last->state, fw::BallState::kAir);
  EXPECT_LT((last->position_m - flight(p0, v0, last->time_s)).norm(), 0.01);
  EXPECT_EQ(last->support, 20) << "every frame's flying ball, and nothing else";
  EXPECT_EQ(estimator->resets(), 0);
}

TEST(TrajectoryConfig, ShippedDefaultsAreTheStructDefaults) {
  const fw::Config shipped = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", "", {});
  const TrajectoryConfig read = kinect3d::readTrajectoryConfig(shipped.block("kinect3d"));
  const TrajectoryConfig code;
  EXPECT_EQ(read.mode, code.mode);
  EXPECT_EQ(read.ball_radius_m, code.ball_radius_m);
  EXPECT_EQ(read.drag_per_m, code.drag_per_m);
  EXPECT_EQ(read.drag_sigma_per_m, code.drag_sigma_per_m);
  EXPECT_EQ(read.curve_sigma_radps, code.curve_sigma_radps);
  EXPECT_EQ(read.rolling_decel_mps2, code.rolling_decel_mps2);
  EXPECT_EQ(read.gate_sigma, code.gate_sigma);
  EXPECT_EQ(read.model_sigma_m, code.model_sigma_m);
  EXPECT_EQ(read.max_gravity_error_mps2, code.max_gravity_error_mps2);
  EXPECT_EQ(read.min_flight_speed_mps, code.min_flight_speed_mps);
  EXPECT_EQ(read.min_support, code.min_support);
  EXPECT_EQ(read.max_gap_s, code.max_gap_s);
  EXPECT_EQ(read.history, code.history);
}

TEST(TrajectoryConfig, ModeNames) {
  EXPECT_EQ(kinect3d::trajectoryModeFromString("paper"), TrajectoryConfig::Mode::kPaper);
  EXPECT_THROW(kinect3d::trajectoryModeFromString("kalman"), std::invalid_argument);
}

}  // namespace
