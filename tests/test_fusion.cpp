// The fusion on exact and noisy synthetic data: each measurement model, the phantom of a ball in
// the air, late measurements, a turning robot, a lost and re-acquired ball, a static floater, the
// mode switches and the omni latency it learns.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <random>

#include "framework_api/pose_history.h"
#include "fusion/ball_fusion.h"
#include "fusion/measurements.h"
#include "random_draws.h"

namespace {

constexpr double kT0 = 1.7e9;  // source clock of the synthetic runs
constexpr double kRadius = 0.11;
constexpr double kKinectSigma_m = 0.02;

fw::RobotPose poseAt(double x, double y, double theta, double t) {
  fw::RobotPose pose{x, y, theta, {}, std::nullopt};
  pose.stamp.source_time_s = t;
  return pose;
}

// One mode's Gaussian: position and velocity x, every variance the same, and its weight.
fusion::Hypothesis hypothesis(fw::BallState mode, const fusion::Vector6d& x, double variance, double weight = 1.0) {
  fusion::Hypothesis h;
  h.mode = mode;
  h.x = x;
  h.P = variance * fusion::Matrix6d::Identity();
  h.weight = weight;
  return h;
}

fusion::Vector6d state(double x, double y, double z, double vx = 0.0, double vy = 0.0, double vz = 0.0) {
  return (fusion::Vector6d() << x, y, z, vx, vy, vz).finished();
}

// A true ball: position in the field frame at time t.
using Truth = std::function<Eigen::Vector3d(double)>;

// The omni camera's exact view of a centre p_F from a robot pose: the ray through the centre
// meets the plane of resting centres.
fw::OmniBallObservation omniView(const Eigen::Vector3d& p_F, const fw::RobotPose& pose, double viewpoint_m) {
  const Eigen::Vector3d p_R = pose.T_F_R().inverse() * p_F;
  fw::OmniBallObservation omni;
  omni.bearing_rad = std::atan2(-p_R.x(), p_R.y());
  omni.distance_m = p_R.head<2>().norm() * (viewpoint_m - kRadius) / (viewpoint_m - p_R.z());
  omni.source = "omni";
  return omni;
}

fw::BallObservation kinectView(const Eigen::Vector3d& p_F, const fw::RobotPose& pose, std::mt19937& random,
                               double sigma_m = kKinectSigma_m) {
  std::normal_distribution<double> noise(0.0, sigma_m);
  const Eigen::Vector3d p_R = pose.T_F_R().inverse() * p_F + drawVector3(noise, random);
  const fw::BallState state = p_R.z() > kRadius + 0.08 ? fw::BallState::kAir : fw::BallState::kGround;
  return fw::BallObservation::inRobotFrame(p_R, sigma_m * sigma_m * Eigen::Matrix3d::Identity(), state, "kinect3d", {});
}

// A real ball's physics, which the fusion's configured ball only approximates.
struct TruePhysics {
  double drag_per_m = 0.024;
  double restitution = 0.6;
  double bounce_friction = 0.2;
  double rolling_decel_mps2 = 0.4;
};

// A lob from the floor: ballistic with drag, then bouncing, then rolling.
Eigen::Vector3d lobAt(double t, double kick_t, Eigen::Vector3d p0, Eigen::Vector3d v0,
                      const TruePhysics& physics = {}) {
  if (t <= kick_t) return p0;
  fw::BallTrajectory flight;
  flight.state = fw::BallState::kAir;
  flight.position_m = p0;
  flight.velocity_mps = v0;
  flight.drag_per_m = physics.drag_per_m;
  flight.time_s = kick_t;
  // March to t, reflecting at the floor with the restitution and friction.
  const double step = 0.001;
  double now = kick_t;
  while (now + step <= t) {
    flight = flight.movedTo(now + step);
    now += step;
    if (flight.state == fw::BallState::kAir && flight.position_m.z() < kRadius && flight.velocity_mps.z() < 0) {
      flight.position_m.z() = kRadius;
      flight.velocity_mps.z() *= -physics.restitution;
      flight.velocity_mps.head<2>() *= 1.0 - physics.bounce_friction;
      if (flight.velocity_mps.z() < 0.5) {
        flight.velocity_mps.z() = 0.0;
        flight.state = fw::BallState::kGround;
        flight.rolling_decel_mps2 = physics.rolling_decel_mps2;
      }
    }
  }
  return flight.movedTo(t).position_m;
}

fusion::FusionConfig testConfig() {
  fusion::FusionConfig config;
  config.omni.estimate_latency = false;
  return config;
}

struct FedRun {
  std::vector<fusion::FusionUpdate> updates;
  std::vector<Eigen::Vector3d> truth;  // at each update's time
  std::vector<bool> from_teammate;     // which updates a teammate's message made (feedWithTeammate)
};

// Whether a sensor sees the ball at p at time t.
using Sees = std::function<bool(double, const Eigen::Vector3d&)>;

// One 30 Hz step at t of this robot's own sensors watching `truth` from `pose(t)`: a Kinect frame (the
// ball while kinect_sees) and, with_omni, an omni image half a frame later (the ball while it is in
// the camera's view and omni_sees), stamped omni_stamp_late_s late.
// shirts_F: orange things on the floor that the omni camera takes for balls in every image.
void feedOwnStep(fusion::BallFusion& fusion, const Truth& truth, double t,
                 const std::function<fw::RobotPose(double)>& pose, const Sees& kinect_sees, const Sees& omni_sees,
                 bool with_omni, double omni_stamp_late_s, std::mt19937& random, FedRun& run,
                 const std::vector<Eigen::Vector3d>& shirts_F = {}) {
  fusion.addPose(pose(t));
  const Eigen::Vector3d p = truth(t);
  std::vector<fw::BallObservation> kinect;
  if (kinect_sees(t, p)) kinect.push_back(kinectView(p, pose(t), random));
  run.updates.push_back(fusion.addKinectFrame(t, kinect));
  run.truth.push_back(p);
  run.from_teammate.push_back(false);
  if (!with_omni) return;
  const double t_omni = t + 0.5 / 30.0;
  const Eigen::Vector3d q = truth(t_omni);
  std::vector<fw::OmniBallObservation> omni;
  if (q.z() < 0.6 && omni_sees(t_omni, q)) omni.push_back(omniView(q, pose(t_omni), 0.75));
  for (const Eigen::Vector3d& shirt_F : shirts_F) omni.push_back(omniView(shirt_F, pose(t_omni), 0.75));
  fusion.addPose(pose(t_omni));
  run.updates.push_back(fusion.addOmniFrame(t_omni + omni_stamp_late_s, omni));
  run.truth.push_back(q);
  run.from_teammate.push_back(false);
}

// Feeds a Kinect at 30 Hz and an omni camera at 30 Hz (half a frame later) watching `truth` from
// a robot at `pose(t)`, in time order. The Kinect only sees the ball while kinect_sees(t, p).
FedRun feed(fusion::BallFusion& fusion, const Truth& truth, double duration_s,
            const std::function<fw::RobotPose(double)>& pose, const Sees& kinect_sees, bool with_omni = true,
            double omni_stamp_late_s = 0.0) {
  std::mt19937 random(7);
  FedRun run;
  const Sees omni_sees = [](double, const Eigen::Vector3d&) { return true; };
  for (int i = 0; i * (1.0 / 30) < duration_s; ++i) {
    feedOwnStep(fusion, truth, kT0 + i / 30.0, pose, kinect_sees, omni_sees, with_omni, omni_stamp_late_s, random, run);
  }
  return run;
}

auto standingAtOrigin = [](double t) { return poseAt(0.0, 0.0, 0.0, t); };
auto always = [](double, const Eigen::Vector3d&) { return true; };
auto never = [](double, const Eigen::Vector3d&) { return false; };

}  // namespace

TEST(PoseHistory, PosesAlmostAtTheSameTimeGiveAFinitePoseAtAnyTime) {
  // Found by tests/fuzz/fuzz_stamps.cpp: two poses 1e-320 s apart, asked for a time long after them.
  fw::PoseHistory history;
  history.add(fw::RobotPose{-4.0, 0.0, 0.0, {-1.9857619387229293e-307, 0.0}, std::nullopt});
  history.add(fw::RobotPose{-0.8, 0.8, 0.0, {-1.9857619387230415e-307, 0.0}, std::nullopt});
  for (const double t : {2.7e9, 0.0, 0.05, -1.0}) {
    const fw::RobotPose pose = history.at(t);
    EXPECT_TRUE(std::isfinite(pose.x_m) && std::isfinite(pose.y_m) && std::isfinite(pose.theta_rad)) << t;
  }
  // Poses a normal interval apart are still extrapolated, at most 0.1 s.
  fw::PoseHistory moving;
  moving.add(fw::RobotPose{0.0, 0.0, 0.0, {10.0, 10.0}, std::nullopt});
  moving.add(fw::RobotPose{0.1, 0.0, 0.0, {10.1, 10.1}, std::nullopt});
  EXPECT_NEAR(moving.at(10.15).x_m, 0.15, 1e-9);
  EXPECT_NEAR(moving.at(20.0).x_m, 0.2, 1e-9);
}

TEST(FusionMeasurements, KinectPositionIsMovedToTheFieldWithThePoseAndItsCovarianceTurned) {
  const fw::RobotPose pose = poseAt(1.0, 2.0, M_PI / 2, 0.0);              // facing the field's -x
  Eigen::Matrix3d cov_R = Eigen::Vector3d(0.01, 0.09, 0.04).asDiagonal();  // long along the robot's y
  fusion::PoseConfig exact;
  exact.sigma_xy_m = exact.sigma_theta_rad = 0.0;
  const fusion::PositionMeasurement m({0.0, 3.0, 0.5}, cov_R, pose, exact);
  EXPECT_TRUE(m.value().isApprox(Eigen::Vector3d(-2.0, 2.0, 0.5), 1e-12));
  const Eigen::MatrixXd R = m.noise(m.value());
  EXPECT_NEAR(R(0, 0), 0.09, 1e-12);  // the robot's y is the field's -x
  EXPECT_NEAR(R(1, 1), 0.01, 1e-12);
  EXPECT_NEAR(R(2, 2), 0.04, 1e-12);
  // The pose's heading error widens the point across its bearing from the robot: 3 m away.
  fusion::PoseConfig heading;
  heading.sigma_xy_m = 0.0;
  heading.sigma_theta_rad = 0.01;
  const fusion::PositionMeasurement turned({0.0, 3.0, 0.5}, cov_R, pose, heading);
  EXPECT_NEAR(turned.noise(m.value())(1, 1), 0.01 + 0.03 * 0.03, 1e-12);
}

TEST(FusionMeasurements, OmniPredictsTheGroundBallAndThePhantomOfABallInTheAir) {
  const fw::RobotPose pose = poseAt(-1.0, 0.5, 0.3, 0.0);
  fusion::OmniConfig omni;
  omni.viewpoint_height_m = 0.75;
  const fusion::OmniMeasurement m(fw::OmniBallObservation{}, pose, pose, omni, fusion::PoseConfig{}, kRadius, 0.0);
  // On the floor: bearing and distance of the ball itself.
  const Eigen::Vector3d ground_R(-1.0, 2.0, kRadius);
  const Eigen::VectorXd on_floor = m.predict(pose.T_F_R() * ground_R);
  EXPECT_NEAR(on_floor[0], std::atan2(1.0, 2.0), 1e-12);
  EXPECT_NEAR(on_floor[1], std::sqrt(5.0), 1e-12);
  // 0.43 m up, 2.24 m away: the ray from 0.75 m meets the resting plane twice as far out.
  const Eigen::Vector3d air_R(-1.0, 2.0, 0.43);
  const Eigen::VectorXd in_air = m.predict(pose.T_F_R() * air_R);
  EXPECT_NEAR(in_air[0], on_floor[0], 1e-12);
  EXPECT_NEAR(in_air[1], std::sqrt(5.0) * (0.75 - kRadius) / (0.75 - 0.43), 1e-12);
  // Bearings wrap: just either side of the robot's back are 0.02 rad apart, not 2 pi.
  Eigen::VectorXd a(2), b(2);
  a << M_PI - 0.01, 1.0;
  b << -M_PI + 0.01, 1.0;
  EXPECT_NEAR(m.residual(a, b)[0], -0.02, 1e-12);
  EXPECT_NEAR(m.ownMotionRate(pose.T_F_R() * ground_R).norm(), 0.0, 1e-12) << "a robot standing still";
  // The robot turning at 1.5 rad/s turns a still ball's bearing the other way, its distance not.
  const double step_s = fusion::OmniMeasurement::kPoseRateStep_s;
  const fusion::OmniMeasurement turning(fw::OmniBallObservation{}, pose, poseAt(-1.0, 0.5, 0.3 + 1.5 * step_s, step_s),
                                        omni, fusion::PoseConfig{}, kRadius, 0.0);
  EXPECT_NEAR(turning.ownMotionRate(pose.T_F_R() * ground_R)[0], -1.5, 1e-9);
  EXPECT_NEAR(turning.ownMotionRate(pose.T_F_R() * ground_R)[1], 0.0, 1e-9);
}

TEST(FusionFilter, ABallAboveTheOmniViewNeitherExplainsNorIsMovedByAnOmniBall) {
  const fw::RobotPose pose = poseAt(0.0, 0.0, 0.0, kT0);
  const fusion::FusionConfig config = testConfig();
  // Two modes: rolling 3 m out, or flying just under the mirror's viewpoint above the same spot,
  // where a phantom's distance runs away with the height and a linearised update would throw the
  // ball about.
  const fusion::Hypothesis rolling = hypothesis(fw::BallState::kGround, state(0.0, 3.0, kRadius), 0.01, 0.5);
  const fusion::Hypothesis flying = hypothesis(fw::BallState::kAir, state(0.0, 3.0, 0.72), 0.01, 0.5);
  const fusion::OmniMeasurement far_ball(omniView(Eigen::Vector3d(0.0, 5.0, kRadius), pose, 0.75), pose, pose,
                                         config.omni, config.pose, kRadius, 0.0);
  EXPECT_TRUE(std::isinf(fusion::BallFilter::fit({flying}, far_ball).mahalanobis)) << "never associated by that branch";
  fusion::BallFilter filter(config.motion, kT0, {rolling, flying});
  filter.update(filter.branchesAt(kT0), kT0, far_ball);
  EXPECT_EQ(filter.airProbability(), 0.0) << "the omni ball is credited to the ball it can see";
}

TEST(FusionFilter, AFlightThatPredictedTheOmniPhantomOutweighsAGroundBallSittingOnIt) {
  // Behind the robot only the omni camera sees the hop: 4 m out, 0.25 m up, its phantom 5.1 m out.
  // The flight predicted it; a ground ball that has followed the phantoms out there explains it too.
  // The looser hold the update takes on a phantom is no measurement noise: weighed by it, the flight
  // lost to the ground ball, and the world ball sat on the phantom.
  const fw::RobotPose pose = poseAt(0.0, 0.0, 0.0, kT0);
  const fusion::FusionConfig config = testConfig();
  const Eigen::Vector3d ball(0.0, 4.0, 0.25);
  const fusion::OmniMeasurement phantom(omniView(ball, pose, 0.75), pose, pose, config.omni, config.pose, kRadius, 0.0);
  const Eigen::Vector3d phantom_ground = phantom.groundBall_F();
  ASSERT_GT(phantom_ground.y() - ball.y(), 1.0) << "a phantom well beyond the ball";
  fusion::Hypothesis flying = hypothesis(fw::BallState::kAir, state(0.0, 4.0, 0.25, 0.0, -2.0, 0.0), 0.0025, 0.5);
  flying.P(2, 2) = 1e-4;  // a hop's height, which the bounce and gravity tell
  const fusion::Hypothesis rolling =
      hypothesis(fw::BallState::kGround, state(0.0, phantom_ground.y(), kRadius, 0.0, -2.0), 0.09, 0.5);
  fusion::BallFilter filter(config.motion, kT0, {flying, rolling});
  filter.update(filter.branchesAt(kT0), kT0, phantom);
  EXPECT_GT(filter.airProbability(), 0.5) << "the phantom confirms the flight";
  EXPECT_LT((filter.best().x.head<3>() - ball).norm(), 0.1) << "the world ball stays on the flight";
}

TEST(FusionFilter, AnOmniBallNeverPutsAFlyingBallBelowTheFloor) {
  // Believed 0.3 m up and falling fast, with its height and speed uncertain, the ball is on the floor
  // nearer the robot. The ray to it goes on below the floor past the ball: unconstrained, the update
  // follows it there (a world ball 1.7 m under the floor came so from a live run's omni camera).
  const fw::RobotPose pose = poseAt(0.0, 0.0, 0.0, kT0);
  const fusion::FusionConfig config = testConfig();
  fusion::Hypothesis falling = hypothesis(fw::BallState::kAir, state(0.0, 2.0, 0.3, 0.0, 0.0, -4.0), 0.25);
  falling.P.bottomRightCorner<3, 3>() = 9.0 * Eigen::Matrix3d::Identity();
  const fusion::OmniMeasurement on_floor(omniView({0.0, 1.2, kRadius}, pose, 0.75), pose, pose, config.omni,
                                         config.pose, kRadius, 0.0);
  fusion::BallFilter filter(config.motion, kT0, {falling});
  filter.update(filter.branchesAt(kT0 + 0.05), kT0 + 0.05, on_floor);
  for (const fusion::Hypothesis& h : filter.hypotheses()) {
    EXPECT_GE(h.x.z(), kRadius - 1e-9) << fw::toString(h.mode) << " at " << h.x.head<3>().transpose();
  }
}

TEST(FusionFilter, ABranchWithoutWeightThatExplainsAMeasurementBestLeavesTheBallANumber) {
  // Found by fuzz_stamps: the only branch with weight lies far from the measurement, one without any
  // lies on it. Its likelihood relative to the weighted branch is e^1000: a weight of 0 times that is
  // not a number, and every state merged with it neither.
  const fw::RobotPose pose = poseAt(0.0, 0.0, 0.0, kT0);
  const fusion::FusionConfig config = testConfig();
  const fusion::Hypothesis far = hypothesis(fw::BallState::kGround, state(8.0, 3.0, kRadius), 1e-4, 1.0);
  const fusion::Hypothesis near = hypothesis(fw::BallState::kGround, state(0.0, 3.0, kRadius), 1e-4, 0.0);
  const fusion::PositionMeasurement seen(Eigen::Vector3d(0.0, 3.0, kRadius), 1e-4 * Eigen::Matrix3d::Identity(), pose,
                                         config.pose);
  fusion::BallFilter filter(config.motion, kT0, {far, near});
  filter.update({far, near}, kT0, seen);
  for (const fusion::Hypothesis& h : filter.hypotheses()) {
    EXPECT_TRUE(std::isfinite(h.weight));
    EXPECT_TRUE(h.x.allFinite());
  }
  EXPECT_TRUE(filter.best().x.allFinite());
}

TEST(FusionFilter, AnOmniPhantomMovesAFlyingBallAlongItsRayNotPastTheMirrorsView) {
  const fw::RobotPose pose = poseAt(0.0, 0.0, 0.0, kT0);
  const fusion::FusionConfig config = testConfig();
  // Believed 0.2 m up (+- 0.2 m), the ball is 0.55 m up: its phantom lies 6.4 m out, not the 2.3 m
  // predicted. Linearised once about the belief, the update puts the ball above the mirror's view.
  fusion::Hypothesis flying = hypothesis(fw::BallState::kAir, state(0.0, 2.0, 0.2, 0.0, -3.0, 3.0), 0.04);
  flying.P.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d truth(0.0, 2.0, 0.55);
  const fusion::OmniMeasurement phantom(omniView(truth, pose, 0.75), pose, pose, config.omni, config.pose, kRadius,
                                        0.0);
  fusion::BallFilter filter(config.motion, kT0, {flying});
  filter.update(filter.branchesAt(kT0), kT0, phantom);
  const Eigen::Vector3d updated = filter.best().x.head<3>();
  EXPECT_LE(updated.z(), config.omni.max_height_m) << "where the camera sees it";
  EXPECT_GT(updated.z(), 0.4) << "higher than believed, as the phantom says";
  EXPECT_LT((updated - truth).head<2>().norm(), 0.1) << "on its own spot, not out at the phantom";
}

TEST(FusionFilter, AMeasurementIsLikelierOnTheTrackThatExplainsItThanOnOneThatExplainsAnything) {
  const fw::RobotPose pose = poseAt(0.0, 0.0, 0.0, kT0);
  const fusion::PositionMeasurement ball(Eigen::Vector3d(0.05, 3.0, kRadius), 1e-4 * Eigen::Matrix3d::Identity(), pose,
                                         fusion::PoseConfig{});
  // Seen a moment ago; unseen for long, a metre either way.
  const fusion::Hypothesis known = hypothesis(fw::BallState::kGround, state(0.0, 3.0, kRadius), 1e-3);
  const fusion::Hypothesis stale = hypothesis(fw::BallState::kGround, state(0.0, 3.5, kRadius), 1.0);
  const fusion::MeasurementFit on_known = fusion::BallFilter::fit({known}, ball);
  const fusion::MeasurementFit on_stale = fusion::BallFilter::fit({stale}, ball);
  ASSERT_LT(on_stale.mahalanobis, on_known.mahalanobis) << "in sigmas the stale track is nearer";
  EXPECT_GT(on_known.log_likelihood, on_stale.log_likelihood + 3.0) << "but the known track explains the ball";
}

TEST(FusionFilter, ABallTheOmniCameraDoesNotSeeIsMoreLikelyAboveItsView) {
  const fusion::FusionConfig config = testConfig();
  const fusion::Hypothesis rolling = hypothesis(fw::BallState::kGround, state(0.0, 3.0, kRadius), 0.01, 0.9);
  const fusion::Hypothesis flying =
      hypothesis(fw::BallState::kAir, state(0.0, 3.0, 1.0, 0.0, 2.0, 3.0), 0.01, 0.1);  // rising 1 m up
  fusion::BallFilter filter(config.motion, kT0, {rolling, flying});
  const auto seen_by_omni = [&](const fusion::Hypothesis& h) {
    return config.omni.detection_probability * fusion::omniVisibleProbability(h, config.omni);
  };
  for (int i = 1; i <= 3; ++i) filter.notSeen(kT0 + i / 30.0, seen_by_omni);
  EXPECT_GT(filter.airProbability(), 0.9) << "three images without the ball: it flies above the mirror's view";
  EXPECT_DOUBLE_EQ(filter.time(), kT0) << "looking changes how likely each mode is, not where the ball is";
}

TEST(FusionFilter, ABounceFromAHighFallHopsOnAndALowOneEndsTheHops) {
  const fusion::FusionConfig config = testConfig();
  // Touching down at 4 m/s no restitution within reason leaves the ball rolling; at 1.2 m/s it
  // would take a restitution 3 sigma above the configured one to hop 5 cm.
  fusion::BallFilter high(config.motion, kT0,
                          {hypothesis(fw::BallState::kAir, state(0.0, 3.0, 0.2, 0.0, 1.0, -4.0), 1e-4)});
  high.predict(kT0 + 0.05);
  EXPECT_GT(high.airProbability(), 0.95) << "a ball falling fast bounces";
  fusion::BallFilter low(config.motion, kT0,
                         {hypothesis(fw::BallState::kAir, state(0.0, 3.0, 0.13, 0.0, 1.0, -1.2), 1e-4)});
  low.predict(kT0 + 0.05);
  EXPECT_LT(low.airProbability(), 0.05) << "a ball falling slowly rolls on";
}

TEST(FusionFilter, ABounceHappensWhereTheFlightItselfReachesTheFloor) {
  // The touchdown is searched within each step, to 1e-5 s: the bounce's hop then starts where the
  // flight's own propagation first brings the centre down to the radius. Falls and rises, gentle and
  // fast, with little and much drag, the floor reached early or late in the step.
  struct Drop {
    fusion::Vector6d x;
    double drag_per_m, after_touchdown_s;
  };
  const std::vector<Drop> drops = {{state(0.0, 3.0, 0.5, 0.0, 6.0, -1.0), 0.02, 0.01},
                                   {state(0.0, 3.0, 0.3, 1.0, 2.0, 2.0), 0.02, 0.002},
                                   {state(0.0, 3.0, 1.2, 0.0, 15.0, -3.0), 0.035, 0.02},
                                   {state(0.0, 3.0, 0.112, 0.5, 4.0, -0.5), 0.012, 0.03},
                                   {state(0.0, 3.0, 0.9, -3.0, 9.0, 4.0), 0.03, 0.001}};
  for (const Drop& drop : drops) {
    fusion::FusionConfig config = testConfig();
    config.motion.drag_per_m = drop.drag_per_m;
    fw::BallTrajectory flight;
    flight.time_s = kT0;
    flight.position_m = drop.x.head<3>();
    flight.velocity_mps = drop.x.tail<3>();
    flight.drag_per_m = drop.drag_per_m;
    // The flight's own touchdown, to a nanosecond: the first millisecond that ends below, bisected.
    double lo_s = 0.0;
    while (flight.movedTo(kT0 + lo_s + 1e-3).position_m.z() >= kRadius) lo_s += 1e-3;
    double hi_s = lo_s + 1e-3;
    for (int i = 0; i < 60; ++i) {
      const double mid_s = 0.5 * (lo_s + hi_s);
      (flight.movedTo(kT0 + mid_s).position_m.z() < kRadius ? hi_s : lo_s) = mid_s;
    }
    fw::BallTrajectory hop = flight.movedTo(kT0 + hi_s);
    hop.position_m.z() = kRadius;
    hop.velocity_mps.z() *= -config.motion.restitution;
    hop.velocity_mps.head<2>() *= 1.0 - config.motion.bounce_friction;
    const double t_s = kT0 + hi_s + drop.after_touchdown_s;
    const fusion::BallFilter filter(config.motion, kT0, {hypothesis(fw::BallState::kAir, drop.x, 1e-4)});
    const std::vector<fusion::Hypothesis> branches = filter.branchesAt(t_s);
    const auto bounce = std::find_if(branches.begin(), branches.end(),
                                     [](const fusion::Hypothesis& h) { return h.mode == fw::BallState::kAir; });
    ASSERT_NE(bounce, branches.end());
    // Within 1e-5 s of the touchdown the hop starts off by at most the ball's speed times that.
    const double tolerance_m = 2e-5 * drop.x.tail<3>().norm() + 1e-9;
    EXPECT_LT((bounce->x.head<3>() - hop.movedTo(t_s).position_m).norm(), tolerance_m)
        << "drop from " << drop.x.transpose() << ": " << bounce->x.head<3>().transpose() << " against "
        << hop.movedTo(t_s).position_m.transpose();
  }
}

TEST(FusionFilter, AFlightCarriedLongUnseenBouncesOnInOneStepAsInManySteps) {
  // The world's ball is carried to its time from the last measurement, however long ago: a ball
  // falling at 2.5 m/s and rolling out at 4.7 m/s, carried a second in one step, had stood at its
  // second touchdown, falling, from then on.
  const fusion::FusionConfig config = testConfig();
  const fusion::Hypothesis falling = hypothesis(fw::BallState::kAir, state(0.0, -7.0, 0.14, 0.0, -4.7, -2.5), 1e-4);
  fusion::BallFilter at_once(config.motion, kT0, {falling});
  fusion::BallFilter frame_by_frame(config.motion, kT0, {falling});
  at_once.predict(kT0 + 1.0);
  for (int i = 1; i <= 30; ++i) frame_by_frame.predict(kT0 + i / 30.0);
  const Eigen::Vector3d once = at_once.best().x.head<3>(), stepped = frame_by_frame.best().x.head<3>();
  EXPECT_LT(once.y(), -10.0) << "rolled on: " << once.transpose();
  EXPECT_LT((once - stepped).norm(), 0.3) << once.transpose() << " against " << stepped.transpose();
}

TEST(FusionFilter, AHopLowerThanARobotNoticesIsNotAFlight) {
  const fusion::BallFilter filter(fusion::MotionConfig{}, kT0, {});
  auto hops = [&](fw::BallState mode, double z, double vz) {
    return filter.hopsNoticeably(hypothesis(mode, state(0.0, 3.0, z, 0.0, 1.0, vz), 1e-4));
  };
  EXPECT_TRUE(hops(fw::BallState::kAir, kRadius, 2.0)) << "kicked up: it will rise 20 cm";
  EXPECT_FALSE(hops(fw::BallState::kAir, kRadius, 0.5)) << "it will rise 1.3 cm";
  EXPECT_TRUE(hops(fw::BallState::kAir, kRadius + 0.02, -3.0)) << "it comes down fast and bounces high";
  EXPECT_FALSE(hops(fw::BallState::kAir, kRadius + 0.02, -0.6)) << "the end of the last hop";
  EXPECT_TRUE(hops(fw::BallState::kAir, 1.0, -0.6)) << "a metre up";
  EXPECT_FALSE(hops(fw::BallState::kGround, kRadius, 0.0));
}

TEST(FusionPoseHistory, InterpolatesAcrossTheTurnAndExtrapolatesOnlyALittle) {
  fw::PoseHistory poses;
  EXPECT_TRUE(poses.at(5.0).T_F_R().isApprox(Eigen::Isometry3d::Identity()));
  poses.add(poseAt(0.0, 0.0, M_PI - 0.1, 1.0));
  poses.add(poseAt(2.0, 0.0, -M_PI + 0.1, 2.0));  // turned through the back, not the front
  const fw::RobotPose mid = poses.at(1.5);
  EXPECT_NEAR(mid.x_m, 1.0, 1e-12);
  EXPECT_NEAR(std::abs(mid.theta_rad), M_PI, 1e-9);
  EXPECT_NEAR(poses.at(5.0).x_m, 2.0 + 2.0 * fw::PoseHistory::kMaxExtrapolation_s, 1e-9);
  EXPECT_NEAR(poses.at(0.0).x_m, 0.0, 1e-12);
}

TEST(Fusion, ARollingBallSeenByBothIsConfirmedPublishedAndAccurate) {
  fusion::BallFusion fusion(testConfig());
  const Truth rolling = [](double t) { return Eigen::Vector3d(-1.0 + 1.5 * (t - kT0), 3.0, kRadius); };
  const FedRun run = feed(fusion, rolling, 2.0, standingAtOrigin, always);
  EXPECT_FALSE(run.updates[0].ball) << "one measurement is not a confirmed ball";
  ASSERT_TRUE(run.updates.back().ball);
  const fw::FusedBall& ball = *run.updates.back().ball;
  EXPECT_LT((ball.position_F - run.truth.back()).norm(), 0.05);
  EXPECT_LT((ball.velocity_F - Eigen::Vector3d(1.5, 0, 0)).norm(), 0.2);
  EXPECT_EQ(ball.state, fw::BallState::kGround);
  EXPECT_EQ(ball.sources, (std::vector<std::string>{"kinect3d", "omni"}));
  EXPECT_TRUE(ball.position_R.isApprox(ball.position_F, 1e-9)) << "the robot stands at the origin facing +y";
}

TEST(Fusion, ALobIsFollowedThroughTheAirAndItsOmniPhantomNeverBecomesTheBall) {
  fusion::BallFusion fusion(testConfig());
  const Eigen::Vector3d p0(0.2, 2.0, kRadius), v0(0.0, 4.0, 4.5);
  const Truth lob = [&](double t) { return lobAt(t, kT0 + 0.5, p0, v0); };
  const FedRun run = feed(fusion, lob, 2.5, standingAtOrigin, always);
  int air_updates = 0, on_phantom = 0, switched_to_air_after = -1, kick_index = -1;
  for (std::size_t i = 0; i < run.updates.size(); ++i) {
    const auto& ball = run.updates[i].ball;
    const Eigen::Vector3d& truth = run.truth[i];
    if (truth.z() > kRadius + 0.01 && kick_index < 0) kick_index = static_cast<int>(i);
    if (!ball) continue;
    if (truth.z() > 0.3) {
      ++air_updates;
      EXPECT_LT((ball->position_F - truth).norm(), 0.10) << "update " << i;
      // The omni's phantom of this ball lies farther out along the same bearing.
      const double d = truth.head<2>().norm();
      const double phantom_d = d * (0.75 - kRadius) / (0.75 - std::min(truth.z(), 0.6));
      if (std::abs(ball->position_F.head<2>().norm() - phantom_d) < 0.3 && phantom_d - d > 0.5) ++on_phantom;
    }
    if (kick_index >= 0 && switched_to_air_after < 0 && ball->state == fw::BallState::kAir) {
      switched_to_air_after = static_cast<int>(i) - kick_index;
    }
  }
  EXPECT_GT(air_updates, 20);
  EXPECT_EQ(on_phantom, 0);
  EXPECT_GE(switched_to_air_after, 0);
  EXPECT_LE(switched_to_air_after, 4) << "two frames of each sensor";
  ASSERT_TRUE(run.updates.back().ball);
  EXPECT_EQ(run.updates.back().ball->state, fw::BallState::kGround) << "rolling again at the end";
  EXPECT_LT((run.updates.back().ball->position_F - run.truth.back()).norm(), 0.1);
}

TEST(Fusion, TheOmniAloneFollowsAGroundBallAndKeepsALobOnItsBearing) {
  fusion::BallFusion fusion(testConfig());
  const Eigen::Vector3d p0(-2.0, -1.0, kRadius), v0(0.5, -2.0, 0.0);
  const Truth rolling = [&](double t) { return p0 + v0 * (t - kT0); };
  const FedRun run = feed(fusion, rolling, 1.5, standingAtOrigin, never);
  ASSERT_TRUE(run.updates.back().ball);
  EXPECT_LT((run.updates.back().ball->position_F - run.truth.back()).norm(), 0.15);
  EXPECT_EQ(run.updates.back().ball->sources, std::vector<std::string>{"omni"});
}

TEST(Fusion, LateMeasurementsGiveTheSameWorldAsInOrderOnes) {
  const Eigen::Vector3d p0(0.2, 2.0, kRadius), v0(0.3, 3.0, 3.0);
  const Truth lob = [&](double t) { return lobAt(t, kT0 + 0.3, p0, v0); };
  fusion::BallFusion in_order(testConfig());
  feed(in_order, lob, 1.5, standingAtOrigin, always);

  // The same frames, every omni frame delivered 80 ms late (after the Kinect frames that follow it).
  fusion::BallFusion late(testConfig());
  std::mt19937 random(7);
  std::vector<std::pair<double, std::vector<fw::OmniBallObservation>>> held;
  for (int i = 0; i * (1.0 / 30) < 1.5; ++i) {
    const double t = kT0 + i / 30.0;
    late.addPose(standingAtOrigin(t));
    std::vector<fw::BallObservation> kinect{kinectView(lob(t), standingAtOrigin(t), random)};
    late.addKinectFrame(t, kinect);
    const double t_omni = t + 0.5 / 30.0;
    std::vector<fw::OmniBallObservation> omni;
    if (lob(t_omni).z() < 0.6) omni.push_back(omniView(lob(t_omni), standingAtOrigin(t_omni), 0.75));
    late.addPose(standingAtOrigin(t_omni));
    held.emplace_back(t_omni, omni);
    while (!held.empty() && held.front().first < t - 0.08) {
      late.addOmniFrame(held.front().first, held.front().second);
      held.erase(held.begin());
    }
  }
  for (const auto& [t, omni] : held) late.addOmniFrame(t, omni);
  ASSERT_TRUE(in_order.latest().ball);
  ASSERT_TRUE(late.latest().ball);
  EXPECT_DOUBLE_EQ(late.latest().time_s, in_order.latest().time_s);
  EXPECT_TRUE(late.latest().ball->position_F.isApprox(in_order.latest().ball->position_F, 1e-12));
  EXPECT_EQ(late.lateFramesDropped(), 0);
  // Beyond max_delay_s a frame is refused and counted, and the world is left as it was.
  const Eigen::Vector3d before = late.latest().ball->position_F;
  late.addOmniFrame(late.latest().time_s - 0.5, {omniView({3.0, 3.0, kRadius}, standingAtOrigin(0), 0.75)});
  EXPECT_EQ(late.lateFramesDropped(), 1);
  EXPECT_TRUE(late.latest().ball->position_F.isApprox(before, 1e-12));
}

TEST(Fusion, AStillBallStaysStillInTheFieldWhileTheRobotTurnsAndDrives) {
  fusion::BallFusion fusion(testConfig());
  const Truth still = [](double) { return Eigen::Vector3d(1.0, 3.0, kRadius); };
  // Turning at 1 rad/s while driving at 1 m/s: the ball sweeps across both cameras.
  const auto driving = [](double t) { return poseAt(0.0, 1.0 * (t - kT0), 0.5 * std::sin(2.0 * (t - kT0)), t); };
  const auto in_view = [&](double t, const Eigen::Vector3d& p) {
    const Eigen::Vector3d p_R = driving(t).T_F_R().inverse() * p;
    return p_R.y() > 0.5 && std::abs(std::atan2(p_R.x(), p_R.y())) < 0.5;
  };
  const FedRun run = feed(fusion, still, 2.0, driving, in_view);
  int checked = 0;
  for (std::size_t i = 10; i < run.updates.size(); ++i) {
    const auto& ball = run.updates[i].ball;
    ASSERT_TRUE(ball) << "update " << i;
    EXPECT_LT((ball->position_F - still(0)).head<2>().norm(), 0.08) << "update " << i;
    EXPECT_LT(ball->velocity_F.norm(), 0.5) << "update " << i;
    // And in the robot frame it is where the robot sees it.
    EXPECT_LT((ball->position_R - driving(run.updates[i].time_s).T_F_R().inverse() * still(0)).norm(), 0.08);
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

TEST(Fusion, ALostBallIsDroppedAfterTheConfiguredTimeAndReacquired) {
  fusion::FusionConfig config = testConfig();
  config.track.lost_after_s = 0.5;
  fusion::BallFusion fusion(config);
  const Truth rolling = [](double t) { return Eigen::Vector3d(0.5, 2.0 + 0.5 * (t - kT0), kRadius); };
  const auto gap = [](double t, const Eigen::Vector3d&) { return t - kT0 < 1.0 || t - kT0 > 2.0; };
  const FedRun run = feed(fusion, rolling, 3.0, standingAtOrigin, gap, /*with_omni=*/false);
  auto at = [&](double since_start) -> const fusion::FusionUpdate& {
    return run.updates[static_cast<std::size_t>(std::lround(since_start * 30))];
  };
  EXPECT_TRUE(at(0.9).ball);
  EXPECT_TRUE(at(1.0).ball) << "within lost_after_s it is predicted on";
  // The world only changes with a measurement: the first one after the gap finds the old track gone.
  EXPECT_FALSE(at(2.0 + 1.0 / 30).ball);
  EXPECT_TRUE(at(2.0 + 4.0 / 30).ball) << "confirmed again after three measurements";
  EXPECT_LT((at(2.9).ball->position_F - at(2.9).ball->position_F).norm(), 1e-12);
  EXPECT_LT((run.updates.back().ball->position_F - run.truth.back()).norm(), 0.05);
}

namespace {

// A ball rolling across the view of both sensors for 3 s, each stamping with its own clock
// (true time -> stamp); the updates after each Kinect frame and the truth then.
FedRun feedRollingWithClocks(fusion::BallFusion& fusion, const std::function<double(int, double)>& kinect_clock,
                             const std::function<double(int, double)>& omni_clock) {
  std::mt19937 random(11);
  const Truth rolling = [](double t) { return Eigen::Vector3d(-1.0 + 0.8 * (t - kT0), 3.0, kRadius); };
  FedRun run;
  for (int i = 0; i < 90; ++i) {
    const double t = kT0 + i / 30.0;
    fusion.addPose(poseAt(0.0, 0.0, 0.0, kinect_clock(i, t)));
    run.updates.push_back(
        fusion.addKinectFrame(kinect_clock(i, t), {kinectView(rolling(t), poseAt(0, 0, 0, t), random)}));
    run.truth.push_back(rolling(t));
    const double t_omni = t + 0.5 / 30.0;
    fusion.addOmniFrame(omni_clock(i, t_omni), {omniView(rolling(t_omni), poseAt(0, 0, 0, t_omni), 0.75)});
  }
  return run;
}

}  // namespace

TEST(Fusion, AClockThatJumpsEitherWayStartsTheFusionAgainOnItsNewTimeLine) {
  for (const double jump_s : {1e9, -1e6, 30.0, -5.0}) {
    SCOPED_TRACE("every clock jumps by " + std::to_string(jump_s) + " s after one second");
    fusion::BallFusion fusion(testConfig());
    const auto jumping = [jump_s](int i, double t) { return i >= 30 ? t + jump_s : t; };
    const FedRun run = feedRollingWithClocks(fusion, jumping, jumping);
    EXPECT_EQ(fusion.timeLineRestarts(), 1);
    ASSERT_TRUE(run.updates[29].ball);
    EXPECT_FALSE(run.updates[30].ball) << "nothing carried across the jump";
    ASSERT_TRUE(run.updates.back().ball) << "the ball is found again on the new time line";
    EXPECT_LT((run.updates.back().ball->position_F - run.truth.back()).norm(), 0.05);
    EXPECT_NEAR(run.updates.back().time_s, kT0 + 89 / 30.0 + jump_s, 1e-6);
  }
}

TEST(Fusion, AnOmniClockThatAloneJumpsIsDroppedAndTheKinectCarriesTheBall) {
  fusion::BallFusion fusion(testConfig());
  const auto steady = [](int, double t) { return t; };
  const auto jumping = [](int i, double t) { return i >= 30 ? t + 1e7 : t; };
  const FedRun run = feedRollingWithClocks(fusion, steady, jumping);
  EXPECT_EQ(fusion.timeLineRestarts(), 0) << "the Kinect's clock is the reference";
  EXPECT_EQ(fusion.unusableFramesDropped(), 60);
  ASSERT_TRUE(run.updates.back().ball);
  EXPECT_EQ(run.updates.back().ball->sources, std::vector<std::string>{"kinect3d"});
  EXPECT_LT((run.updates.back().ball->position_F - run.truth.back()).norm(), 0.05);
}

TEST(Fusion, StampsThatAreNotFiniteAreDroppedAndCounted) {
  fusion::BallFusion fusion(testConfig());
  const auto broken = [](int i, double t) {
    return i % 10 == 5 ? (i % 20 == 5 ? std::numeric_limits<double>::quiet_NaN() : HUGE_VAL) : t;
  };
  const FedRun run = feedRollingWithClocks(fusion, broken, broken);
  EXPECT_EQ(fusion.unusableFramesDropped(), 18);  // 9 frames of each sensor
  EXPECT_EQ(fusion.timeLineRestarts(), 0);
  ASSERT_TRUE(run.updates.back().ball);
  EXPECT_TRUE(run.updates.back().ball->position_F.allFinite());
  EXPECT_LT((run.updates.back().ball->position_F - run.truth.back()).norm(), 0.05);
}

TEST(Fusion, AStaticFloaterIsNeverTheBall) {
  fusion::BallFusion fusion(testConfig());
  std::mt19937 random(3);
  const Eigen::Vector3d lamp(0.5, 3.0, 1.6);
  for (int i = 0; i < 90; ++i) {
    const double t = kT0 + i / 30.0;
    fw::BallObservation seen = kinectView(lamp, standingAtOrigin(t), random);
    seen.is_static = i >= 60;  // the scene map calls it static after two seconds
    EXPECT_FALSE(fusion.addKinectFrame(t, {seen}).ball) << "frame " << i;
  }
}

TEST(Fusion, AFalseOrangeObjectDoesNotTakeTheBallAway) {
  fusion::BallFusion fusion(testConfig());
  const Truth rolling = [](double t) { return Eigen::Vector3d(0.0, 2.0 + 1.0 * (t - kT0), kRadius); };
  std::mt19937 random(5);
  for (int i = 0; i < 60; ++i) {
    const double t = kT0 + i / 30.0;
    fusion.addKinectFrame(t, {kinectView(rolling(t), standingAtOrigin(t), random)});
    std::vector<fw::OmniBallObservation> omni{omniView(rolling(t + 0.01), standingAtOrigin(t), 0.75)};
    if (i > 20) omni.push_back(omniView({-3.0, -2.0, kRadius}, standingAtOrigin(t), 0.75));  // a shirt
    const fusion::FusionUpdate& update = fusion.addOmniFrame(t + 0.01, omni);
    if (i > 5) {
      ASSERT_TRUE(update.ball);
      EXPECT_LT((update.ball->position_F - rolling(t + 0.01)).norm(), 0.1) << "frame " << i;
    }
  }
}

TEST(Fusion, FollowsAFlyingBallThatHitsARobot) {
  // A shot at 6 m/s a metre up springs back off a robot's hull 0.3 s later with 40 % of its speed.
  const double hit_t = kT0 + 0.3;
  auto flight = [](Eigen::Vector3d p, Eigen::Vector3d v, double t0) {
    fw::BallTrajectory f;
    f.state = fw::BallState::kAir;
    f.position_m = p;
    f.velocity_mps = v;
    f.drag_per_m = fusion::MotionConfig{}.drag_per_m;
    f.time_s = t0;
    return f;
  };
  const fw::BallTrajectory shot = flight({0.0, 1.5, 1.0}, {0.0, 6.0, 1.0}, kT0);
  const fw::BallTrajectory at_hit = shot.movedTo(hit_t);
  const Eigen::Vector3d rebound(at_hit.velocity_mps.x(), -0.4 * at_hit.velocity_mps.y(), at_hit.velocity_mps.z());
  const fw::BallTrajectory back = flight(at_hit.position_m, rebound, hit_t);
  const Truth ball = [&](double t) { return (t < hit_t ? shot : back).movedTo(t).position_m; };
  fusion::BallFusion fusion(testConfig());
  const FedRun run = feed(fusion, ball, 0.5, standingAtOrigin, always, /*with_omni=*/false);
  ASSERT_TRUE(run.updates.back().ball);
  EXPECT_LT((run.updates.back().ball->position_F - run.truth.back()).norm(), 0.06)
      << "0.2 s after the hit the ball flies back, and the world's ball with it";
  EXPECT_LT((run.updates.back().ball->velocity_F - back.movedTo(run.updates.back().time_s).velocity_mps).norm(), 0.5);
}

TEST(Fusion, AFlightNoSensorSeesStaysTheWorldsBallThoughAnotherBallIsSeen) {
  fusion::BallFusion fusion(testConfig());
  const Eigen::Vector3d p0(0.0, 2.0, kRadius), v0(0.0, 2.0, 6.0);  // up to 1.9 m, a second above the omni's view
  const double kick_t = kT0 + 0.3;
  const Truth lob = [&](double t) { return lobAt(t, kick_t, p0, v0); };
  const Eigen::Vector3d shirt(-3.0, -2.0, kRadius);  // orange, seen by the omni camera all along
  std::mt19937 random(3);
  int checked = 0;
  for (int i = 0; i < 36; ++i) {
    const double t = kT0 + i / 30.0;
    fusion.addPose(standingAtOrigin(t));
    std::vector<fw::BallObservation> kinect;
    if (t < kick_t + 0.3) kinect.push_back(kinectView(lob(t), standingAtOrigin(t), random));  // then above it
    fusion.addKinectFrame(t, kinect);
    const double t_omni = t + 0.01;
    std::vector<fw::OmniBallObservation> omni{omniView(shirt, standingAtOrigin(t_omni), 0.75)};
    if (lob(t_omni).z() < 0.6) omni.push_back(omniView(lob(t_omni), standingAtOrigin(t_omni), 0.75));
    fusion.addPose(standingAtOrigin(t_omni));
    const fusion::FusionUpdate& update = fusion.addOmniFrame(t_omni, omni);
    if (t < kick_t + 0.3) continue;
    ++checked;
    ASSERT_TRUE(update.ball);
    EXPECT_LT((update.ball->position_F - lob(t_omni)).norm(), 0.3) << (t - kick_t) << " s after the kick";
  }
  EXPECT_GT(checked, 15) << "over half a second that only physics carries";
}

TEST(Fusion, AFlightNoSensorSupportsGivesWayToTheBallAKinectLocatesElsewhere) {
  // The world's flight went wrong (in a live run, a teammate's balls on two clock estimates made one
  // climb at 16 m/s): from 0.3 s after the kick the Kinect sees the ball 1.5 m to the side of it.
  // That flight is not hidden above the omni's view but lost: the world's ball is the one located.
  fusion::BallFusion fusion(testConfig());
  const Eigen::Vector3d p0(0.0, 2.0, kRadius);
  const double kick_t = kT0 + 0.3, found_t = kick_t + 0.3;
  const Truth believed = [&](double t) { return lobAt(t, kick_t, p0, {0.0, 2.0, 6.0}); };
  const Truth located = [&](double t) { return lobAt(t, kick_t, p0, {5.0, 2.0, 6.0}); };
  const Truth seen = [&](double t) { return t < found_t ? believed(t) : located(t); };
  ASSERT_GT((believed(found_t) - located(found_t)).norm(), 1.4);
  const FedRun run = feed(fusion, seen, 1.2, standingAtOrigin, always);
  int checked = 0;
  for (std::size_t i = 0; i < run.updates.size(); ++i) {
    const double t = run.updates[i].time_s;
    if (t < found_t + 0.25 || located(t).z() < 0.3) continue;
    ++checked;
    ASSERT_TRUE(run.updates[i].ball);
    EXPECT_LT((run.updates[i].ball->position_F - located(t)).norm(), 0.3) << (t - found_t) << " s after it was found";
  }
  EXPECT_GT(checked, 10);
}

// A ball rolling out of the reach of an omni camera whose mirror sees 7 m, watched by this robot
// standing at the origin (its Kinect while kinect_sees); from other_after_s after the ball left the
// reach the camera also reports something else at other_F in every image.
struct RolledOut {
  FedRun run;
  double out_of_reach_t = 0.0;  // the first step with the ball beyond the reach
};
RolledOut rollOutOfTheOmnisReach(fusion::BallFusion& fusion, const Truth& rolling, const Sees& kinect_sees,
                                 const Eigen::Vector3d& other_F, double other_after_s, double duration_s,
                                 unsigned seed) {
  constexpr double kReach_m = 7.0;
  const Sees within_reach = [&](double, const Eigen::Vector3d& p) { return p.head<2>().norm() <= kReach_m; };
  std::mt19937 random(seed);
  RolledOut out;
  for (int i = 0; i * (1.0 / 30) < duration_s; ++i) {
    const double t = kT0 + i / 30.0;
    if (out.out_of_reach_t == 0.0 && !within_reach(t, rolling(t))) out.out_of_reach_t = t;
    const bool other_shown = out.out_of_reach_t > 0.0 && t > out.out_of_reach_t + other_after_s;
    feedOwnStep(fusion, rolling, t, standingAtOrigin, kinect_sees, within_reach, true, 0.0, random, out.run,
                other_shown ? std::vector<Eigen::Vector3d>{other_F} : std::vector<Eigen::Vector3d>{});
  }
  return out;
}

TEST(Fusion, ABallRolledBeyondTheOmniCamerasReachIsCarriedNotSwappedForAnOrangeShirt) {
  // A ball rolls past the robot and away behind it. The Kinect sees it in front; the omni camera's
  // mirror reaches 7 m. Once the ball is past that, an orange shirt 2.5 m in front is all the camera
  // reports. The ball is out of view, not lost: the world's ball rolls on (in the fusion report's lobs
  // landing behind the robot it had jumped to such a shirt 12 m away).
  fusion::BallFusion fusion(testConfig());
  constexpr double kSpeed_mps = 3.0, kDecel_mps2 = 0.3;
  const Truth rolling = [&](double t) {
    const double s = std::min(t - kT0, kSpeed_mps / kDecel_mps2);
    return Eigen::Vector3d(0.6, 2.5 - (kSpeed_mps * s - 0.5 * kDecel_mps2 * s * s), kRadius);
  };
  const Sees in_front = [](double, const Eigen::Vector3d& p) { return p.y() > 0.8; };
  const Eigen::Vector3d shirt_F(-1.0, 2.5, kRadius);
  const auto [run, out_of_reach_t] = rollOutOfTheOmnisReach(fusion, rolling, in_front, shirt_F, 0.3, 5.5, 3);
  ASSERT_GT(out_of_reach_t, kT0 + 2.0);
  int checked = 0;
  for (std::size_t i = 0; i < run.updates.size(); ++i) {
    const double t = run.updates[i].time_s;
    // The shirt's track is confirmed a few images after it appears; the ball's is lost a second
    // after the camera last saw it (track.lost_after_s).
    if (t < out_of_reach_t + 0.5 || t > out_of_reach_t + 0.9) continue;
    ++checked;
    ASSERT_TRUE(run.updates[i].ball) << t - out_of_reach_t << " s after the ball left the camera's reach";
    EXPECT_LT((run.updates[i].ball->position_F - run.truth[i]).norm(), 0.5)
        << t - out_of_reach_t << " s after the ball left the camera's reach";
  }
  EXPECT_GT(checked, 20);
}

TEST(Fusion, ABallOnlyTheOmniCameraSawGivesWayOnceItIsOutOfReach) {
  // A robot without a Kinect: what its omni camera placed beyond its reach may be placed wrong (a
  // flight put too far), so it is not carried there. The ball rolls out of the mirror's 7 m, and a
  // ball the camera then sees 3 m away becomes the world's within a few tenths of a second, not only
  // once the lost one is dropped (track.lost_after_s, a second).
  fusion::BallFusion fusion(testConfig());
  const Truth rolling = [](double t) { return Eigen::Vector3d(0.6, -4.0 - 3.0 * (t - kT0), kRadius); };
  const Eigen::Vector3d seen_next_F(-1.0, 3.0, kRadius);
  const auto [run, out_of_reach_t] = rollOutOfTheOmnisReach(fusion, rolling, never, seen_next_F, 0.1, 2.5, 5);
  ASSERT_GT(out_of_reach_t, kT0 + 0.5);
  int checked = 0;
  for (std::size_t i = 0; i < run.updates.size(); ++i) {
    const double t = run.updates[i].time_s;
    if (t < out_of_reach_t + 0.5 || t > out_of_reach_t + 0.9) continue;
    ++checked;
    ASSERT_TRUE(run.updates[i].ball) << t - out_of_reach_t << " s after the ball left the camera's reach";
    EXPECT_LT((run.updates[i].ball->position_F - seen_next_F).norm(), 0.3)
        << t - out_of_reach_t << " s after the ball left the camera's reach";
  }
  EXPECT_GT(checked, 20);
}

// What a teammate standing at true_pose but believing it stands at believed_pose tells of the ball
// at p_F seen at time t: its Kinect's ball, placed in the field with the pose it believes.
fw::TeamMessage teammateMessage(const fw::RobotPose& true_pose, const fw::RobotPose& believed_pose,
                                const std::vector<std::pair<double, Eigen::Vector3d>>& seen, std::mt19937& random) {
  fw::TeamMessage message;
  message.robot_id = 4;
  message.robot_name = "keeper";
  message.pose = believed_pose;
  message.pose_sigma_xy_m = 0.03;
  message.pose_sigma_theta_rad = 0.0175;
  for (const auto& [t, p_F] : seen) {
    fw::BallObservation ball = kinectView(p_F, true_pose, random);
    ball.position_m = believed_pose.fieldFromRobot(ball.position_m);
    ball.frame = fw::Frame::kField;
    ball.stamp.source_time_s = t;
    message.kinect_balls.push_back(ball);
  }
  return message;
}

// Where a teammate believes it stands at time t (none: it sends nothing).
using Belief = std::function<std::optional<fw::RobotPose>(double t)>;

// This robot at the origin watches `truth` with its Kinect while kinect_sees and with its omni camera
// while omni_sees (and the ball is in its view); a teammate's Kinect sees it all the time from true_pose and sends what
// it saw every 50 ms, each message 80-130 ms late and a fifth of them lost (none sent while it has no belief);
// with_world_ball: each message also carries the teammate's world ball, its newest Kinect ball;
// shirts_F and omni_stamp_late_s: as feedOwnStep's. Everything reaches the fusion in arrival order.
FedRun feedWithTeammate(fusion::BallFusion& fusion, const Truth& truth, double duration_s, const Sees& kinect_sees,
                        const Sees& omni_sees, const fw::RobotPose& true_pose, const Belief& belief,
                        bool with_world_ball = false, const std::vector<Eigen::Vector3d>& shirts_F = {},
                        double omni_stamp_late_s = 0.0) {
  std::mt19937 random(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  FedRun run;
  std::vector<std::pair<double, Eigen::Vector3d>> unsent;
  std::vector<std::pair<double, fw::TeamMessage>> in_flight;  // arrival time, message
  for (int i = 0; i * (1.0 / 30) < duration_s; ++i) {
    const double t = kT0 + i / 30.0;
    for (auto it = in_flight.begin(); it != in_flight.end();) {
      if (it->first > t) {
        ++it;
        continue;
      }
      run.updates.push_back(fusion.addTeamMessage(it->second));
      run.truth.push_back(truth(run.updates.back().time_s));
      run.from_teammate.push_back(true);
      it = in_flight.erase(it);
    }
    unsent.emplace_back(t, truth(t));  // the teammate's Kinect, in step with this robot's
    if (i % 3 != 0 || i == 0) {
      // Every 50 ms (every one and a half frames: here every third frame carries two) a message goes.
      const std::optional<fw::RobotPose> believed_pose = belief(t);
      if (unit(random) > 0.2 && believed_pose) {
        fw::RobotPose believed = *believed_pose;
        believed.stamp.source_time_s = t;
        fw::TeamMessage message = teammateMessage(true_pose, believed, unsent, random);
        if (with_world_ball) {
          fw::FusedBall world;
          world.position_F = message.kinect_balls.back().position_m;
          world.covariance_F = message.kinect_balls.back().covariance_m2;
          world.sources = {"kinect3d"};
          world.age_s = 0.0;
          world.stamp.source_time_s = message.kinect_balls.back().stamp.source_time_s;
          message.world_ball = world;
        }
        in_flight.emplace_back(t + 0.08 + 0.05 * unit(random), message);
      }
      unsent.clear();
    }
    feedOwnStep(fusion, truth, t, standingAtOrigin, kinect_sees, omni_sees, true, omni_stamp_late_s, random, run,
                shirts_F);
  }
  return run;
}

// The same, the teammate believing the same pose all along (none: it sends nothing).
FedRun feedWithTeammate(fusion::BallFusion& fusion, const Truth& truth, double duration_s, const Sees& kinect_sees,
                        const Sees& omni_sees, const fw::RobotPose& true_pose,
                        const std::optional<fw::RobotPose>& believed_pose, bool with_world_ball = false,
                        const std::vector<Eigen::Vector3d>& shirts_F = {}, double omni_stamp_late_s = 0.0) {
  return feedWithTeammate(
      fusion, truth, duration_s, kinect_sees, omni_sees, true_pose, [believed_pose](double) { return believed_pose; },
      with_world_ball, shirts_F, omni_stamp_late_s);
}

TEST(Fusion, ATeammatesMessageLeavesTheFusionWhereItsFramesOneByOneWould) {
  // A message's balls at several times go in with one rewind: the world's ball must be the one that
  // a message per time gives, each replayed after the frames already held at its time (the
  // teammate's Kinect in step with this robot's, and half a frame after).
  fusion::BallFusion whole(testConfig()), split(testConfig());
  std::mt19937 own_whole(5), own_split(5), mate_whole(6), mate_split(6);
  const Truth rolling = [](double t) { return Eigen::Vector3d(0.5, 3.0 - 1.5 * (t - kT0), kRadius); };
  const fw::RobotPose keeper = poseAt(0.5, 7.0, M_PI, kT0);
  std::vector<std::pair<double, Eigen::Vector3d>> unsent;
  int compared = 0;
  for (int i = 0; i < 60; ++i) {
    const double t = kT0 + i / 30.0;
    for (auto [fusion, random] : {std::pair{&whole, &own_whole}, std::pair{&split, &own_split}}) {
      fusion->addPose(standingAtOrigin(t));
      fusion->addKinectFrame(t, {kinectView(rolling(t), standingAtOrigin(t), *random)});
    }
    if (i < 6) continue;  // this robot's Kinect has confirmed the ball
    const double between = t + 1.0 / 60.0;
    unsent.emplace_back(t, rolling(t));
    if (i % 2 == 1) unsent.emplace_back(between, rolling(between));
    if (unsent.size() < 3) continue;
    fw::RobotPose sent_pose = keeper;
    sent_pose.stamp.source_time_s = t;
    const fusion::FusionUpdate from_whole =
        whole.addTeamMessage(teammateMessage(keeper, sent_pose, unsent, mate_whole));
    fusion::FusionUpdate from_split;
    for (const auto& seen : unsent) {
      from_split = split.addTeamMessage(teammateMessage(keeper, sent_pose, {seen}, mate_split));
    }
    unsent.clear();
    ASSERT_TRUE(from_whole.ball);
    ASSERT_TRUE(from_split.ball);
    EXPECT_EQ(from_whole.time_s, from_split.time_s);
    EXPECT_EQ(from_whole.ball->position_F, from_split.ball->position_F) << "message " << compared;
    EXPECT_EQ(from_whole.ball->covariance_F, from_split.ball->covariance_F);
    ++compared;
  }
  EXPECT_GE(compared, 20);
}

TEST(Fusion, ALobOnlyATeammatesKinectSeesIsHeldInTheAirFromItsMessages) {
  fusion::BallFusion fusion(testConfig());
  // Kicked from in front of this robot over its head; the keeper, 7 m away facing it, sees it all.
  const Eigen::Vector3d p0(0.3, 2.5, kRadius), v0(0.0, -3.5, 5.0);
  const Truth lob = [&](double t) { return lobAt(t, kT0 + 0.5, p0, v0); };
  const fw::RobotPose keeper = poseAt(0.5, 7.0, M_PI, kT0);
  const FedRun run = feedWithTeammate(fusion, lob, 2.5, never, always, keeper, keeper);
  std::vector<double> air_errors_m;
  int from_teammate = 0;
  for (std::size_t i = 0; i < run.updates.size(); ++i) {
    const auto& ball = run.updates[i].ball;
    if (run.truth[i].z() < 0.3) continue;
    ASSERT_TRUE(ball) << "update " << i << ": the lob is the world's ball all through its flight";
    air_errors_m.push_back((ball->position_F - run.truth[i]).norm());
    EXPECT_EQ(ball->state, fw::BallState::kAir) << "update " << i;
    from_teammate += std::count(ball->sources.begin(), ball->sources.end(), "team:keeper") > 0 ? 1 : 0;
  }
  ASSERT_GT(air_errors_m.size(), 20u);
  EXPECT_LE(fw::quantile(air_errors_m, 0.5), 0.15);
  EXPECT_EQ(from_teammate, static_cast<int>(air_errors_m.size()));
  ASSERT_EQ(fusion.teammates().count(4), 1u);
  EXPECT_FALSE(fusion.teammates().at(4).discounted);
}

TEST(Fusion, AWellLocalisedTeammateIsNotJudgedAgainstAnOrangeShirtThisRobotsOmniCameraSees) {
  // A lob over this robot, 2 m high, seen by the keeper's Kinect and by this robot's omni camera only
  // below 0.6 m; an orange shirt lies on the floor 2.5 m to this robot's right, and its omni camera
  // takes it for a ball in every image. While the lob flies above the camera's view, the shirt is
  // the only ball this robot's own sensors hold: it says nothing of the keeper.
  const Eigen::Vector3d p0(0.3, 2.5, kRadius), v0(0.0, -3.0, 6.5);
  const Truth lob = [&](double t) { return lobAt(t, kT0 + 0.5, p0, v0); };
  const fw::RobotPose keeper = poseAt(0.5, 7.0, M_PI, kT0);
  fusion::BallFusion fusion(testConfig());
  const FedRun run =
      feedWithTeammate(fusion, lob, 2.5, never, always, keeper, keeper, false, {Eigen::Vector3d(2.5, 0.5, kRadius)});
  ASSERT_EQ(fusion.teammates().count(4), 1u);
  EXPECT_FALSE(fusion.teammates().at(4).discounted);
  std::vector<double> air_errors_m;
  for (std::size_t i = 0; i < run.updates.size(); ++i) {
    if (run.truth[i].z() < 0.6 || !run.updates[i].ball) continue;
    air_errors_m.push_back((run.updates[i].ball->position_F - run.truth[i]).norm());
  }
  ASSERT_GE(air_errors_m.size(), 30u);
  EXPECT_LE(fw::quantile(air_errors_m, 0.5), 0.15) << "the lob, from the keeper's balls";
}

TEST(Fusion, AMislocalisedTeammateIsDiscountedAndDoesNotMoveTheBall) {
  // The ball rolls in front of this robot, which sees it with both sensors for 1.5 s, then a robot
  // hides it; the keeper sees it all the time but believes it stands a metre from where it does, or
  // turned by twenty degrees, and sends its world ball too. After each of this robot's own frames,
  // its world ball must lie where it would without the keeper: neither its balls nor its world ball
  // may become the world's when this robot's own go.
  const Truth rolling = [](double t) {
    const double tau = std::min(t - kT0, 2.5);  // 1 m/s, slowing by 0.4 m/s^2 as the fusion expects
    return Eigen::Vector3d(-0.5 + tau - 0.2 * tau * tau, 3.0, kRadius);
  };
  const auto until_hidden = [](double t, const Eigen::Vector3d&) { return t < kT0 + 1.5; };
  const fw::RobotPose keeper = poseAt(0.5, 7.0, M_PI, kT0);
  fusion::BallFusion alone(testConfig());
  const FedRun without = feedWithTeammate(alone, rolling, 4.0, until_hidden, until_hidden, keeper, std::nullopt);
  for (const fw::RobotPose& believed : {poseAt(1.5, 7.0, M_PI, kT0), poseAt(0.5, 7.0, M_PI + 0.35, kT0)}) {
    fusion::BallFusion fusion(testConfig());
    const FedRun run = feedWithTeammate(fusion, rolling, 4.0, until_hidden, until_hidden, keeper, believed, true);
    std::vector<const fusion::FusionUpdate*> own;
    for (std::size_t i = 0; i < run.updates.size(); ++i) {
      if (!run.from_teammate[i]) own.push_back(&run.updates[i]);
    }
    ASSERT_EQ(own.size(), without.updates.size());
    int published = 0, with_keeper = 0;
    double moved_m = 0.0;
    for (std::size_t i = 0; i < own.size(); ++i) {
      ASSERT_EQ(own[i]->ball.has_value(), without.updates[i].ball.has_value()) << "update " << i;
      if (!own[i]->ball) continue;
      ++published;
      moved_m = std::max(moved_m, (own[i]->ball->position_F - without.updates[i].ball->position_F).norm());
      const std::vector<std::string>& sources = own[i]->ball->sources;
      with_keeper += std::count(sources.begin(), sources.end(), "team:keeper") > 0 ? 1 : 0;
    }
    EXPECT_GT(published, 100);
    EXPECT_LE(moved_m, 0.2) << "believed (" << believed.x_m << ", " << believed.theta_rad << ")";
    EXPECT_EQ(with_keeper, 0) << "the world's ball never rested on its balls";
    ASSERT_EQ(fusion.teammates().count(4), 1u);
    const fusion::TeammateStanding& standing = fusion.teammates().at(4);
    EXPECT_TRUE(standing.discounted);
    EXPECT_GT(standing.median_gap_m, 0.7);
  }
}

TEST(Fusion, ATeammateTheConfigurationIgnoresChangesNoWorldBall) {
  // The lob only the keeper sees (above): with fusion.team.ignore naming the keeper, every world ball
  // after this robot's own frames is the one it gives without the keeper's messages, to the bit.
  const Eigen::Vector3d p0(0.3, 2.5, kRadius), v0(0.0, -3.5, 5.0);
  const Truth lob = [&](double t) { return lobAt(t, kT0 + 0.5, p0, v0); };
  const fw::RobotPose keeper = poseAt(0.5, 7.0, M_PI, kT0);
  fusion::BallFusion alone(testConfig());
  const FedRun without = feedWithTeammate(alone, lob, 2.5, never, always, keeper, std::nullopt);
  fusion::FusionConfig config = testConfig();
  config.team.ignore = {"striker", "keeper"};
  fusion::BallFusion ignoring(config);
  const FedRun run = feedWithTeammate(ignoring, lob, 2.5, never, always, keeper, keeper, true);
  std::vector<const fusion::FusionUpdate*> own;
  for (std::size_t i = 0; i < run.updates.size(); ++i) {
    if (!run.from_teammate[i]) own.push_back(&run.updates[i]);
  }
  ASSERT_EQ(own.size(), without.updates.size());
  int published = 0;
  for (std::size_t i = 0; i < own.size(); ++i) {
    ASSERT_EQ(own[i]->ball.has_value(), without.updates[i].ball.has_value()) << "update " << i;
    if (!own[i]->ball) continue;
    ++published;
    EXPECT_EQ(own[i]->ball->position_F, without.updates[i].ball->position_F) << "update " << i;
    EXPECT_EQ(own[i]->ball->sources, without.updates[i].ball->sources) << "update " << i;
  }
  EXPECT_GT(published, 30);
  EXPECT_EQ(ignoring.teammates().count(4), 0u) << "not even judged";
  // The same messages heard: the lob is held from them (ALobOnlyATeammatesKinectSeesIsHeldInTheAirFromItsMessages).
  fusion::BallFusion listening(testConfig());
  const FedRun heard = feedWithTeammate(listening, lob, 2.5, never, always, keeper, keeper, true);
  int from_keeper = 0;
  for (const fusion::FusionUpdate& update : heard.updates) {
    if (update.ball) from_keeper += std::count(update.ball->sources.begin(), update.ball->sources.end(), "team:keeper");
  }
  EXPECT_GT(from_keeper, 30);
}

TEST(Fusion, ADiscountedTeammateIsTrustedAgainOnlyByObservationsThatWouldShowItsError) {
  // The keeper, 7 m away facing this robot, believes it is turned by 20 degrees. The ball rests 2 m in
  // front of this robot, where its omni camera sees the keeper's error (1.8 m), then rolls up to the
  // keeper and rests 0.6 m from it: there the keeper puts it only 0.2 m off, which this robot, 6.4 m
  // away, sees as agreement (under 2 sigma). The keeper stays discounted. When instead its
  // localisation comes right while the ball still rests near this robot, it is trusted again and used.
  const fw::RobotPose keeper = poseAt(0.5, 7.0, M_PI, kT0), turned = poseAt(0.5, 7.0, M_PI + 0.35, kT0);
  const double roll_t = kT0 + 2.0, v0 = std::sqrt(2.0 * 0.4 * 4.4);  // 4.4 m at 0.4 m/s^2, as the fusion expects
  const Truth rolls_to_keeper = [&](double t) {
    const double tau = std::clamp(t - roll_t, 0.0, v0 / 0.4);
    return Eigen::Vector3d(0.5, 2.0 + v0 * tau - 0.2 * tau * tau, kRadius);
  };
  const auto keeperIn = [](const fusion::FusionUpdate& update) {
    return update.ball && std::count(update.ball->sources.begin(), update.ball->sources.end(), "team:keeper") > 0;
  };
  {
    fusion::BallFusion fusion(testConfig());
    const FedRun run = feedWithTeammate(fusion, rolls_to_keeper, 9.0, never, always, keeper, turned);
    ASSERT_EQ(fusion.teammates().count(4), 1u);
    const fusion::TeammateStanding& standing = fusion.teammates().at(4);
    EXPECT_TRUE(standing.discounted) << "judged near the keeper: median " << standing.median_mahalanobis << " sigma, "
                                     << standing.median_gap_m << " m, against " << standing.discounted_gap_m
                                     << " m when discounted";
    EXPECT_LT(standing.median_mahalanobis, 2.0) << "its balls near it look right from here";
    int with_keeper = 0, late = 0;
    for (const fusion::FusionUpdate& update : run.updates) {
      if (update.time_s < roll_t + 3.0) continue;
      ++late;
      with_keeper += keeperIn(update) ? 1 : 0;
    }
    EXPECT_GT(late, 100);
    EXPECT_EQ(with_keeper, 0) << "the ball beside the keeper rests on this robot's camera alone";
  }
  {
    const Truth rests = [](double) { return Eigen::Vector3d(0.5, 2.0, kRadius); };
    fusion::BallFusion fusion(testConfig());
    const FedRun run = feedWithTeammate(fusion, rests, 5.0, never, always, keeper, [&](double t) {
      return std::optional<fw::RobotPose>(t < kT0 + 2.0 ? turned : keeper);
    });
    int discounted_while_turned = 0, used_at_the_end = 0;
    for (const fusion::FusionUpdate& update : run.updates) {
      if (update.time_s > kT0 + 1.0 && update.time_s < kT0 + 2.0) discounted_while_turned += keeperIn(update) ? 0 : 1;
      if (update.time_s > kT0 + 4.0) used_at_the_end += keeperIn(update) ? 1 : 0;
    }
    EXPECT_GT(discounted_while_turned, 30);
    EXPECT_GT(used_at_the_end, 30) << "trusted again, and used";
    EXPECT_FALSE(fusion.teammates().at(4).discounted);
  }
}

TEST(Fusion, AMislocalisedTeammateIsDiscountedWhileTheBallHopsInFrontOfThisRobotsOmniCamera) {
  // The ball hops 0.35 m high 3 m in front of this robot, which has only its omni camera: of a ball
  // in the air that gives the bearing alone. The keeper's Kinect sees every hop, but the keeper
  // believes it stands a metre from where it does, across this robot's line of sight. Its balls
  // lie off this robot's bearing to the ball by about 18 degrees, which is what judges it: the ball
  // never rests on the floor long enough to judge it there.
  const Truth hopping = [](double t) {
    const double tau = t - kT0, hop_s = 2.0 * std::sqrt(2.0 * 0.35 / 9.81);
    const double phase = std::fmod(tau, hop_s);
    return Eigen::Vector3d(-1.0 + 0.4 * tau, 3.0, kRadius + 0.5 * 9.81 * phase * (hop_s - phase));
  };
  const fw::RobotPose keeper = poseAt(0.5, 7.0, M_PI, kT0);
  fusion::BallFusion fusion(testConfig());
  const FedRun run = feedWithTeammate(fusion, hopping, 3.0, never, always, keeper, poseAt(1.5, 7.0, M_PI, kT0));
  ASSERT_EQ(fusion.teammates().count(4), 1u);
  const fusion::TeammateStanding& standing = fusion.teammates().at(4);
  EXPECT_TRUE(standing.discounted);
  EXPECT_GT(standing.median_gap_m, 0.5);
  EXPECT_GE(standing.examples, testConfig().team.judge_examples);
  // After the judgement, the world's ball follows this robot's own camera: the last second's world
  // balls rest on none of the keeper's.
  int last_second = 0, with_keeper = 0;
  for (const fusion::FusionUpdate& update : run.updates) {
    if (!update.ball || update.time_s < kT0 + 2.0) continue;
    ++last_second;
    const std::vector<std::string>& sources = update.ball->sources;
    with_keeper += std::count(sources.begin(), sources.end(), "team:keeper") > 0 ? 1 : 0;
  }
  EXPECT_GT(last_second, 20);
  EXPECT_EQ(with_keeper, 0);
}

// The keeper's message with its pose and world ball alone (a robot without a Kinect sends no more),
// its ball on the floor at p_F rolling at v_F, given by `sources`, at time t.
fw::TeamMessage worldBallMessage(const Eigen::Vector3d& p_F, const Eigen::Vector3d& v_F, double t,
                                 const std::vector<std::string>& sources, double age_s = 0.02) {
  fw::TeamMessage message;
  message.robot_id = 4;
  message.robot_name = "keeper";
  message.pose = poseAt(0.5, 7.0, M_PI, t);
  message.pose_sigma_xy_m = 0.03;
  message.pose_sigma_theta_rad = 0.0175;
  fw::FusedBall ball;
  ball.position_F = p_F;
  ball.velocity_F = v_F;
  ball.covariance_F = 0.03 * 0.03 * Eigen::Matrix3d::Identity();
  ball.sources = sources;
  ball.age_s = age_s;
  ball.stamp.source_time_s = t;
  message.world_ball = ball;
  return message;
}

TEST(Fusion, ATeammatesWorldBallIsTheBallWhileThisRobotSeesNothingUntilItsOwnSensorsDo) {
  // The ball rolls 3 m in front of this robot, which sees nothing of it for 2 s (turned away, or
  // the ball hidden), then sees it with its Kinect. The keeper's world ball arrives every 67 ms.
  const Eigen::Vector3d velocity(0.8, 0.0, 0.0);
  const Truth rolling = [&](double t) -> Eigen::Vector3d {
    return Eigen::Vector3d(-0.5, 3.0, kRadius) + (t - kT0) * velocity;
  };
  fusion::BallFusion fusion(testConfig());
  std::mt19937 random(5);
  int from_keeper = 0, own = 0;
  for (int i = 0; i < 90; ++i) {
    const double t = kT0 + i / 30.0;
    fusion.addPose(standingAtOrigin(t));
    if (i % 2 == 0)
      fusion.addTeamMessage(worldBallMessage(rolling(t - 0.05), velocity, t - 0.05, {"kinect3d", "omni"}));
    std::vector<fw::BallObservation> kinect;
    if (t >= kT0 + 2.0) kinect.push_back(kinectView(rolling(t), standingAtOrigin(t), random));
    const fusion::FusionUpdate& update = fusion.addKinectFrame(t, kinect);
    ASSERT_TRUE(update.ball) << "update " << i << ": the world holds a ball all along";
    const fw::FusedBall& ball = *update.ball;
    if (t < kT0 + 2.0) {
      ++from_keeper;
      EXPECT_EQ(ball.sources, std::vector<std::string>{"team:keeper:world_ball"}) << "update " << i;
      EXPECT_LT((ball.position_F - rolling(t)).norm(), 0.01) << "the keeper's ball, carried on to this frame's time";
      EXPECT_NEAR(ball.position_R.y(), 3.0, 0.01) << "in this robot's frame too";
      EXPECT_GT(ball.covariance_F(0, 0), 0.03 * 0.03 + std::pow(3.9 * 0.0175, 2)) << "weaker than the keeper's own";
    } else if (t >= kT0 + 2.25) {
      ++own;
      EXPECT_EQ(ball.sources, std::vector<std::string>{"kinect3d"}) << "update " << i << ": its own Kinect's ball";
      EXPECT_LT((ball.position_F - rolling(t)).norm(), 0.05);
    }
  }
  EXPECT_EQ(from_keeper, 60);
  EXPECT_EQ(own, 22);
}

TEST(Fusion, ATeammatesWorldBallIsNotUsedWhenItIsItselfAPriorOrOld) {
  const Eigen::Vector3d p(1.0, 3.0, kRadius), still = Eigen::Vector3d::Zero();
  for (const auto& [sources, age_s] :
       std::vector<std::pair<std::vector<std::string>, double>>{{{"team:striker:world_ball"}, 0.02}, {{"omni"}, 1.2}}) {
    fusion::BallFusion fusion(testConfig());
    for (int i = 0; i < 30; ++i) {
      const double t = kT0 + i / 30.0;
      fusion.addPose(standingAtOrigin(t));
      fusion.addTeamMessage(worldBallMessage(p, still, t - 0.05, sources, age_s));
      EXPECT_FALSE(fusion.addKinectFrame(t, {}).ball) << sources.front() << ", " << age_s << " s old, update " << i;
    }
  }
  // Its age counts on from its time: a ball the keeper's sensors last saw 0.75 s before is held for
  // a quarter of a second more.
  fusion::BallFusion fusion(testConfig());
  fusion.addPose(standingAtOrigin(kT0));
  fusion.addTeamMessage(worldBallMessage(p, still, kT0, {"omni"}, 0.75));
  for (int i = 1; i <= 9; ++i) {
    fusion.addPose(standingAtOrigin(kT0 + i / 30.0));
    EXPECT_EQ(fusion.addKinectFrame(kT0 + i / 30.0, {}).ball.has_value(), i <= 7) << "frame " << i;
  }
}

TEST(Fusion, AWellLocalisedTeammateSeeingTheSameBallIsUsedBesideThisRobotsSensors) {
  const Truth rolling = [](double t) { return Eigen::Vector3d(-0.5 + 0.4 * (t - kT0), 3.0, kRadius); };
  const fw::RobotPose keeper = poseAt(0.5, 7.0, M_PI, kT0);
  fusion::BallFusion fusion(testConfig());
  const FedRun run = feedWithTeammate(fusion, rolling, 3.0, always, always, keeper, keeper);
  ASSERT_TRUE(run.updates.back().ball);
  EXPECT_EQ(run.updates.back().ball->sources, (std::vector<std::string>{"kinect3d", "omni", "team:keeper"}));
  EXPECT_LT((run.updates.back().ball->position_F - run.truth.back()).norm(), 0.05);
  const fusion::TeammateStanding& standing = fusion.teammates().at(4);
  EXPECT_FALSE(standing.discounted);
  EXPECT_EQ(standing.examples, 10);
  EXPECT_LT(standing.median_gap_m, 0.15);
}

// A robot at p_F (its centre on the floor) as the omni camera of a robot at pose sees it, with the
// camera's noise (0.01 rad of bearing; 3 cm + 4 % of the distance along it).
fw::OmniRobotObservation omniRobotView(const Eigen::Vector2d& p_F, const fw::RobotPose& pose, std::mt19937& random) {
  const Eigen::Vector3d p_R = pose.T_F_R().inverse() * Eigen::Vector3d(p_F.x(), p_F.y(), 0.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  fw::OmniRobotObservation robot;
  robot.bearing_sigma_rad = 0.01;
  robot.distance_sigma_m = 0.03 + 0.04 * p_R.head<2>().norm();
  robot.bearing_rad = std::atan2(-p_R.x(), p_R.y()) + robot.bearing_sigma_rad * normal(random);
  robot.distance_m = p_R.head<2>().norm() + robot.distance_sigma_m * normal(random);
  return robot;
}

TEST(Fusion, ATeammateThatSeesTheRobotsElsewhereIsDiscountedBeforeItsBallIsEverUsed) {
  // This robot stands at the origin, a striker 3 m to its right and 3 m ahead, the keeper 7 m ahead
  // facing it; every omni camera sees the other robots. A ball lies 3 m ahead, which only the
  // keeper's Kinect sees. The keeper believes it stands where it does, a metre to the side, or
  // turned by twenty degrees, and tells what it sees every 50 ms, 0.1 s late; the striker tells
  // where it stands. Nothing this robot sees of the ball can judge the keeper: it must be found out
  // by where it puts the robots, before its first ball is used. Once by where it puts this robot;
  // once with this robot hidden from it (behind the striker, say): then by where it puts the
  // striker, who says where it stands and whom this robot's own camera sees there.
  const Eigen::Vector2d striker(3.0, 3.0);
  const Eigen::Vector3d ball(1.0, 3.0, kRadius);
  const fw::RobotPose keeper = poseAt(0.5, 7.0, M_PI, kT0);
  for (const bool keeper_sees_this_robot : {true, false}) {
    for (const fw::RobotPose& believed : {keeper, poseAt(1.5, 7.0, M_PI, kT0), poseAt(0.5, 7.0, M_PI + 0.35, kT0)}) {
      const bool mislocalised = believed.x_m != keeper.x_m || believed.theta_rad != keeper.theta_rad;
      const std::string what = std::string(mislocalised ? "a mislocalised" : "a well localised") + " keeper " +
                               (keeper_sees_this_robot ? "seeing this robot" : "seeing only the striker");
      fusion::BallFusion fusion(testConfig());
      std::mt19937 random(17);
      std::vector<std::pair<double, fw::TeamMessage>> in_flight;  // arrival time, message
      std::vector<fusion::FusionUpdate> updates;
      for (int i = 0; i < 60; ++i) {
        const double t = kT0 + i / 30.0;
        for (auto it = in_flight.begin(); it != in_flight.end();) {
          if (it->first > t) {
            ++it;
            continue;
          }
          updates.push_back(fusion.addTeamMessage(it->second));
          it = in_flight.erase(it);
        }
        fusion.addPose(standingAtOrigin(t));
        updates.push_back(fusion.addKinectFrame(t, {}));
        const double t_omni = t + 0.01;
        fusion.addPose(standingAtOrigin(t_omni));
        updates.push_back(
            fusion.addOmniFrame(t_omni, {},
                                {omniRobotView(striker, standingAtOrigin(t_omni), random),
                                 omniRobotView({keeper.x_m, keeper.y_m}, standingAtOrigin(t_omni), random)}));
        if (i % 3 == 1) continue;  // a message every 50 ms from each
        fw::TeamMessage from_striker;
        from_striker.robot_id = 2;
        from_striker.robot_name = "striker";
        from_striker.pose = poseAt(striker.x(), striker.y(), M_PI / 2, t);
        from_striker.pose_sigma_xy_m = 0.03;
        from_striker.pose_sigma_theta_rad = 0.0175;
        in_flight.emplace_back(t + 0.1, from_striker);
        fw::TeamMessage from_keeper =
            teammateMessage(keeper, poseAt(believed.x_m, believed.y_m, believed.theta_rad, t), {{t, ball}}, random);
        std::vector<Eigen::Vector2d> seen_by_keeper{striker};
        if (keeper_sees_this_robot) seen_by_keeper.emplace_back(0.0, 0.0);
        for (const Eigen::Vector2d& robot : seen_by_keeper) {
          from_keeper.robots_seen.push_back(
              fusion::seenRobot_F(omniRobotView(robot, keeper, random), *from_keeper.pose, testConfig().omni, t_omni));
        }
        in_flight.emplace_back(t + 0.1, from_keeper);
      }
      ASSERT_EQ(fusion.teammates().count(4), 1u) << what;
      const fusion::TeammateStanding& standing = fusion.teammates().at(4);
      EXPECT_EQ(standing.examples, testConfig().team.judge_examples) << what;
      EXPECT_EQ(standing.discounted, mislocalised)
          << what << ": median " << standing.median_mahalanobis << " sigma, " << standing.median_gap_m << " m";
      EXPECT_EQ(standing.median_gap_m > 0.7, mislocalised) << what << ": " << standing.median_gap_m << " m";
      EXPECT_EQ(standing.median_mahalanobis < 2.0, !mislocalised) << what << ": " << standing.median_mahalanobis;
      int with_keeper = 0;
      for (const fusion::FusionUpdate& update : updates) {
        with_keeper +=
            update.ball && std::count(update.ball->sources.begin(), update.ball->sources.end(), "team:keeper") > 0;
      }
      EXPECT_EQ(with_keeper > 0, !mislocalised) << what << ": " << with_keeper << " world balls from its balls";
      const std::optional<fw::FusedBall>& last = updates.back().ball;
      EXPECT_EQ(last && (last->position_F - ball).norm() < 0.15, !mislocalised) << what << ": the ball, by its balls";
    }
  }
}

TEST(Fusion, ATeammatesRobotsSeenAreJudgedEvenWhenTheFrameTheyWaitedForComesTooLate) {
  // The keeper, 7 m ahead and facing this robot, says every 100 ms where it sees this robot. Its
  // sightings are judged with this robot's next own frame; one of those frames comes stamped 0.5 s
  // behind the others (later than fusion.max_delay_s, a stalled USB transfer) and is dropped. The
  // sightings it carried must wait for the frame after it, not vanish with it.
  fusion::BallFusion fusion(testConfig());
  std::mt19937 random(5);
  const fw::RobotPose keeper = poseAt(0.5, 7.0, M_PI, kT0);
  constexpr int kMessages = 6;
  int heard = 0;
  for (int i = 0; i < 3 * kMessages; ++i) {
    const double t = kT0 + i / 30.0;
    fusion.addPose(standingAtOrigin(t));
    if (i % 3 == 0) {
      fw::TeamMessage message =
          teammateMessage(keeper, poseAt(keeper.x_m, keeper.y_m, keeper.theta_rad, t), {}, random);
      message.robots_seen = {
          fusion::seenRobot_F(omniRobotView({0.0, 0.0}, keeper, random), *message.pose, testConfig().omni, t)};
      fusion.addTeamMessage(message);
      ++heard;
      if (heard == 3) {
        const int dropped_before = fusion.lateFramesDropped();
        fusion.addKinectFrame(t - 0.5, {});
        ASSERT_EQ(fusion.lateFramesDropped(), dropped_before + 1) << "the late frame is dropped";
      }
    }
    fusion.addKinectFrame(t + 0.001, {});
  }
  ASSERT_EQ(fusion.teammates().count(4), 1u);
  ASSERT_LT(kMessages, testConfig().team.judge_examples);
  EXPECT_EQ(fusion.teammates().at(4).examples, kMessages) << "every message's sightings judged";
  EXPECT_FALSE(fusion.teammates().at(4).discounted);
}

// An omni camera's view of p_F with its noise: 1.5 degrees of bearing, 5 cm and 5 % of distance.
fw::OmniBallObservation noisyOmniView(const Eigen::Vector3d& p_F, const fw::RobotPose& pose, std::mt19937& random) {
  std::normal_distribution<double> unit(0.0, 1.0);
  fw::OmniBallObservation omni = omniView(p_F, pose, 0.75);
  omni.bearing_rad += 0.026 * unit(random);
  omni.distance_m = std::max(0.1, omni.distance_m + (0.05 + 0.05 * omni.distance_m) * unit(random));
  return omni;
}

// The ray a teammate's omni camera (viewpoint 0.75 m up, view top 0.6 m) sends for an omni ball.
fw::BallRay rayOf(const fw::OmniBallObservation& omni, const fw::RobotPose& pose, double t) {
  fw::BallRay ray;
  ray.origin_F = pose.fieldFromRobot({0.0, 0.0, 0.75});
  Eigen::Vector3d ground_R = omni.groundPoint_R();
  ground_R.z() = kRadius;
  ray.direction_F = (pose.fieldFromRobot(ground_R) - ray.origin_F).normalized();
  ray.bearing_sigma_rad = 0.026;
  const double d = omni.distance_m, drop = 0.75 - kRadius;
  ray.elevation_sigma_rad = (0.05 + 0.05 * d) * drop / (d * d + drop * drop);
  ray.view_top_m = 0.6;
  ray.time_s = t;
  return ray;
}

TEST(Fusion, TwoOrThreeRobotsOmniRaysPlaceABallInTheAirThatOneCannot) {
  // A ball hopping up to 0.57 m across the field, below every omni camera's view top: this robot at
  // the origin sees it with its omni camera only, and so do the keeper at (4, 5) and the striker at
  // (-4, 6), their rays arriving every 50 ms, 80-130 ms late, a fifth lost. One camera puts a ball in
  // the air somewhere on its ray (the flight's physics narrows that down once it has been followed
  // from the floor); two rays meet at it, and a third adds its own direction.
  const Eigen::Vector3d p0(-1.5, 2.5, kRadius), v0(1.2, 0.8, 3.0);
  const Truth hops = [&](double t) { return lobAt(t, kT0 + 0.2, p0, v0); };
  struct Teammate {
    int robot_id;
    const char* name;
    fw::RobotPose pose;
  };
  const std::vector<Teammate> team{{4, "keeper", poseAt(4.0, 5.0, 2.0, kT0)},
                                   {2, "striker", poseAt(-4.0, 6.0, -2.0, kT0)}};
  const auto airErrors = [&](std::size_t teammates) {
    fusion::BallFusion fusion(testConfig());
    std::mt19937 random(5);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<std::pair<double, fw::TeamMessage>> in_flight;
    std::vector<fw::TeamMessage> next(teammates);
    std::vector<double> errors_m;
    for (int i = 0; i * (1.0 / 30) < 3.0; ++i) {
      const double t = kT0 + (i + 0.5) / 30.0;
      fusion.addPose(standingAtOrigin(t));
      for (auto it = in_flight.begin(); it != in_flight.end();) {
        if (it->first > t) {
          ++it;
          continue;
        }
        fusion.addTeamMessage(it->second);
        it = in_flight.erase(it);
      }
      const Eigen::Vector3d p = hops(t);
      std::vector<fw::OmniBallObservation> own;
      if (p.z() < 0.6) own.push_back(noisyOmniView(p, standingAtOrigin(t), random));
      const fusion::FusionUpdate update = fusion.addOmniFrame(t, own);
      // In the air: a hop higher than 10 cm (a missing world ball counts as infinitely wrong).
      if (p.z() > kRadius + 0.1) {
        errors_m.push_back(update.ball ? (update.ball->position_F - p).norm()
                                       : std::numeric_limits<double>::infinity());
      }
      for (std::size_t k = 0; k < teammates; ++k) {
        const double t_mate = t + 0.01 * (k + 1);  // their cameras' images fall between this robot's
        const Eigen::Vector3d q = hops(t_mate);
        if (q.z() < 0.6)
          next[k].omni_rays.push_back(rayOf(noisyOmniView(q, team[k].pose, random), team[k].pose, t_mate));
        if (i % 3 == 2) continue;
        next[k].robot_id = team[k].robot_id;
        next[k].robot_name = team[k].name;
        next[k].pose = team[k].pose;
        next[k].pose_sigma_xy_m = 0.03;
        next[k].pose_sigma_theta_rad = 0.0175;
        if (unit(random) > 0.2) in_flight.emplace_back(t + 0.08 + 0.05 * unit(random), next[k]);
        next[k] = fw::TeamMessage{};
      }
    }
    return errors_m;
  };
  const std::vector<double> alone = airErrors(0), two = airErrors(1), three = airErrors(2);
  ASSERT_GT(two.size(), 20u);
  ASSERT_EQ(three.size(), two.size());
  EXPECT_LE(fw::quantile(two, 0.5), 0.13) << "the issue's anchor: two robots' omni cameras, 0.13 m";
  EXPECT_LE(fw::quantile(three, 0.5), 0.13);
  EXPECT_GT(fw::quantile(alone, 0.5), fw::quantile(two, 0.5)) << "one camera alone places it worse";
  std::printf(
      "median in the air: %.3f m alone, %.3f m with the keeper's rays, %.3f m with the keeper's and the "
      "striker's; p90 %.3f, %.3f, %.3f m\n",
      fw::quantile(alone, 0.5), fw::quantile(two, 0.5), fw::quantile(three, 0.5), fw::quantile(alone, 0.9),
      fw::quantile(two, 0.9), fw::quantile(three, 0.9));
}

// Where and when the true ball first crosses y = line_y: (x, z, t), by 2 ms steps.
std::optional<Eigen::Vector3d> trueCrossing(const Truth& truth, double from_t, double to_t, double line_y) {
  Eigen::Vector3d before = truth(from_t);
  for (double t = from_t + 0.002; t <= to_t; t += 0.002) {
    const Eigen::Vector3d p = truth(t);
    if ((before.y() - line_y) * (p.y() - line_y) <= 0.0) return Eigen::Vector3d(p.x(), p.z(), t);
    before = p;
  }
  return std::nullopt;
}

TEST(Fusion, TheWorldBallSaysWhereAndWhenAShotWillCrossTheGoalLine) {
  // This team's goal line is at y = -11 m (the shipped 22 m field). A robot 4 m before it watches
  // shots at its goal with its Kinect and omni camera: one in the air all the way, a chip that
  // bounces 2 m before the line and crosses it in its hop, 0.3-0.4 m up, one along the floor. Each is kicked with five
  // balls whose physics the fusion's configured ball only approximates: drag 0.011-0.027 /m, restitution 0.5-0.7,
  // bounce friction 0.1-0.3, rolling 0.2-0.6 m/s^2.
  const auto robot = [](double t) { return poseAt(0.5, -7.0, 0.0, t); };
  const double line_y = -fusion::FusionConfig().field_length_m / 2.0;
  struct Shot {
    const char* name;
    Eigen::Vector3d p0, v0;
  };
  std::mt19937 random(29);
  std::uniform_real_distribution<double> drag(0.011, 0.027), restitution(0.5, 0.7), friction(0.1, 0.3),
      rolling(0.2, 0.6);
  for (const Shot& shot :
       {Shot{"lob", {1.0, -2.0, kRadius}, {-0.3, -10.0, 5.0}}, Shot{"chip", {1.0, -3.0, kRadius}, {-0.3, -8.0, 4.0}},
        Shot{"ground shot", {1.0, -3.0, kRadius}, {-0.2, -7.0, 0.0}}}) {
    // Every world ball from 0.2 s after the kick (the flight's velocity known) to 0.3 s before the
    // ball reaches the line (time for a goalkeeper to move).
    std::vector<double> off_m, late_s, sigmas, time_sigmas;
    int world_balls = 0;
    for (int ball = 0; ball < 5; ++ball) {
      TruePhysics physics;
      physics.drag_per_m = drag(random);
      physics.restitution = restitution(random);
      physics.bounce_friction = friction(random);
      physics.rolling_decel_mps2 = rolling(random);
      fusion::BallFusion fusion(testConfig());
      const double kick_t = kT0 + 0.3;
      const Truth truth = [&](double t) { return lobAt(t, kick_t, shot.p0, shot.v0, physics); };
      const std::optional<Eigen::Vector3d> crossing = trueCrossing(truth, kick_t, kick_t + 4.0, line_y);
      ASSERT_TRUE(crossing) << shot.name;
      const FedRun run = feed(fusion, truth, crossing->z() - kT0 + 0.2, robot, always);
      for (const fusion::FusionUpdate& update : run.updates) {
        if (!update.ball || update.time_s < kick_t + 0.2 || update.time_s > crossing->z() - 0.3) continue;
        ++world_balls;
        const auto& predicted = update.ball->goal_crossing;
        if (!predicted) continue;
        EXPECT_EQ(predicted->goal, -1) << shot.name;
        const double off = std::hypot(predicted->x_m - crossing->x(), predicted->z_m - crossing->y());
        off_m.push_back(off);
        const double late = std::abs(predicted->time_s - crossing->z());
        late_s.push_back(late);
        sigmas.push_back(off / predicted->sigma_m);
        time_sigmas.push_back(late / predicted->time_sigma_s);
      }
    }
    ASSERT_GT(world_balls, 25) << shot.name;
    EXPECT_GE(off_m.size(), world_balls * 9 / 10u) << shot.name << ": the crossing predicted";
    EXPECT_LE(fw::quantile(off_m, 0.5), 0.15) << shot.name;
    // A chip's arrival waits on a bounce whose friction the configured ball knows only on average.
    EXPECT_LE(fw::quantile(late_s, 0.5), 0.1) << shot.name;
    // The reported sigmas own the errors: nine in ten within two.
    EXPECT_LE(fw::quantile(sigmas, 0.9), 2.0) << shot.name;
    EXPECT_LE(fw::quantile(time_sigmas, 0.9), 2.0) << shot.name;
    std::printf(
        "%s: crossing predicted in %zu of %d world balls, %.3f m median off (%.3f m p90), %.3f s, "
        "off/sigma %.2f median, %.2f p90; time off/sigma %.2f median, %.2f p90\n",
        shot.name, off_m.size(), world_balls, fw::quantile(off_m, 0.5), fw::quantile(off_m, 0.9),
        fw::quantile(late_s, 0.5), fw::quantile(sigmas, 0.5), fw::quantile(sigmas, 0.9), fw::quantile(time_sigmas, 0.5),
        fw::quantile(time_sigmas, 0.9));
  }

  // A ball rolling slowly towards the line stops 0.2 m short of it: no crossing once its speed is known.
  fusion::BallFusion fusion(testConfig());
  const Truth slow = [&](double t) { return lobAt(t, kT0 + 0.3, {0.0, -8.9, kRadius}, {0.0, -1.5, 0.0}); };
  ASSERT_FALSE(trueCrossing(slow, kT0, kT0 + 6.0, line_y));
  const FedRun run = feed(fusion, slow, 3.0, robot, always);
  int world_balls = 0, crossings = 0;
  for (const fusion::FusionUpdate& update : run.updates) {
    if (!update.ball || update.time_s < kT0 + 0.8) continue;
    ++world_balls;
    crossings += update.ball->goal_crossing ? 1 : 0;
  }
  EXPECT_GT(world_balls, 50);
  EXPECT_LE(crossings, world_balls / 10) << "a ball that stops short";
}

TEST(Fusion, LearnsTheOmniLatencyFromABallBothSeeRolling) {
  fusion::FusionConfig config;  // estimate_latency on, as shipped
  ASSERT_TRUE(config.omni.estimate_latency);
  fusion::BallFusion fusion(config);
  // A ball rolled around the robot: 2 m/s on a 2.5 m circle.
  const Truth circling = [](double t) {
    const double a = 0.8 * (t - kT0);
    return Eigen::Vector3d(2.5 * std::sin(a), 2.5 * std::cos(a), kRadius);
  };
  const FedRun run = feed(fusion, circling, 4.0, standingAtOrigin, always, true, /*omni_stamp_late_s=*/0.04);
  ASSERT_TRUE(fusion.omniLatency());
  EXPECT_GE(fusion.omniLatencyExamples(), fusion::LatencyEstimator::kMinExamples);
  EXPECT_NEAR(fusion.omniLatency()->latency_s, 0.04, 0.01);
}

TEST(Fusion, ARobotWithoutAKinectLearnsItsOmniLatencyFromATeammatesKinect) {
  fusion::BallFusion fusion{fusion::FusionConfig()};
  // The ball rolls round this robot as above; only a teammate's Kinect, 4 m away, sees it (its
  // messages a fifth lost, the rest 80-130 ms late). This robot's omni camera is 40 ms late.
  const Truth circling = [](double t) {
    const double a = 0.8 * (t - kT0);
    return Eigen::Vector3d(2.5 * std::sin(a), 2.5 * std::cos(a), kRadius);
  };
  const fw::RobotPose teammate = poseAt(0.0, -4.0, 0.0, kT0);
  feedWithTeammate(fusion, circling, 4.0, never, always, teammate, teammate, false, {}, /*omni_stamp_late_s=*/0.04);
  ASSERT_TRUE(fusion.omniLatency()) << fusion.omniLatencyExamples() << " examples";
  EXPECT_NEAR(fusion.omniLatency()->latency_s, 0.04, 0.01);
}

TEST(Fusion, LearnsTheOmniLatencyFromLowLobsBothSeeFlyingPast) {
  fusion::BallFusion fusion{fusion::FusionConfig()};
  // Low lobs (under the omni's view top) across the robot's front, 1.5 m away, one a second; the
  // Kinect sees the ball only in flight, so only flights can teach the latency.
  const Truth lobs = [](double t) {
    const double kick_t = kT0 + std::floor(t - kT0);
    const double x0 = static_cast<int>(std::floor(t - kT0)) % 2 == 0 ? -2.0 : 2.0;
    return lobAt(t, kick_t, Eigen::Vector3d(x0, 1.5, kRadius), Eigen::Vector3d(x0 < 0 ? 5.0 : -5.0, 0.0, 2.8));
  };
  const auto in_flight = [](double, const Eigen::Vector3d& p_F) { return p_F.z() > kRadius + 0.03; };
  feed(fusion, lobs, 6.0, standingAtOrigin, in_flight, true, /*omni_stamp_late_s=*/0.04);
  ASSERT_TRUE(fusion.omniLatency()) << fusion.omniLatencyExamples() << " examples";
  EXPECT_NEAR(fusion.omniLatency()->latency_s, 0.04, 0.01);
}

// Feeds a standing robot's Kinect (where kinect_sees) and its omni camera, whose bearings and
// distances are as noisy as the simulator's camera draws them and whose distances are distance_scale
// times the truth (a mirror calibrated a few per cent off), stamped late_s late.
void feedNoisyOmni(fusion::BallFusion& fusion, const Truth& truth, double duration_s, const Sees& kinect_sees,
                   double late_s, double distance_scale, std::mt19937& random) {
  std::normal_distribution<double> normal(0.0, 1.0);
  const double frame_s = 1.0 / 30.0;
  for (int i = 0; i * frame_s < duration_s; ++i) {
    const double t = kT0 + i * frame_s, t_omni = t + 0.5 * frame_s;
    fusion.addPose(standingAtOrigin(t));
    std::vector<fw::BallObservation> kinect;
    if (kinect_sees(t, truth(t))) kinect.push_back(kinectView(truth(t), standingAtOrigin(t), random));
    fusion.addKinectFrame(t, kinect);
    std::vector<fw::OmniBallObservation> omni;
    if (truth(t_omni).z() < 0.6) {
      fw::OmniBallObservation ball = omniView(truth(t_omni), standingAtOrigin(t_omni), 0.75);
      ball.bearing_sigma_rad = 0.01;
      ball.distance_sigma_m = 0.03 + 0.04 * ball.distance_m;
      ball.bearing_rad += ball.bearing_sigma_rad * normal(random);
      ball.distance_m = distance_scale * ball.distance_m + ball.distance_sigma_m * normal(random);
      omni.push_back(ball);
    }
    fusion.addPose(standingAtOrigin(t_omni));
    fusion.addOmniFrame(t_omni + late_s, omni);
  }
}

// What a standing robot's fusion learns of its omni camera's latency, per seed 1-5: the camera is
// 20-60 ms late and its distances 0.97-1.03 times the truth, both drawn from the seed.
struct LearntLatency {
  int seed = 0;
  double late_s = 0.0;
  std::optional<fusion::LatencyEstimator::Fit> learnt;
  int examples = 0;
};
std::vector<LearntLatency> learnOmniLatencyOverSeeds(const Truth& truth, double duration_s, const Sees& kinect_sees) {
  std::vector<LearntLatency> runs;
  for (int seed = 1; seed <= 5; ++seed) {
    std::mt19937 random(seed);
    LearntLatency run;
    run.seed = seed;
    run.late_s = std::uniform_real_distribution<double>(0.02, 0.06)(random);
    const double distance_scale = std::uniform_real_distribution<double>(0.97, 1.03)(random);
    fusion::BallFusion fusion{fusion::FusionConfig()};
    feedNoisyOmni(fusion, truth, duration_s, kinect_sees, run.late_s, distance_scale, random);
    run.learnt = fusion.omniLatency();
    run.examples = fusion.omniLatencyExamples();
    runs.push_back(run);
  }
  return runs;
}

TEST(Fusion, TheOmniLatencyFromBallsRolledStraightAwayIsAsSureAsItSays) {
  // A ball rolled away along the robot's +y at 3 m/s from 0.8 m, every 2 s: its bearing stands still,
  // so the Kinect's bearings turn only by their noise, which is in the residuals too (it had the
  // latency 60-95 ms late, sure to 4-5 ms); the distances change, a few per cent off.
  const Truth rolling = [](double t) {
    const double kick_t = kT0 + 2.0 * std::floor((t - kT0) / 2.0) + 0.3;
    return lobAt(t, kick_t, Eigen::Vector3d(0.0, 0.8, kRadius), Eigen::Vector3d(0.0, 3.0, 0.0));
  };
  for (const LearntLatency& run : learnOmniLatencyOverSeeds(rolling, 16.0, always)) {
    ASSERT_TRUE(run.learnt) << "seed " << run.seed << ": " << run.examples << " examples";
    EXPECT_LE(run.learnt->sigma_s, 0.01) << "seed " << run.seed;
    EXPECT_LE(std::abs(run.learnt->latency_s - run.late_s), 2.5 * run.learnt->sigma_s)
        << "seed " << run.seed << ": " << 1000 * run.late_s << " ms late, learnt " << 1000 * run.learnt->latency_s
        << " +- " << 1000 * run.learnt->sigma_s << " ms";
  }
}

TEST(Fusion, LearnsTheOmniLatencyFromLobsStraightAtTheRobotWhosePhantomRunsOut) {
  // Lobs from 5 m straight at the robot, one every 1.5 s: their bearing stands still, and the omni sees
  // each only over its first few frames, its phantom running out as the ball rises to the top of
  // the view. The Kinect sees the ball in flight only, as after a kick from far away.
  const Truth lobs = [](double t) {
    const double kick_t = kT0 + 1.5 * std::floor((t - kT0) / 1.5);
    return lobAt(t, kick_t, Eigen::Vector3d(0.0, 5.0, kRadius), Eigen::Vector3d(0.0, -6.0, 4.5));
  };
  const auto in_flight = [](double, const Eigen::Vector3d& p_F) { return p_F.z() > kRadius + 0.03; };
  for (const LearntLatency& run : learnOmniLatencyOverSeeds(lobs, 9.0, in_flight)) {
    ASSERT_TRUE(run.learnt) << "seed " << run.seed << ": " << run.examples << " examples";
    EXPECT_NEAR(run.learnt->latency_s, run.late_s, 0.01) << "seed " << run.seed;
  }
}

TEST(Fusion, ASingleLobStraightAtTheRobotTeachesTheOmniLatencyFromItsFewFrames) {
  // One lob from 5 m straight at the standing robot: the omni sees it over the few frames before
  // its phantom leaves the view, the fusion report's lobs landing behind the robot in small. Those
  // frames are the only ones that carry the latency: what they teach is applied, as sure as it says.
  const Truth lob = [](double t) {
    return lobAt(t, kT0 + 0.3, Eigen::Vector3d(0.0, 5.0, kRadius), Eigen::Vector3d(0.0, -6.0, 4.5));
  };
  const auto in_flight = [](double, const Eigen::Vector3d& p_F) { return p_F.z() > kRadius + 0.03; };
  for (const LearntLatency& run : learnOmniLatencyOverSeeds(lob, 1.5, in_flight)) {
    ASSERT_TRUE(run.learnt) << "seed " << run.seed << ": " << run.examples << " examples";
    EXPECT_LE(std::abs(run.learnt->latency_s - run.late_s), 2.5 * run.learnt->sigma_s)
        << "seed " << run.seed << ": " << 1000 * run.late_s << " ms late, learnt " << 1000 * run.learnt->latency_s
        << " +- " << 1000 * run.learnt->sigma_s << " ms from " << run.examples << " examples";
    EXPECT_LT(std::abs(run.learnt->latency_s - run.late_s), 0.5 * run.late_s)
        << "seed " << run.seed << ": nearer than configured";
  }
}

TEST(Fusion, AnOmniPhantomRisingTowardsTheMirrorIsReadForItsWholeLateness) {
  // A lob kicked 4 m in front of the robot, rising at 3.8 m/s, 0.56 m up: its phantom is 9-10 m
  // out and runs away ever faster (the distance goes as 1 / (viewpoint height - ball height)). An
  // omni camera 20-60 ms late shows the phantom of that much earlier. Read by the rate at the
  // reading's own time, the steepest, the lateness came out at 0.6-0.85 of itself (the report's
  // lobs landing behind the robot were learnt 15-20 ms short); the secant reads all of it.
  const fusion::OmniConfig omni;
  const auto ball_R = [](double t) {
    return Eigen::Vector3d(0.3, 4.0 - 4.0 * t, kRadius + 3.8 * t - 0.5 * fw::kGravity_mps2 * t * t);
  };
  const auto distance = [&](double t) { return fusion::omniView_R(ball_R(t), omni, kRadius)[1]; };
  const auto bearing = [&](double t) { return fusion::omniView_R(ball_R(t), omni, kRadius)[0]; };
  const double t = 0.145;
  ASSERT_NEAR(ball_R(t).z(), 0.56, 0.01);
  for (const double late_s : {0.02, 0.04, 0.06}) {
    const double residual = distance(t - late_s) - distance(t);
    const double tangent = fusion::omniViewJacobian_R(ball_R(t), omni, kRadius).row(1) *
                           Eigen::Vector3d(0.0, -4.0, 3.8 - fw::kGravity_mps2 * t);
    const double secant =
        fusion::omniSecantRate([&](double tau) { return distance(t) - distance(t - tau); }, residual, tangent, 0.2);
    EXPECT_NEAR(-residual / secant, late_s, 1e-4) << 1000 * late_s << " ms late";
    EXPECT_LT(-residual / tangent, 0.9 * late_s) << "the tangent's reading, for contrast";
    // The bearing hardly bends over the lateness: both rates read it.
    const double bearing_residual = bearing(t - late_s) - bearing(t);
    const double bearing_tangent = fusion::omniViewJacobian_R(ball_R(t), omni, kRadius).row(0) *
                                   Eigen::Vector3d(0.0, -4.0, 3.8 - fw::kGravity_mps2 * t);
    const double bearing_secant = fusion::omniSecantRate([&](double tau) { return bearing(t) - bearing(t - tau); },
                                                         bearing_residual, bearing_tangent, 0.2);
    EXPECT_NEAR(-bearing_residual / bearing_secant, late_s, 1e-4);
  }
  // A residual no offset within the reach explains (its noise) keeps the tangent.
  EXPECT_EQ(fusion::omniSecantRate([&](double tau) { return distance(t) - distance(t - tau); }, -1000.0, 100.0, 0.2),
            100.0);
}

TEST(Fusion, AnOmniReadingWhoseViewTurnsBackWithinThePlausibleOffsetsCannotSayWhichWayItIsLate) {
  // A lob passing over the robot 0.11 m beside the camera's axis, 0.53 m up, at 6.15 m/s: its
  // phantom's distance is at its minimum 6.5 ms after the reading. Stamps 21 ms late the other way
  // show it beyond that minimum, as far out as it was 4.6 ms before: the secant reads 4.6 ms the
  // wrong way, and in the fusion report that one reading took the estimate's sigma from 14 to 5 ms
  // while it stood 20-25 ms off (lob_over_robot, seed 2).
  const fusion::OmniConfig omni;
  const auto ball_R = [](double t) { return Eigen::Vector3d(-0.11, 0.04 - 6.15 * t, 0.53); };
  const auto distance = [&](double t) { return fusion::omniView_R(ball_R(t), omni, kRadius)[1]; };
  const auto change_over = [&](double tau) { return distance(0.0) - distance(-tau); };
  const double tangent = fusion::omniViewJacobian_R(ball_R(0.0), omni, kRadius).row(1) * Eigen::Vector3d(0, -6.15, 0);
  const double residual = distance(0.021) - distance(0.0);
  ASSERT_LT(tangent, 0.0);
  ASSERT_GT(residual, 0.0);
  EXPECT_TRUE(fusion::omniOffsetIsAmbiguous(change_over, residual, tangent, 0.045)) << "within 3 sigma of 15 ms";
  EXPECT_FALSE(fusion::omniOffsetIsAmbiguous(change_over, residual, tangent, 0.005)) << "the turn beyond the window";
  // Where the camera could not have seen the ball, the view says nothing.
  EXPECT_FALSE(fusion::omniOffsetIsAmbiguous([](double) { return std::numeric_limits<double>::quiet_NaN(); }, residual,
                                             tangent, 0.045));
  // A ball rolled straight away: its distance grows whichever way the time is off.
  const auto rolling = [](double t) {
    return fusion::omniView_R(Eigen::Vector3d(0.5, 2.0 + 3.0 * t, kRadius), fusion::OmniConfig(), kRadius)[1];
  };
  for (const double late_s : {-0.03, 0.03}) {
    const double rolled_residual = rolling(-late_s) - rolling(0.0);
    EXPECT_FALSE(fusion::omniOffsetIsAmbiguous([&](double tau) { return rolling(0.0) - rolling(-tau); },
                                               rolled_residual, 3.0, 0.15))
        << 1000 * late_s << " ms late";
  }
}

TEST(Fusion, LearnsTheOmniLatencyFromTheRobotsTurnWithTheBallAtRest) {
  fusion::BallFusion fusion{fusion::FusionConfig()};
  // The robot turns on the spot at 1.5 rad/s; the ball lies still, in the Kinect's 57 degrees once a
  // turn. A late omni stamp shows as a bearing that lags the turn.
  const auto turning = [](double t) { return poseAt(0.0, 0.0, 1.5 * (t - kT0), t); };
  const Truth resting = [](double) { return Eigen::Vector3d(-0.8, 2.9, kRadius); };
  const auto in_kinect_view = [&](double t, const Eigen::Vector3d& p_F) {
    const Eigen::Vector3d p_R = turning(t).T_F_R().inverse() * p_F;
    return std::abs(std::atan2(p_R.x(), p_R.y())) < fw::degreesToRadians(28.5);
  };
  feed(fusion, resting, 6.0, turning, in_kinect_view, true, /*omni_stamp_late_s=*/0.04);
  ASSERT_TRUE(fusion.omniLatency()) << fusion.omniLatencyExamples() << " examples";
  EXPECT_NEAR(fusion.omniLatency()->latency_s, 0.04, 0.01);
}

// A localisation's heading error: a degree, correlated over a second (the simulator's model), moved
// on by a frame at each pose it gives. It draws from the caller's generator and distribution, in
// the caller's order.
class WanderingHeading {
 public:
  WanderingHeading(std::mt19937& random, std::normal_distribution<double>& normal, double frame_s)
      : random_(random), normal_(normal), keep_(std::exp(-frame_s / 1.0)), fresh_(std::sqrt(1.0 - keep_ * keep_)) {
    error_rad_ = kSigma_rad * normal_(random_);
  }
  // The pose as the localisation believes it.
  fw::RobotPose believed(fw::RobotPose pose) {
    pose.theta_rad += error_rad_;
    error_rad_ = keep_ * error_rad_ + fresh_ * kSigma_rad * normal_(random_);
    return pose;
  }

 private:
  static constexpr double kSigma_rad = M_PI / 180.0;
  std::mt19937& random_;
  std::normal_distribution<double>& normal_;
  double keep_, fresh_, error_rad_ = 0.0;
};

// A robot at the field's origin that stands for a second, then swings its heading back and forth by up
// to swing_rad either way, every 3 s.
fw::RobotPose standThenSwing(double swing_rad, double t) {
  const double turning_s = std::max(0.0, t - kT0 - 1.0);
  return poseAt(0.0, 0.0, swing_rad * std::sin(2.0 * M_PI * turning_s / 3.0), t);
}

// A robot without a Kinect (or whose Kinect does not see the ball) and a ball at rest 3 m away:
// it stands for a second, then turns back and forth for 10 s (half a radian either way, every 3 s:
// up to 1 rad/s). Its localisation's heading wanders by a degree, correlated over a second, and the
// omni's bearings carry 0.6 degrees of noise, its distances 5 cm. Where the ball lay while the robot
// stood, its bearing as the turn goes on lags the pose's heading by the omni's latency.
fusion::BallFusion turnWithoutAKinect(int seed, double late_s) {
  fusion::BallFusion fusion{fusion::FusionConfig()};
  std::mt19937 random(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto turning = [](double t) { return standThenSwing(0.5, t); };
  const Eigen::Vector3d resting(0.5, 3.0, kRadius);
  const double frame_s = 1.0 / 30.0;
  WanderingHeading localisation(random, normal, frame_s);
  for (int i = 0; i * frame_s < 11.0; ++i) {
    const double t = kT0 + i * frame_s;
    fusion.addPose(localisation.believed(turning(t)));
    fw::OmniBallObservation omni = omniView(resting, turning(t), 0.75);
    omni.bearing_rad += 0.01 * normal(random);
    omni.distance_m += 0.05 * normal(random);
    fusion.addOmniFrame(t + late_s, {omni});
  }
  return fusion;
}

TEST(Fusion, ARobotWithoutAKinectLearnsItsOmniLatencyFromItsOwnTurns) {
  int within_10ms = 0;
  double sum_s = 0.0;
  for (int seed = 1; seed <= 10; ++seed) {
    std::mt19937 random(1000 + seed);
    const double late_s = std::uniform_real_distribution<double>(0.02, 0.06)(random);
    const fusion::BallFusion fusion = turnWithoutAKinect(seed, late_s);
    ASSERT_TRUE(fusion.omniLatency()) << "seed " << seed << ": " << fusion.omniLatencyExamples() << " examples";
    const double error_s = fusion.omniLatency()->latency_s - late_s;
    std::printf("seed %d: %.0f ms late, learnt %.0f +- %.0f ms\n", seed, 1000 * late_s,
                1000 * fusion.omniLatency()->latency_s, 1000 * fusion.omniLatency()->sigma_s);
    within_10ms += std::abs(error_s) <= 0.01;
    sum_s += error_s;
  }
  EXPECT_GE(within_10ms, 9);
  EXPECT_LE(std::abs(sum_s / 10), 0.005) << "no bias";
}

// A robot whose Kinect sees a ball at rest 3 m ahead: it stands for a second, then turns back and forth
// for 10 s (0.35 rad either way, every 3 s: up to 0.7 rad/s, the ball always in the Kinect's view).
// Its localisation's heading wanders by a degree, correlated over a second, and its poses are stamped
// late_s late. The world's ball error over the last 5 s goes to errors_m.
fusion::BallFusion turnBesideARestingBall(int seed, double late_s, const fusion::FusionConfig& config,
                                          std::vector<double>& errors_m) {
  fusion::BallFusion fusion{config};
  std::mt19937 random(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto turning = [](double t) { return standThenSwing(0.35, t); };
  const Eigen::Vector3d resting(0.3, 3.0, kRadius);
  const double frame_s = 1.0 / 30.0;
  WanderingHeading localisation(random, normal, frame_s);
  for (int i = 0; i * frame_s < 11.0; ++i) {
    const double t = kT0 + i * frame_s;
    fw::RobotPose pose = localisation.believed(turning(t));
    pose.stamp.source_time_s += late_s;
    fusion.addPose(pose);
    const fusion::FusionUpdate& update = fusion.addKinectFrame(t, {kinectView(resting, turning(t), random)});
    if (t - kT0 > 6.0 && update.ball) errors_m.push_back((update.ball->position_F - resting).norm());
  }
  return fusion;
}

TEST(Fusion, LearnsThePosesLatencyFromTheRobotsTurnBesideABallAtRest) {
  // The heading's wander is most of each reading's error (a degree against 0.7 rad/s of turn: 25 ms),
  // shared by a second of them: it says 11 ms of standard error after 10 s of such turns.
  double sum_s = 0.0, worst_s = 0.0;
  std::vector<double> learnt_errors_m, unlearnt_errors_m;
  fusion::FusionConfig without;
  without.pose.estimate_latency = false;
  for (int seed = 1; seed <= 10; ++seed) {
    std::mt19937 random(2000 + seed);
    const double late_s = std::uniform_real_distribution<double>(0.02, 0.06)(random);
    const fusion::BallFusion fusion = turnBesideARestingBall(seed, late_s, fusion::FusionConfig(), learnt_errors_m);
    turnBesideARestingBall(seed, late_s, without, unlearnt_errors_m);
    ASSERT_TRUE(fusion.poseLatency()) << "seed " << seed << ": " << fusion.poseLatencyExamples() << " examples";
    const double error_s = fusion.poseLatency()->latency_s - late_s;
    std::printf("seed %d: pose %.0f ms late, learnt %.0f +- %.0f ms from %d examples\n", seed, 1000 * late_s,
                1000 * fusion.poseLatency()->latency_s, 1000 * fusion.poseLatency()->sigma_s,
                fusion.poseLatencyExamples());
    worst_s = std::max(worst_s, std::abs(error_s));
    sum_s += error_s;
  }
  EXPECT_LE(worst_s, 0.015);
  EXPECT_LE(std::abs(sum_s / 10), 0.005) << "no bias";
  // What it is for: the ball at rest stays where it lies while the robot turns.
  const double learnt_p90_m = fw::quantile(learnt_errors_m, 0.9), unlearnt_p90_m = fw::quantile(unlearnt_errors_m, 0.9);
  std::printf("world ball's error while turning, p90: %.3f m learnt, %.3f m not\n", learnt_p90_m, unlearnt_p90_m);
  EXPECT_LT(learnt_p90_m, 0.75 * unlearnt_p90_m);
}

TEST(Fusion, LearnsTheOmniLatencyFromTheRobotsTurnThroughALocalisationThatWanders) {
  // The robot turns at 40 deg/s with a ball at rest 5 m away in the Kinect's view for a second (the
  // start of the fusion report's lob_while_turning). Its localisation's heading wanders by a degree,
  // correlated over a second (the simulator's model), and the omni's bearings carry 0.6 degrees of
  // noise. Both sensors see the ball from the same robot: the heading's error is no time.
  const double turn_radps = fw::degreesToRadians(40.0);
  const auto turning = [&](double t) {
    return poseAt(0.0, 0.0, fw::degreesToRadians(-20.0) + turn_radps * (t - kT0), t);
  };
  const Eigen::Vector3d resting(0.5, 5.0, kRadius);
  std::vector<double> errors_s;  // learnt minus true
  for (int seed = 1; seed <= 10; ++seed) {
    std::mt19937 random(seed);
    std::normal_distribution<double> normal(0.0, 1.0);
    const double late_s = std::uniform_real_distribution<double>(0.02, 0.06)(random);
    const double frame_s = 1.0 / 30.0;
    WanderingHeading localisation(random, normal, frame_s);
    fusion::BallFusion fusion{fusion::FusionConfig()};
    for (int i = 0; i * frame_s < 1.0; ++i) {
      const double t = kT0 + i * frame_s;
      fusion.addPose(localisation.believed(turning(t)));
      fusion.addKinectFrame(t, {kinectView(resting, turning(t), random, 0.03)});
      fw::OmniBallObservation omni = omniView(resting, turning(t + 0.5 * frame_s), 0.75);
      omni.bearing_rad += 0.01 * normal(random);
      fusion.addOmniFrame(t + 0.5 * frame_s + late_s, {omni});
    }
    ASSERT_TRUE(fusion.omniLatency()) << "seed " << seed << ": " << fusion.omniLatencyExamples() << " examples";
    errors_s.push_back(fusion.omniLatency()->latency_s - late_s);
    std::printf("seed %d: %.0f ms late, learnt %.0f ms\n", seed, 1000 * late_s, 1000 * fusion.omniLatency()->latency_s);
  }
  // Without a bias (learnt from the track in the field frame, through the pose, the latency came out
  // 2.9 ms short on average here and up to 7 ms short at 60 ms), and each within 6 ms.
  double sum_s = 0.0, worst_s = 0.0;
  for (const double e : errors_s) {
    sum_s += e;
    worst_s = std::max(worst_s, std::abs(e));
  }
  // The Kinect's balls are carried on along a line over up to a third of a second, and a turning
  // robot sees them on an arc: a millisecond or two (5.3 ms at worst here).
  EXPECT_LE(std::abs(sum_s / errors_s.size()), 0.002);
  EXPECT_LE(worst_s, 0.006);
}

TEST(Fusion, TheWheelsOdometryKeepsAWanderingLocalisationOutOfAFlightsVelocity) {
  // The robot drives at 1.5 m/s and turns while the Kinect sees a lob until it rises out of view
  // (1.2 m); the rest of the flight is carried. Its localisation wanders as the simulator's (3 cm and a
  // degree, correlated over a second), whose steps from frame to frame read as ball velocity; the
  // wheels' odometry (2 % long) moves smoothly. The position's error is mostly the localisation's own
  // slow error, which the odometry does not remove (over these seeds 0.059 against 0.072 m, but
  // 0.066 m either way over seeds 13-24); the velocity's is what it removes.
  const auto driving = [](double t) { return poseAt(0.0, 1.5 * (t - kT0), 0.3 * (t - kT0), t); };
  const auto below_view = [](const Eigen::Vector3d& p) { return p.z() < 1.2; };
  std::vector<double> with_wheels_m, without_m, with_wheels_mps, without_mps;
  for (int seed = 1; seed <= 12; ++seed) {
    std::mt19937 random(seed);
    std::normal_distribution<double> normal(0.0, 1.0);
    const double keep = std::exp(-1.0 / 30.0), fresh = std::sqrt(1.0 - keep * keep);
    const Eigen::Vector3d sigma(0.03, 0.03, fw::degreesToRadians(1.0));
    std::vector<fw::RobotPose> believed;
    Eigen::Vector3d error = sigma.cwiseProduct(drawVector3(normal, random));
    for (int i = 0; i < 75; ++i) {
      const double t = kT0 + i / 30.0;
      fw::RobotPose pose = driving(t);
      pose.odometry = fw::RobotPose::Odometry{0.0, 1.02 * 1.5 * (t - kT0), 1.02 * 0.3 * (t - kT0)};
      pose.x_m += error.x();
      pose.y_m += error.y();
      pose.theta_rad += error.z();
      believed.push_back(pose);
      error = keep * error + fresh * sigma.cwiseProduct(drawVector3(normal, random));
    }
    const Eigen::Vector3d p0(0.0, 3.0, kRadius), v0(0.5, 3.0, 5.0);
    const Truth lob = [&](double t) { return lobAt(t, kT0 + 0.2, p0, v0); };
    for (const bool wheels : {true, false}) {
      fusion::BallFusion fusion(testConfig());
      std::mt19937 kinect_noise(seed);
      for (std::size_t i = 0; i < believed.size(); ++i) {
        const double t = kT0 + i / 30.0;
        fw::RobotPose pose = believed[i];
        if (!wheels) pose.odometry.reset();
        fusion.addPose(pose);
        const Eigen::Vector3d p = lob(t);
        std::vector<fw::BallObservation> kinect;
        if (below_view(p)) kinect.push_back(kinectView(p, driving(t), kinect_noise));
        const auto& ball = fusion.addKinectFrame(t, kinect).ball;
        if (p.z() > 0.3 && ball) {
          const Eigen::Vector3d v = (lob(t + 1e-3) - lob(t - 1e-3)) / 2e-3;
          (wheels ? with_wheels_m : without_m).push_back((ball->position_F - p).norm());
          (wheels ? with_wheels_mps : without_mps).push_back((ball->velocity_F - v).norm());
        }
      }
    }
  }
  ASSERT_EQ(with_wheels_m.size(), without_m.size());
  ASSERT_GT(with_wheels_m.size(), 100u);
  std::printf("air error median: %.3f m with the wheels' odometry, %.3f m without\n", fw::quantile(with_wheels_m, 0.5),
              fw::quantile(without_m, 0.5));
  std::printf("velocity error median: %.3f m/s with, %.3f m/s without\n", fw::quantile(with_wheels_mps, 0.5),
              fw::quantile(without_mps, 0.5));
  EXPECT_LT(fw::quantile(with_wheels_mps, 0.5), 0.85 * fw::quantile(without_mps, 0.5));
}

TEST(BounceLearner, LearnsTheRestitutionAndFrictionOfBouncesItSeesWholeAndNothingFromARollOrAHull) {
  fusion::MotionConfig configured;  // restitution 0.6 +- 0.07, bounce friction 0.2 +- 0.1
  // Balls chipped up in front of the robot, moving 1.5-2.5 m/s along the floor, bouncing with
  // restitution 0.45 and friction 0.35, seen at 30 Hz with 1 cm of noise (the detector's centre of a
  // ball 3 m away is steadier: docs/accuracy.md, Table 1).
  TruePhysics physics;
  physics.restitution = 0.45;
  physics.bounce_friction = 0.35;
  std::mt19937 random(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  fusion::BounceLearner learner(configured);
  int learnt_at = 0;
  for (int chip = 0; chip < 3; ++chip) {
    const double kick_t = kT0 + 5.0 * chip;
    const Eigen::Vector3d p0(0.0, 3.0, kRadius), v0(0.3 * chip, 1.5 + 0.5 * chip, 5.0);
    for (int i = 0; i < 90; ++i) {
      const double t = kick_t + i / 30.0;
      learnt_at += learner.add(1, t, lobAt(t, kick_t, p0, v0, physics) + drawVector3(noise, random));
    }
  }
  // The first bounce of each; the next hops, under 7 cm, are not told from the noise.
  ASSERT_GE(learner.bounces(), 3);
  EXPECT_EQ(learnt_at, learner.bounces());
  const double n = learner.bounces(), prior = fusion::BounceLearner::kPriorBounces;
  EXPECT_NEAR(learner.motion().restitution, (prior * 0.6 + n * 0.45) / (prior + n), 0.03);
  EXPECT_NEAR(learner.motion().bounce_friction, (prior * 0.2 + n * 0.35) / (prior + n), 0.06);
  EXPECT_LT(learner.motion().restitution_sigma, configured.restitution_sigma);
  // The rest of the motion is the configured one.
  EXPECT_EQ(learner.motion().drag_per_m, configured.drag_per_m);

  // Rolling on the floor, or thrown back off a robot's hull 0.4 m up, a ball teaches no bounce.
  fusion::BounceLearner rolled(configured), deflected(configured);
  for (int i = 0; i < 60; ++i) {
    const double t = i / 30.0;
    rolled.add(1, t, Eigen::Vector3d(0.0, 2.0 + 2.0 * t, kRadius) + drawVector3(noise, random));
    // Falling at 3 m/s onto the hull at t = 0.5 s, back up at 1.5 m/s.
    const double tau = t - 0.5, vz = tau < 0.0 ? -3.0 : 1.5;
    deflected.add(1, t,
                  Eigen::Vector3d(0.0, 3.0 - 2.0 * tau, 0.4 + vz * tau - 0.5 * fw::kGravity_mps2 * tau * tau) +
                      drawVector3(noise, random));
  }
  EXPECT_EQ(rolled.bounces(), 0);
  EXPECT_EQ(deflected.bounces(), 0);
}

TEST(Fusion, AHopBehindTheRobotFollowsTheBounceLearntFromTheBouncesItsKinectSaw) {
  // The match ball bounces deader than configured (restitution 0.45 for 0.6, friction 0.35 for 0.2).
  // It is first dropped in front of the robot, which sees it bounce; then lobbed over the robot,
  // bouncing behind it where only the omni camera sees it. The hops there follow the learnt bounce.
  TruePhysics physics;
  physics.restitution = 0.45;
  physics.bounce_friction = 0.35;
  const double lob_t = kT0 + 3.5;
  const Truth drop = [&](double t) { return lobAt(t, kT0 + 0.2, {0.0, 3.0, kRadius}, {0.0, 1.5, 5.0}, physics); };
  const Truth truth = [&](double t) {
    return t < lob_t ? drop(t) : lobAt(t, lob_t, drop(lob_t), {0.0, -6.0, 4.0}, physics);
  };
  const Sees in_front = [](double, const Eigen::Vector3d& p) { return p.y() > 0.5; };
  // The world ball from the lob's first touchdown behind the robot for a second.
  double first_touchdown_s = 0.0;
  for (double t = lob_t + 0.1; t < lob_t + 2.0 && first_touchdown_s == 0.0; t += 0.001) {
    if (truth(t).z() < kRadius + 1e-3) first_touchdown_s = t;
  }
  ASSERT_GT(first_touchdown_s, 0.0);
  const auto hopErrors = [&](bool learn) {
    fusion::FusionConfig config = testConfig();
    config.motion.learn_bounce = learn;
    fusion::BallFusion fusion(config);
    const FedRun run = feed(fusion, truth, first_touchdown_s + 1.0 - kT0, standingAtOrigin, in_front);
    std::vector<double> errors;
    for (std::size_t i = 0; i < run.updates.size(); ++i) {
      if (run.updates[i].time_s < first_touchdown_s + 0.05) continue;
      if (!run.updates[i].ball) {
        errors.push_back(std::numeric_limits<double>::infinity());
        continue;
      }
      errors.push_back((run.updates[i].ball->position_F - run.truth[i]).norm());
    }
    std::sort(errors.begin(), errors.end());
    return std::make_pair(errors[errors.size() / 2], fusion.bouncesLearnt());
  };
  const auto [learnt_median_m, learnt] = hopErrors(true);
  const auto [configured_median_m, none] = hopErrors(false);
  EXPECT_GE(learnt, 2) << "the drop's bounces";
  EXPECT_EQ(none, 0);
  EXPECT_LT(learnt_median_m, 0.7 * configured_median_m)
      << "median error over the hops behind the robot: " << learnt_median_m << " m learnt, " << configured_median_m
      << " m configured";
}

TEST(FusionConfig, ShippedDefaultsAreTheStructDefaults) {
  const fw::Config shipped = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", "", {});
  const fusion::FusionConfig read = fusion::readFusionConfig(shipped.block("fusion"));
  const fusion::FusionConfig code;
  EXPECT_EQ(read.max_delay_s, code.max_delay_s);
  EXPECT_EQ(read.field_length_m, code.field_length_m);
  EXPECT_EQ(read.motion.radius_m, code.motion.radius_m);
  EXPECT_EQ(read.motion.drag_per_m, code.motion.drag_per_m);
  EXPECT_EQ(read.motion.rolling_decel_mps2, code.motion.rolling_decel_mps2);
  EXPECT_EQ(read.motion.drag_sigma_per_m, code.motion.drag_sigma_per_m);
  EXPECT_EQ(read.motion.restitution, code.motion.restitution);
  EXPECT_EQ(read.motion.restitution_sigma, code.motion.restitution_sigma);
  EXPECT_EQ(read.motion.bounce_friction, code.motion.bounce_friction);
  EXPECT_EQ(read.motion.bounce_friction_sigma, code.motion.bounce_friction_sigma);
  EXPECT_EQ(read.motion.air_accel_sigma_mps2, code.motion.air_accel_sigma_mps2);
  EXPECT_EQ(read.motion.ground_accel_sigma_mps2, code.motion.ground_accel_sigma_mps2);
  EXPECT_EQ(read.motion.kick_rate_hz, code.motion.kick_rate_hz);
  EXPECT_EQ(read.motion.deflection_rate_hz, code.motion.deflection_rate_hz);
  EXPECT_EQ(read.motion.kick_speed_sigma_mps, code.motion.kick_speed_sigma_mps);
  EXPECT_EQ(read.motion.learn_bounce, code.motion.learn_bounce);
  EXPECT_EQ(read.kinect.source, code.kinect.source);
  EXPECT_EQ(read.kinect.latency_s, code.kinect.latency_s);
  EXPECT_EQ(read.omni.source, code.omni.source);
  EXPECT_EQ(read.omni.latency_s, code.omni.latency_s);
  EXPECT_EQ(read.omni.viewpoint_height_m, code.omni.viewpoint_height_m);
  EXPECT_EQ(read.omni.max_height_m, code.omni.max_height_m);
  EXPECT_EQ(read.omni.detection_probability, code.omni.detection_probability);
  EXPECT_NEAR(read.omni.bearing_sigma_rad, code.omni.bearing_sigma_rad, 1e-4);  // 1.5 degrees
  EXPECT_EQ(read.omni.distance_sigma_m, code.omni.distance_sigma_m);
  EXPECT_EQ(read.omni.distance_sigma_fraction, code.omni.distance_sigma_fraction);
  EXPECT_EQ(read.omni.estimate_latency, code.omni.estimate_latency);
  EXPECT_EQ(read.omni.timing_sigma_s, code.omni.timing_sigma_s);
  EXPECT_EQ(read.pose.latency_s, code.pose.latency_s);
  EXPECT_EQ(read.pose.sigma_xy_m, code.pose.sigma_xy_m);
  EXPECT_NEAR(read.pose.sigma_theta_rad, code.pose.sigma_theta_rad, 1e-4);  // 1 degree
  EXPECT_EQ(read.pose.odometry_blend_s, code.pose.odometry_blend_s);
  EXPECT_EQ(read.track.gate_sigma, code.track.gate_sigma);
  EXPECT_EQ(read.track.confirm_updates, code.track.confirm_updates);
  EXPECT_EQ(read.track.confirm_window_s, code.track.confirm_window_s);
  EXPECT_EQ(read.track.lost_after_s, code.track.lost_after_s);
  EXPECT_EQ(read.track.min_flight_speed_mps, code.track.min_flight_speed_mps);
  EXPECT_EQ(read.track.initial_speed_sigma_mps, code.track.initial_speed_sigma_mps);
  EXPECT_EQ(read.team.use, code.team.use);
  EXPECT_EQ(read.team.max_delay_s, code.team.max_delay_s);
  EXPECT_EQ(read.team.judge_examples, code.team.judge_examples);
  EXPECT_EQ(read.team.discount_sigma, code.team.discount_sigma);
  EXPECT_EQ(read.team.ignore, code.team.ignore);
}

TEST(FusionConfig, AnOmniViewTopAboveItsViewpointIsRefusedWithItsKey) {
  const fw::Config config =
      fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", "", {"fusion.omni.max_height_m=0.8"});
  try {
    fusion::readFusionConfig(config.block("fusion"));
    FAIL() << "a view reaching above the viewpoint was accepted";
  } catch (const fw::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("fusion.omni.max_height_m"), std::string::npos) << e.what();
  }
}

TEST(FusionConfig, AViewpointBelowTheBallIsRefusedWithItsKey) {
  const fw::Config config =
      fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", "", {"fusion.omni.viewpoint_height_m=0.05"});
  try {
    fusion::readFusionConfig(config.block("fusion"));
    FAIL() << "a viewpoint at 5 cm was accepted";
  } catch (const fw::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("fusion.omni.viewpoint_height_m"), std::string::npos) << e.what();
  }
}
