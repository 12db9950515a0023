// `kinect3d calibrate drag`: the ball's drag and bounce from recorded flights, checked on
// balls whose physics the fit was not told (the library on clean tracks, the command on the
// detector's output of a simulated lob), and the printed lines used as a robot file.
#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "framework_api/config.h"
#include "fusion/fusion_config.h"
#include "kinect3d/ball_physics_fit.h"
#include "kinect3d/config_io.h"
#include "kinect3d/sim/ball_motion.h"
#include "kinect3d/trajectory.h"
#include "random_draws.h"
#include "run_command.h"
#include "scoped_temp_dir.h"

namespace {

// A lob and its first bounce seen at 30 Hz with 5 mm of noise, as the detector reports it.
std::vector<fw::BallFrame> seenLob(const kinect3d::sim::BallPhysics& physics, int seed) {
  const kinect3d::sim::BallMotion motion({{0.2, 1.5, 0.11}, {0.4, 6.5, 5.0}, 0.0, false}, physics, 2.5, {});
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.005);
  std::vector<fw::BallFrame> frames;
  for (double t = 1.0 / 30; t < 2.5; t += 1.0 / 30) {
    fw::BallFrame frame;
    frame.stamp = {t, t};
    const Eigen::Vector3d p = motion.positionAt(t) + drawVector3(noise, rng);
    const fw::BallState state = p.z() > 0.19 ? fw::BallState::kAir : fw::BallState::kGround;
    frame.balls.push_back(
        fw::BallObservation::inRobotFrame(p, 2.5e-5 * Eigen::Matrix3d::Identity(), state, "kinect3d", frame.stamp));
    frames.push_back(frame);
  }
  return frames;
}

TEST(CalibrateDrag, RecoversTheDragRestitutionAndBounceFrictionOfBallsAcrossTheRange) {
  struct Ball {
    double drag, restitution, friction;
  };
  for (const Ball& ball : {Ball{0.011, 0.75, 0.1}, Ball{0.027, 0.55, 0.3}}) {
    const double drag = ball.drag, restitution = ball.restitution;
    SCOPED_TRACE("drag " + std::to_string(drag) + ", restitution " + std::to_string(restitution) + ", friction " +
                 std::to_string(ball.friction));
    kinect3d::sim::BallPhysics physics;
    physics.drag_per_m = drag;
    physics.restitution = restitution;
    physics.bounce_friction = ball.friction;
    const kinect3d::BallPhysicsCalibration fit = kinect3d::calibrateBallPhysics(seenLob(physics, 3), 0.11);
    ASSERT_GE(fit.flights.size(), 2u) << "the lob and the hop after its bounce";
    EXPECT_NEAR(fit.drag_per_m, drag, 0.003);
    EXPECT_GE(fit.drag_sigma_per_m, 0.002) << "the prior never pins the drag";
    ASSERT_TRUE(fit.restitution.has_value());
    EXPECT_NEAR(*fit.restitution, restitution, 0.08);
    ASSERT_TRUE(fit.bounce_friction.has_value());
    EXPECT_NEAR(*fit.bounce_friction, ball.friction, 0.05);
  }
}

TEST(CalibrateDrag, SaysWhatIsMissingWhenNothingFlies) {
  kinect3d::sim::BallPhysics physics;
  std::vector<fw::BallFrame> resting = seenLob(physics, 3);
  for (fw::BallFrame& frame : resting) frame.balls.front().position_m = Eigen::Vector3d(0.0, 2.0, 0.11);
  try {
    kinect3d::calibrateBallPhysics(resting, 0.11);
    FAIL() << "a ball that never flies has no drag to fit";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no flight to fit"), std::string::npos) << e.what();
  }
}

TEST(CalibrateDragCommand, FitsTheDetectorsFlightsAndPrintsARobotFile) {
  // A lob by a ball with less drag, more bounce and more friction than the shipped prior, through the
  // detector.
  ScopedTempDir dir;
  const std::string d = dir.path().string(), exe = KINECT3D_EXE;
  std::ofstream(d + "/lob.yaml") << "name: lob\nduration_s: 2.2\n"
                                    "sensor:\n  pose_in_robot: {x: 0.0, y: 0.0, z: 0.7, yaw_deg: 0.0, pitch_deg: "
                                    "0.0, roll_deg: 0.0}\n"
                                    "ball:\n  position: [0.1, 1.5, 0.11]\n  velocity: [0.2, 5.5, 4.6]\n"
                                    "  launch_time_s: 0.2\n"
                                    "physics:\n  drag_per_m: 0.013\n  restitution: 0.75\n  bounce_friction: 0.3\n";
  ASSERT_EQ(
      runCommand(exe + " detect --source sim:" + d + "/lob.yaml --output " + d + "/detect.jsonl 2>/dev/null").first, 0);
  const auto [status, out] = runCommand(exe + " calibrate drag " + d + "/detect.jsonl 2>&1");
  ASSERT_EQ(status, 0) << out;
  const std::size_t yaml = out.find("ball:\n");
  ASSERT_NE(yaml, std::string::npos) << out;
  std::ofstream(d + "/robot.yaml") << out.substr(yaml);
  const fw::Config config = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", d + "/robot.yaml", {});
  const kinect3d::TrajectoryConfig prior = kinect3d::readTrajectoryConfig(config.block("kinect3d"));
  EXPECT_NEAR(prior.drag_per_m, 0.013, 0.004) << out;
  const fusion::MotionConfig motion = fusion::readFusionConfig(config.block("fusion")).motion;
  EXPECT_NEAR(motion.restitution, 0.75, 0.1) << out;
  EXPECT_NEAR(motion.bounce_friction, 0.3, 0.08) << out;
}

TEST(CalibrateDragCommand, ABadLineIsNamedWithItsFileAndLine) {
  ScopedTempDir dir;
  const std::string file = dir.path().string() + "/detect.jsonl";
  std::ofstream(file) << "{\"t\": 1.0, \"balls\": []}\n{\"t\": 1.1, \"balls\": [{\"x\": 1, \"y\": 2}]}\n";
  const auto [status, out] = runCommand(std::string(KINECT3D_EXE) + " calibrate drag " + file + " 2>&1");
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find(file + ":2: balls[0]: missing \"z\""), std::string::npos) << out;
}

}  // namespace
