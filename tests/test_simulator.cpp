// The simulator against the Kinect v1 facts listed in docs/simulator.md.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <fstream>
#include <map>
#include <set>

#include "framework_api/config.h"
#include "kinect3d/point_projector.h"
#include "kinect3d/sim/field_sensors.h"
#include "kinect3d/sim/kinect_simulator.h"
#include "kinect3d/sim/people.h"
#include "scoped_temp_dir.h"
#include "sim_test_scenes.h"

#include "real_data.h"

namespace {

using kinect3d::DepthFrame;
using kinect3d::sim::GroundTruth;
using kinect3d::sim::KinectSimulator;
using kinect3d::sim::Scene;

double nguyenSigma_m(double z) { return 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4); }

// Depths (m) of the valid pixels in the central third of the image over `frames` frames.
std::vector<double> centralDepths(const Scene& scene, int frames) {
  KinectSimulator simulator(scene);
  DepthFrame frame;
  GroundTruth truth;
  std::vector<double> depths;
  for (int i = 0; i < frames; ++i) {
    simulator.render(i, frame, truth);
    for (int v = 160; v < 320; ++v) {
      for (int u = 213; u < 427; ++u) {
        if (frame.at(u, v) > 0) depths.push_back(frame.at(u, v) / 1000.0);
      }
    }
  }
  return depths;
}

TEST(Simulator, DepthLevelsAreSpacedLikeKinectQuantisation) {
  for (const double z : {2.0, 3.0, 4.0, 5.0, 6.0}) {
    SCOPED_TRACE("wall at " + std::to_string(z) + " m");
    Scene scene = testing_scenes::wallAt(z);
    scene.noise.shadows = false;
    const std::vector<double> depths = centralDepths(scene, 2);
    std::map<double, int> levels;
    for (const double d : depths) ++levels[d];
    // The gap between the two most populated neighbouring levels around the wall.
    std::vector<double> populated;
    for (const auto& [depth, count] : levels) {
      if (count > static_cast<int>(depths.size() / 50)) populated.push_back(depth);
    }
    ASSERT_GE(populated.size(), 3u) << "noise should spread the wall over several levels";
    double gap_sum = 0.0;
    for (std::size_t i = 1; i < populated.size(); ++i) gap_sum += populated[i] - populated[i - 1];
    const double c = gap_sum / (populated.size() - 1) / (z * z);
    EXPECT_NEAR(c, 0.0030, 0.0003) << "spacing dz = c z^2";
  }
}

TEST(Simulator, AxialNoiseMatchesNguyenSigma) {
  for (const double z : {2.0, 4.0}) {
    SCOPED_TRACE("wall at " + std::to_string(z) + " m");
    const std::vector<double> depths = centralDepths(testing_scenes::wallAt(z), 3);
    double mean = 0.0, square = 0.0;
    for (const double d : depths) mean += d;
    mean /= depths.size();
    for (const double d : depths) square += (d - mean) * (d - mean);
    const double sigma = std::sqrt(square / depths.size());
    EXPECT_NEAR(sigma, nguyenSigma_m(z), 0.25 * nguyenSigma_m(z));
    EXPECT_NEAR(mean, z, 0.01);
  }
}

// Pixels with no data in the columns just left and just right of a near object's image.
struct ShadowSides {
  int left = 0;
  int right = 0;
};
ShadowSides shadowBesideBox(const kinect3d::sim::KinectNoise& noise) {
  Scene scene = testing_scenes::wallAt(5.0);
  scene.noise = noise;
  kinect3d::sim::SceneObject pillar;
  pillar.shapes.push_back({kinect3d::sim::Shape::Kind::kBox, {0.0, 2.0, 0.7}, {0.3, 0.3, 0.6}, 0.0, 0.0});
  scene.objects.push_back(pillar);
  KinectSimulator simulator(scene);
  DepthFrame frame;
  GroundTruth truth;
  simulator.render(0, frame, truth);
  // The pillar spans x in [-0.15, 0.15] at y = 1.85: columns 319.5 -+ 575.8 * 0.15 / 1.85.
  const int left_edge = static_cast<int>(std::floor(319.5 - 575.8 * 0.15 / 1.85));
  const int right_edge = static_cast<int>(std::ceil(319.5 + 575.8 * 0.15 / 1.85));
  ShadowSides sides;
  for (int v = 230; v < 250; ++v) {
    for (int u = left_edge - 12; u < left_edge - 1; ++u) sides.left += frame.at(u, v) == 0;
    for (int u = right_edge + 2; u < right_edge + 13; ++u) sides.right += frame.at(u, v) == 0;
  }
  return sides;
}

TEST(Simulator, ProjectorShadowFallsOnTheSideTheRealSensorShows) {
  kinect3d::sim::KinectNoise noise = testing_scenes::noNoise();
  noise.shadows = true;
  const ShadowSides sides = shadowBesideBox(noise);
  // Width b f (1/z_near - 1/z_far) = 0.075 * 575.8 * (1/1.85 - 1/5) = 14.7 px: the whole
  // 11-column band left of the pillar is dark, none right of it.
  EXPECT_EQ(sides.left, 20 * 11);
  EXPECT_EQ(sides.right, 0);
  noise.shadows = false;
  EXPECT_EQ(shadowBesideBox(noise).left, 0);

  // The real frame: runs of missing depth bounded by a near surface on one side and a far one on
  // the other have the near surface on their right far more often than on their left.
  const std::optional<std::string> tum = realDataFile("real-depth/tum_depth.png");
  if (!tum) GTEST_SKIP() << "the simulated half ran; " << noRealData("real-depth/tum_depth.png");
  const cv::Mat real = cv::imread(*tum, cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(real.empty());
  int near_right = 0, near_left = 0;
  for (int v = 0; v < real.rows; ++v) {
    const auto* row = real.ptr<std::uint16_t>(v);
    for (int u = 1; u < real.cols;) {
      if (row[u] != 0 || row[u - 1] == 0) {
        ++u;
        continue;
      }
      const int start = u;
      while (u < real.cols && row[u] == 0) ++u;
      if (u == real.cols || u - start < 2 || u - start >= 40) continue;
      if (row[u] < 0.85 * row[start - 1]) ++near_right;
      if (row[start - 1] < 0.85 * row[u]) ++near_left;
    }
  }
  EXPECT_GT(near_right, 2 * near_left) << "real shadows lie left of near objects, as simulated";
}

TEST(Simulator, FastBallLeavesTrailBehindIt) {
  auto trailPixels = [](double exposure_s) {
    Scene scene = testing_scenes::wallAt(6.0);
    scene.noise = testing_scenes::noNoise();
    scene.noise.exposure_s = exposure_s;
    scene.physics.gravity_mps2 = 0.0;
    scene.physics.drag_per_m = 0.0;
    scene.ball = kinect3d::sim::BallLaunch{{-1.0, 3.0, 0.7}, {8.0, 0.0, 0.0}, 0.0, false};
    KinectSimulator simulator(scene);
    DepthFrame frame;
    GroundTruth truth;
    simulator.render(5, frame, truth);  // ball centre at x = -1 + 8 * 5/30 = 0.33 m
    const double u_ball = 319.5 + 575.8 * truth.ball_center_R.x() / truth.ball_center_R.y();
    int behind = 0, ahead = 0;
    for (int v = 200; v < 280; ++v) {
      for (int u = 0; u < 640; ++u) {
        const double z = frame.at(u, v) / 1000.0;
        if (z > 3.0 && z < 5.8) (u < u_ball ? behind : ahead)++;  // between ball surface and wall
      }
    }
    return std::make_pair(behind, ahead);
  };
  const auto [behind, ahead] = trailPixels(0.012);
  EXPECT_GT(behind, 50) << "mixed ball/wall depths must trail the ball";
  EXPECT_GT(behind, ahead / 2);
  const auto [still_behind, still_ahead] = trailPixels(0.0);
  EXPECT_EQ(still_behind + still_ahead, 0) << "no exposure time, no trail";
}

TEST(Simulator, BallPhysicsFallsBouncesAndRolls) {
  kinect3d::sim::BallPhysics physics;
  physics.drag_per_m = 0.0;
  kinect3d::sim::BallMotion motion({{0, 0, 0.11}, {0, 5, 5}, 0.0, false}, physics, 5.0, {});
  // Without drag: apex at t = 5/9.81 s, height 0.11 + 25 / (2 * 9.81).
  EXPECT_NEAR(motion.positionAt(5.0 / 9.81).z(), 0.11 + 25.0 / 19.62, 0.01);
  EXPECT_NEAR(motion.positionAt(10.0 / 9.81).y(), 50.0 / 9.81, 0.01);
  // Just after the first bounce the ball rises at restitution times its landing speed.
  EXPECT_NEAR(motion.velocityAt(10.0 / 9.81 + 0.01).z(), 0.6 * 5.0 - 9.81 * 0.01, 0.05);
  EXPECT_NEAR(motion.positionAt(4.9).z(), 0.11, 1e-6) << "comes to rest on the floor";
  EXPECT_LT(motion.velocityAt(4.9).norm(), motion.velocityAt(3.0).norm());

  physics.drag_per_m = 0.024;
  kinect3d::sim::BallMotion dragged({{0, 0, 0.11}, {0, 5, 5}, 0.0, false}, physics, 3.0, {});
  EXPECT_LT(dragged.positionAt(10.0 / 9.81 - 0.05).y(), motion.positionAt(10.0 / 9.81 - 0.05).y() - 0.1);

  // Sidespin, counter-clockwise seen from above, bends a ball flying along +y to the left (-x):
  // 10 rev/s at 8 m/s is about 1.5 m/s^2, so about 0.5 * 1.5 * 0.5^2 = 0.18 m after half a second.
  physics.drag_per_m = 0.0;
  physics.spin_rps = 10.0;
  kinect3d::sim::BallMotion curving({{0, 0, 0.11}, {0, 8, 4}, 0.0, false}, physics, 1.0, {});
  EXPECT_NEAR(curving.positionAt(0.5).x(), -0.5 * physics.magnus_m * 2 * M_PI * 10.0 * 8.0 * 0.25, 0.02);
  EXPECT_NEAR(curving.velocityAt(0.5).head<2>().norm(), 8.0, 0.01) << "the Magnus force turns, it does not slow";
}

TEST(Simulator, ABallShotAtARobotSpringsBackOffItsHullAndDrops) {
  const kinect3d::sim::Scene scene = kinect3d::sim::loadScene("ball_hits_robot");
  const kinect3d::sim::BallMotion hitting(*scene.ball, scene.physics, scene.duration_s, scene.objects);
  const kinect3d::sim::BallMotion unhindered(*scene.ball, scene.physics, scene.duration_s, {});  // no robots
  // The opponent's hull: a box 0.5 m wide and 0.78 m tall on the floor at (0.3, 2.5).
  const auto inside_hull = [](const Eigen::Vector3d& p) {
    return std::abs(p.x() - 0.3) < 0.25 + 0.10 && std::abs(p.y() - 2.5) < 0.25 + 0.10 && p.z() < 0.78 + 0.10;
  };
  bool went_through = false, entered = false;
  for (double t = scene.ball->launch_time_s; t < scene.duration_s; t += 0.005) {
    went_through |= inside_hull(unhindered.positionAt(t));
    entered |= inside_hull(hitting.positionAt(t));
  }
  EXPECT_TRUE(went_through) << "the shot is aimed at the robot";
  EXPECT_FALSE(entered) << "the ball never passes into the hull";
  const Eigen::Vector3d before = hitting.velocityAt(0.75), after = hitting.velocityAt(1.0);
  EXPECT_LT(before.y(), -3.0);
  // Off the hull's front face: the speed into it comes back at the hull's restitution (0.4), the
  // speed along it stays.
  EXPECT_NEAR(after.y(), -0.4 * before.y(), 0.1 * -before.y()) << "it springs back";
  EXPECT_NEAR(after.x(), before.x(), 0.1 * std::abs(before.x()));
  EXPECT_NEAR(hitting.positionAt(scene.duration_s).z(), scene.physics.radius_m, 1e-6) << "and drops to the floor";
}

TEST(Simulator, TruthAndRepeatability) {
  Scene scene = kinect3d::sim::loadScene("kick_away");
  KinectSimulator a(scene), b(scene);
  DepthFrame fa, fb;
  GroundTruth ta, tb;
  a.render(20, fa, ta);
  b.render(3, fb, tb);
  b.render(20, fb, tb);
  EXPECT_EQ(fa.depth_mm, fb.depth_mm) << "same seed and frame, same pixels, in any order";
  EXPECT_TRUE(ta.has_ball);
  EXPECT_TRUE(ta.airborne);
  EXPECT_GT(ta.visible_pixels, 100);
  EXPECT_GT(ta.clearance_m, 0.6);
  scene.noise.seed = 2;
  KinectSimulator c(scene);
  c.render(20, fb, tb);
  EXPECT_NE(fa.depth_mm, fb.depth_mm);
}

TEST(Simulator, EveryBuiltinSceneLoadsAndRenders) {
  for (const std::string& name : kinect3d::sim::builtinSceneNames()) {
    SCOPED_TRACE(name);
    KinectSimulator simulator(kinect3d::sim::loadScene(name));
    EXPECT_GT(simulator.frameCount(), 10);
    DepthFrame frame;
    GroundTruth truth;
    simulator.render(simulator.frameCount() / 2, frame, truth);
    const kinect3d::DepthStats stats = kinect3d::computeStats(frame);
    EXPECT_GT(stats.invalid_fraction, 0.02);
    EXPECT_LT(stats.invalid_fraction, 0.6);
  }
}

// The depth the simulator gives at pixel (u, v) of scene's first frame, with every effect off.
double exactDepthAt(Scene scene, int u, int v) {
  scene.noise = testing_scenes::noNoise();
  KinectSimulator simulator(scene);
  DepthFrame frame;
  GroundTruth truth;
  simulator.render(0, frame, truth);
  return frame.at(u, v) / 1000.0;
}

TEST(Simulator, CapsulesAreLimbsInAnyDirection) {
  // A limb of 5 cm radius 2 m ahead, level with the sensor: across the view, then pointing away
  // from the sensor (its near end's cap faces it).
  Scene across = testing_scenes::wallAt(6.0);
  kinect3d::sim::SceneObject limb;
  limb.shapes = {kinect3d::sim::Shape::capsule({-0.2, 2.0, 0.7}, {0.2, 2.0, 0.7}, 0.05, 0.0)};
  across.objects.push_back(limb);
  EXPECT_NEAR(exactDepthAt(across, 320, 240), 1.95, 0.002);
  EXPECT_NEAR(exactDepthAt(across, 320, 200), 6.0, 0.002) << "above the limb: the wall";
  Scene along = testing_scenes::wallAt(6.0);
  limb.shapes = {kinect3d::sim::Shape::capsule({0.0, 2.0, 0.7}, {0.0, 2.4, 0.7}, 0.05, 0.0)};
  along.objects.push_back(limb);
  EXPECT_NEAR(exactDepthAt(along, 320, 240), 1.95, 0.002);
}

TEST(People, BodyPartsAreWhereAPersonHasThem) {
  kinect3d::sim::Person person;  // 1.75 m, facing +y, arms down
  person.right_arm = kinect3d::sim::ArmPose::of(kinect3d::sim::Gesture::kRaised, 1.0);
  person.left_arm = kinect3d::sim::ArmPose::of(kinect3d::sim::Gesture::kHeldOut, -1.0);
  double top = 0.0, right_most = 0.0, left_most = 0.0;
  for (const kinect3d::sim::Shape& shape : person.shapes()) {
    top = std::max(top, shape.top_m());
    right_most = std::max(right_most, shape.center_m.x() + std::max(0.0, shape.axis_m.x()));
    left_most = std::min(left_most, shape.center_m.x() + std::min(0.0, shape.axis_m.x()));
  }
  EXPECT_GT(top, 2.0) << "a raised hand reaches above the head";
  EXPECT_LT(left_most, -0.7) << "an arm held out reaches sideways";
  EXPECT_LT(right_most, 0.35);
  kinect3d::sim::Person still;  // arms down: the head is the top
  double head_top = 0.0;
  for (const kinect3d::sim::Shape& shape : still.shapes()) head_top = std::max(head_top, shape.top_m());
  EXPECT_NEAR(head_top, 1.75, 0.05);
}

TEST(People, SceneFilesPlacePeopleAndNameWrongGestures) {
  const ScopedTempDir temp;
  auto write = [&](const std::string& person) {
    const std::string path = (temp.path() / "people.yaml").string();
    std::ofstream(path) << "name: people\nduration_s: 1.0\nsensor:\n  pose_in_robot: {x: 0.0, y: 0.0, z: 0.7, "
                           "yaw_deg: 0.0, pitch_deg: 0.0, roll_deg: 0.0}\nobjects:\n  - "
                        << person << "\n";
    return path;
  };
  const Scene scene = kinect3d::sim::loadScene(
      write("{type: person, center: [0.0, 3.0, 0.0], yaw_deg: 180, height: 1.9, left_arm: flag, hair_dropout: 1.0}"));
  ASSERT_EQ(scene.objects.size(), 1u);
  EXPECT_EQ(scene.objects[0].shapes.size(), 18u) << "legs, feet, torso, neck, hair, head, arms, hands, a flag";
  try {
    kinect3d::sim::loadScene(write("{type: person, center: [0.0, 3.0, 0.0], left_arm: waving}"));
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("left_arm"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("waving"), std::string::npos) << e.what();
  }
}

TEST(Simulator, DarkSurfacesLosePatchesNotSinglePixels) {
  // A wall with half its surface dark: about half its pixels return nothing, in patches, so that
  // most of what remains still has four valid neighbours (a surface, not flying pixels).
  Scene scene = testing_scenes::wallAt(3.0);
  scene.noise = testing_scenes::noNoise();
  scene.objects[0].shapes[0].dropout = 0.5;
  KinectSimulator simulator(scene);
  DepthFrame frame;
  GroundTruth truth;
  simulator.render(0, frame, truth);
  const kinect3d::PointProjector surface(kinect3d::PointProjector::Config{}, scene.intrinsics);
  int valid = 0, surface_points = 0;
  for (int v = 1; v < frame.height() - 1; ++v) {
    for (int u = 1; u < frame.width() - 1; ++u) {
      valid += frame.at(u, v) != 0;
      surface_points += surface.isSurface(frame, u, v);
    }
  }
  const double pixels = (frame.width() - 2.0) * (frame.height() - 2.0);
  EXPECT_NEAR(valid / pixels, 0.5, 0.05);
  EXPECT_GT(surface_points, 0.6 * valid);
}

TEST(Simulator, ABallsDarkPanelsReturnNoDepth) {
  // The hung ball 2 m ahead: its 12 black pentagons cover 28 % of it, a quarter or so of its disc.
  Scene scene = testing_scenes::wallAt(5.0);
  scene.ball = kinect3d::sim::BallLaunch{};
  scene.ball->position_m = {0.0, 2.0, 0.7};
  scene.ball->hanging = true;
  auto visible = [&](bool dark) {
    scene.ball->dark_panels = dark;
    KinectSimulator simulator(scene);
    DepthFrame frame;
    GroundTruth truth;
    simulator.render(0, frame, truth);
    return truth.visible_pixels;
  };
  const double share = double(visible(true)) / visible(false);
  EXPECT_GT(share, 0.55);
  EXPECT_LT(share, 0.9);
}

TEST(Simulator, AnotherKinectFacingOursHolesItsViewAndAddsFalseDepth) {
  Scene scene = testing_scenes::wallAt(4.0);
  scene.noise = testing_scenes::noNoise();
  auto frameWith = [&](double interference) {
    scene.noise.interference = interference;
    KinectSimulator simulator(scene);
    DepthFrame frame;
    GroundTruth truth;
    simulator.render(3, frame, truth);
    return frame;
  };
  const DepthFrame clean = frameWith(0.0), overlapped = frameWith(1.0);
  int holes = 0, holes_in_patches = 0, false_depth = 0;
  for (int v = 1; v < clean.height() - 1; ++v) {
    for (int u = 1; u < clean.width() - 1; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * clean.width() + u;
      if (clean.depth_mm[i] != 0 && overlapped.depth_mm[i] == 0) {
        ++holes;
        holes_in_patches += overlapped.depth_mm[i - 1] == 0 || overlapped.depth_mm[i + 1] == 0;
      }
      false_depth += overlapped.depth_mm[i] != 0 && std::abs(overlapped.depth_mm[i] - clean.depth_mm[i]) > 200;
    }
  }
  EXPECT_GT(holes, 1000) << "a tenth of an ellipse of 100-220 x 80-160 px";
  EXPECT_GT(holes_in_patches, 0.95 * holes) << "holes of 2-5 px radius, not single pixels";
  EXPECT_GT(false_depth, 100) << "clusters of 3-7 px across";
  EXPECT_LT(holes + false_depth, static_cast<int>(clean.depth_mm.size() / 8)) << "only where the patterns overlap";
}

TEST(Simulator, TheOmniCameraSeesTheOtherRobotsWhereTheyStandAsFarAsItReaches) {
  // The team world as the defender sees it: it drives sideways at y = 0; the keeper stands 6 m
  // behind it, the striker 3 m to its right and 3 m ahead (tests/data/scenes/team/defender.yaml).
  const Scene scene = kinect3d::sim::loadScene(std::string(TEST_DATA_DIR) + "/scenes/team/defender.yaml");
  const std::vector<Eigen::Vector2d> robots_F{{1.5, -6.0}, {3.0, 3.0}};
  kinect3d::sim::OmniCameraModel model;
  model.miss_probability = 0.0;
  model.false_rate_hz = 0.0;
  for (const double reach_m : {9.0, 4.5}) {
    model.max_distance_m = reach_m;
    const kinect3d::sim::OmniCameraSimulator camera(scene, model);
    std::vector<double> errors_sigma;
    for (int i = 0; i < camera.frameCount(); ++i) {
      const fw::OmniFrame frame = camera.frame(i);
      const fw::RobotPose pose = scene.robot.poseAt(camera.captureTime_s(i) - scene.start_time_s);
      std::size_t in_reach = 0;
      for (const Eigen::Vector2d& robot_F : robots_F) {
        in_reach += (robot_F - Eigen::Vector2d(pose.x_m, pose.y_m)).norm() < reach_m - 0.5 ? 1 : 0;
      }
      EXPECT_GE(frame.robots.size(), in_reach) << "image " << i << ", reach " << reach_m;
      EXPECT_LE(frame.robots.size(), reach_m > 7.0 ? 2u : 1u) << "image " << i << ", the keeper beyond reach";
      for (const fw::OmniRobotObservation& robot : frame.robots) {
        const Eigen::Vector2d seen_F = pose.fieldFromRobot(robot.groundPoint_R()).head<2>();
        double nearest_m = 1e9;
        for (const Eigen::Vector2d& robot_F : robots_F) nearest_m = std::min(nearest_m, (seen_F - robot_F).norm());
        errors_sigma.push_back(nearest_m / robot.distance_sigma_m);
      }
    }
    ASSERT_GT(errors_sigma.size(), 50u);
    EXPECT_LT(fw::quantile(errors_sigma, 0.5), 1.5) << "where they stand, with the camera's noise";
    EXPECT_LT(fw::quantile(errors_sigma, 0.99), 4.5);
  }
}

TEST(Simulator, TheWheelsOdometryFollowsTheTrueMotionOffByItsDrawnError) {
  // pass_on_ground's robot drives a metre and turns as it goes.
  const Scene scene = kinect3d::sim::loadScene("pass_on_ground");
  kinect3d::sim::LocalisationModel model;
  model.odometry_error = 0.05;
  const kinect3d::sim::LocalisationSimulator with(scene, model);
  model.odometry = false;
  const kinect3d::sim::LocalisationSimulator without(scene, model);
  ASSERT_GT(with.frameCount(), 30);
  double true_m = 0.0, wheels_m = 0.0, true_rad = 0.0, wheels_rad = 0.0;
  for (int i = 0; i < with.frameCount(); ++i) {
    const fw::RobotPose pose = with.pose(i);
    ASSERT_TRUE(pose.odometry) << "pose " << i;
    EXPECT_FALSE(without.pose(i).odometry);
    // The localisation's own error is the same drawn either way.
    EXPECT_EQ(pose.x_m, without.pose(i).x_m);
    if (i == 0) continue;
    const fw::RobotPose truth0 = scene.robot.poseAt((i - 1) / model.rate_hz),
                        truth1 = scene.robot.poseAt(i / model.rate_hz);
    const fw::RobotPose::Odometry wheels0 = *with.pose(i - 1).odometry;
    true_m += std::hypot(truth1.x_m - truth0.x_m, truth1.y_m - truth0.y_m);
    wheels_m += std::hypot(pose.odometry->x_m - wheels0.x_m, pose.odometry->y_m - wheels0.y_m);
    true_rad += truth1.theta_rad - truth0.theta_rad;
    wheels_rad += pose.odometry->theta_rad - wheels0.theta_rad;
  }
  std::printf("driven %.3f m, the wheels say %.3f m; turned %.3f rad, the wheels say %.3f rad\n", true_m, wheels_m,
              true_rad, wheels_rad);
  ASSERT_GT(true_m, 0.5);
  ASSERT_GT(std::abs(true_rad), 0.1);
  // Off, by no more than four sigma of the drawn scale and the noise.
  EXPECT_NE(wheels_m, true_m);
  EXPECT_NEAR(wheels_m / true_m, 1.0, 4 * model.odometry_error);
  EXPECT_NE(wheels_rad, true_rad);
  EXPECT_NEAR(wheels_rad / true_rad, 1.0, 4 * model.odometry_error);
}

TEST(Simulator, ARobotSwingsItsHeadingAndItsLocalisationStampsLate) {
  // swing_at_rest's robot swings 20 degrees either way every 2.5 s.
  const Scene scene = kinect3d::sim::loadScene("swing_at_rest");
  EXPECT_NEAR(scene.robot.poseAt(0.0).theta_rad, 0.0, 1e-9);
  EXPECT_NEAR(scene.robot.poseAt(0.625).theta_rad, fw::degreesToRadians(20.0), 1e-9);
  EXPECT_NEAR(scene.robot.poseAt(1.875).theta_rad, fw::degreesToRadians(-20.0), 1e-9);
  kinect3d::sim::LocalisationModel model;
  model.stamp_late_s = 0.03;
  const kinect3d::sim::LocalisationSimulator late(scene, model);
  model.stamp_late_s = 0.0;
  const kinect3d::sim::LocalisationSimulator on_time(scene, model);
  ASSERT_GT(late.frameCount(), 30);
  for (const int i : {0, 30}) {
    EXPECT_NEAR(late.pose(i).stamp.source_time_s - on_time.pose(i).stamp.source_time_s, 0.03, 1e-6);  // at 1.7e9 s
    EXPECT_EQ(late.pose(i).theta_rad, on_time.pose(i).theta_rad) << "the same pose, stamped later";
  }
}

}  // namespace
