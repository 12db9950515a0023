// The detector: each stage on its own, then the report's accuracy checks on shorter runs.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <random>

#include "framework_api/config.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/depth_source.h"
#include "kinect3d/kinect_disparity.h"
#include "kinect3d/sim/evaluation.h"
#include "kinect3d/sim/people.h"
#include "kinect3d/sim/sim_sources.h"
#include "real_data.h"
#include "scoped_temp_dir.h"
#include "shipped_config.h"
#include "sim_test_scenes.h"

namespace {

using kinect3d::DepthFrame;
using kinect3d::DetectorConfig;
namespace sim = kinect3d::sim;

using testing_config::shippedConfig;
using testing_config::shippedDetector;

// ---- Configuration ------------------------------------------------------------------------------

// One source of truth for defaults: the shipped defaults file and the structs agree, so code that
// builds a struct directly (tests, tools) runs what a robot runs.
TEST(DetectorConfig, ShippedDefaultsAreTheStructDefaults) {
  const DetectorConfig read = kinect3d::readDetectorConfig(shippedConfig().block("kinect3d"));
  const DetectorConfig code;
  EXPECT_FALSE(read.ground.pose.has_value());
  EXPECT_FALSE(code.ground.pose.has_value());
  EXPECT_DOUBLE_EQ(read.ground.max_tilt_rad, code.ground.max_tilt_rad);
  EXPECT_EQ(read.ground.distance_threshold_m, code.ground.distance_threshold_m);
  EXPECT_EQ(read.ground.max_fit_range_m, code.ground.max_fit_range_m);
  EXPECT_EQ(read.ground.refit_interval_frames, code.ground.refit_interval_frames);
  EXPECT_EQ(read.ground.min_inlier_fraction, code.ground.min_inlier_fraction);
  EXPECT_EQ(read.ground.min_height_m, code.ground.min_height_m);
  EXPECT_EQ(read.ground.max_height_m, code.ground.max_height_m);
  EXPECT_EQ(read.points.pixel_stride, code.points.pixel_stride);
  EXPECT_EQ(read.points.edge_tolerance_steps, code.points.edge_tolerance_steps);
  EXPECT_EQ(read.points.min_range_m, code.points.min_range_m);
  EXPECT_EQ(read.points.max_range_m, code.points.max_range_m);
  EXPECT_EQ(read.points.floor_margin_m, code.points.floor_margin_m);
  EXPECT_EQ(read.points.baseline_m, code.points.baseline_m);
  EXPECT_EQ(read.grid.voxel_m, code.grid.voxel_m);
  EXPECT_EQ(read.grid.occupied_fraction, code.grid.occupied_fraction);
  EXPECT_EQ(read.grid.min_points, code.grid.min_points);
  EXPECT_EQ(read.mask.core_voxels, code.mask.core_voxels);
  EXPECT_EQ(read.mask.mask_voxels, code.mask.mask_voxels);
  EXPECT_EQ(read.map.voxel_m, code.map.voxel_m);
  EXPECT_EQ(read.map.update_interval_frames, code.map.update_interval_frames);
  EXPECT_EQ(read.map.ray_stride_px, code.map.ray_stride_px);
  EXPECT_EQ(read.map.static_after_s, code.map.static_after_s);
  EXPECT_EQ(read.ball.radius_m, code.ball.radius_m);
  EXPECT_EQ(read.ball.min_visible_fraction, code.ball.min_visible_fraction);
  EXPECT_EQ(read.ball.max_size_ratio, code.ball.max_size_ratio);
  EXPECT_EQ(read.ball.air_min_height_m, code.ball.air_min_height_m);
  EXPECT_EQ(read.second_sight_beyond_m, code.second_sight_beyond_m);
}

// ---- Surface filter ----------------------------------------------------------------------------

TEST(PointProjector, KeepsSurfacesDropsFlyingPixelsAndFloor) {
  DepthFrame frame;
  frame.resize(kinect3d::Intrinsics{});
  std::fill(frame.depth_mm.begin(), frame.depth_mm.end(), 4000);  // a wall at 4 m
  const kinect3d::PointProjector projector({}, frame.intrinsics);
  EXPECT_TRUE(projector.isSurface(frame, 100, 100));
  // A pixel halfway between a ball at 3 m and the wall, with the ball on its left.
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 300; ++u) frame.depth_mm[v * 640 + u] = 3000;
  }
  frame.depth_mm[200 * 640 + 300] = 3500;
  EXPECT_FALSE(projector.isSurface(frame, 300, 200)) << "flying pixel between ball and wall";
  EXPECT_FALSE(projector.isSurface(frame, 299, 200)) << "edge of the near surface";
  EXPECT_TRUE(projector.isSurface(frame, 250, 200));
  // Quantisation noise of one step at 4 m (4.6 cm) is still a surface.
  frame.depth_mm[300 * 640 + 500] = 4046;
  EXPECT_TRUE(projector.isSurface(frame, 500, 300));
  frame.depth_mm[300 * 640 + 500] = 0;
  EXPECT_FALSE(projector.isSurface(frame, 501, 300)) << "a neighbour with no data";
  // Beside that hole (a dark panel's, say): which way it lies, for a pixel that is surface but for it.
  ASSERT_TRUE(projector.holeBeside(frame, 501, 300).has_value());
  EXPECT_EQ(*projector.holeBeside(frame, 501, 300), Eigen::Vector2i(-1, 0));
  EXPECT_EQ(*projector.holeBeside(frame, 500, 299), Eigen::Vector2i(0, 1));
  EXPECT_FALSE(projector.holeBeside(frame, 100, 100).has_value()) << "no hole beside it";
  EXPECT_FALSE(projector.holeBeside(frame, 299, 200).has_value()) << "an edge, not a hole";
  frame.depth_mm[301 * 640 + 501] = 0;
  EXPECT_FALSE(projector.holeBeside(frame, 501, 300).has_value()) << "two neighbours with no data";
}

TEST(PointProjector, ProjectsExactlyTheSampledSurfacePixelsAboveTheFloorAtEveryStride) {
  // A noisy wall 3-5 m away with holes, a step and flying pixels, seen by a level sensor 0.6 m up
  // (optical z forward is the robot's y, optical y down its -z): project() against isSurface and
  // the transform, pixel by pixel, at the default stride (the vectorised path) and at others.
  DepthFrame frame;
  frame.resize(kinect3d::Intrinsics{});
  std::mt19937 random(7);
  std::uniform_int_distribution<int> noise_mm(-30, 30), hole(0, 19);
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const int wall_mm = 3000 + 4 * u + (v > 300 ? 800 : 0);
      frame.depth_mm[v * 640 + u] = hole(random) == 0 ? 0 : static_cast<std::uint16_t>(wall_mm + noise_mm(random));
    }
  }
  Eigen::Isometry3f T_R_S = Eigen::Isometry3f::Identity();
  T_R_S.linear() << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  T_R_S.translation() = Eigen::Vector3f(0.0f, 0.0f, 0.6f);
  for (const int stride : {1, 2, 3}) {
    kinect3d::PointProjector::Config config;
    config.pixel_stride = stride;
    const kinect3d::PointProjector projector(config, frame.intrinsics);
    kinect3d::PointSet expected, projected;
    const int first = std::max(stride / 2, 1);
    for (int v = first; v < 479; v += stride) {
      for (int u = first; u < 639; u += stride) {
        if (!projector.isSurface(frame, u, v)) continue;
        const float z_m = frame.at(u, v) * 0.001f;
        const kinect3d::Intrinsics& in = frame.intrinsics;
        const Eigen::Vector3f p_S(z_m * float((u - in.cx) / in.fx), z_m * float((v - in.cy) / in.fy), z_m);
        const Eigen::Vector3f p_R = T_R_S * p_S;
        if (p_R.z() >= config.floor_margin_m) expected.push_back(p_R);
      }
    }
    projector.project(frame, T_R_S, projected);
    ASSERT_EQ(projected.size(), expected.size()) << "stride " << stride;
    EXPECT_GT(expected.size(), 1000u) << "stride " << stride << ": the wall is mostly surface";
    for (std::size_t i = 0; i < expected.size(); ++i) {
      ASSERT_LT((projected[i] - expected[i]).norm(), 1e-4f) << "stride " << stride << ", point " << i;
    }
  }
}

// ---- Occupancy grid --------------------------------------------------------------------------

TEST(OccupancyGrid, CountsFollowEachFrame) {
  kinect3d::OccupancyGrid::Config config;
  config.min_points = 3;
  config.occupied_fraction = 0.0;
  kinect3d::OccupancyGrid grid(config, 575.8, 2, 9.5);
  const Eigen::Vector3f sensor(0.0f, 0.0f, 0.7f);
  kinect3d::PointSet points;
  auto addPoints = [&](Eigen::Vector3f at, int n) {
    for (int i = 0; i < n; ++i) points.push_back(at);
  };
  const Eigen::Vector3f ball(0.1f, 3.0f, 1.0f), wall(0.0f, 7.0f, 1.0f);
  addPoints(ball, 5);
  addPoints(wall, 2);
  grid.update(points, sensor);
  EXPECT_EQ(grid.count(grid.indexOf(ball)), 5);
  EXPECT_EQ(grid.count(grid.indexOf(wall)), 2);
  EXPECT_TRUE(grid.occupied(grid.indexOf(ball)));
  EXPECT_FALSE(grid.occupied(grid.indexOf(wall))) << "below min_points";
  EXPECT_EQ(grid.occupiedVoxels().size(), 1u);

  points.clear();
  addPoints(wall, 9);
  grid.update(points, sensor);
  EXPECT_EQ(grid.count(grid.indexOf(ball)), 0) << "a voxel that emptied is zero";
  EXPECT_EQ(grid.count(grid.indexOf(wall)), 9);
  EXPECT_TRUE(grid.occupied(grid.indexOf(wall)));
  EXPECT_FALSE(grid.occupied(grid.indexOf(ball)));
}

TEST(OccupancyGrid, ThresholdFallsWithRange) {
  kinect3d::OccupancyGrid::Config config;  // occupied_fraction 0.02 of a full face
  kinect3d::OccupancyGrid grid(config, 575.8, 2, 9.5);
  kinect3d::PointSet points;
  // 30 points: plenty at 6 m (a full face holds ~170), far too few at 1.5 m (~2700).
  for (const float y : {1.5f, 6.0f}) {
    for (int i = 0; i < 30; ++i) points.emplace_back(0.0f, y, 0.7f);
  }
  grid.update(points, Eigen::Vector3f(0.0f, 0.0f, 0.7f));
  EXPECT_FALSE(grid.occupied(grid.indexOf({0.0f, 1.5f, 0.7f})));
  EXPECT_TRUE(grid.occupied(grid.indexOf({0.0f, 6.0f, 0.7f})));
  // The sensor moved (new extrinsics): each voxel's threshold follows its new range.
  grid.update(points, Eigen::Vector3f(0.0f, 4.5f, 0.7f));
  EXPECT_TRUE(grid.occupied(grid.indexOf({0.0f, 1.5f, 0.7f}))) << "now 3 m away";
  EXPECT_FALSE(grid.occupied(grid.indexOf({0.0f, 6.0f, 0.7f}))) << "now 1.5 m away";
}

// ---- The mask ---------------------------------------------------------------------------------

class MaskTest : public ::testing::Test {
 protected:
  MaskTest() : grid_(gridConfig(), 575.8, 2, 9.5), finder_({}) {}
  static kinect3d::OccupancyGrid::Config gridConfig() {
    kinect3d::OccupancyGrid::Config config;
    config.occupied_fraction = 0.0;
    config.min_points = 1;
    return config;
  }
  void occupy(std::initializer_list<Eigen::Vector3f> at) {
    kinect3d::PointSet points;
    for (const auto& p : at) points.push_back(p);
    grid_.update(points, Eigen::Vector3f(0.0f, 0.0f, 0.7f));
    finder_.find(grid_, candidates_);
  }
  kinect3d::OccupancyGrid grid_;
  kinect3d::BallCandidateFinder finder_;
  std::vector<kinect3d::BallCandidate> candidates_;
};

TEST_F(MaskTest, IsolatedBlobInTheAirPasses) {
  occupy({{0.1f, 3.0f, 1.0f}, {0.3f, 3.0f, 1.0f}});  // two neighbouring voxels
  ASSERT_EQ(candidates_.size(), 1u);
  EXPECT_EQ(candidates_[0].voxels, 2);
}

TEST_F(MaskTest, OneEmptyVoxelFromAWallIsEnoughTouchingIsNot) {
  // The paper: a flying object must be at least one voxel (0.27 m) from any other structure.
  occupy({{0.1f, 3.0f, 1.0f}, {0.1f, 3.54f, 0.4f}, {0.1f, 3.54f, 0.7f}, {0.1f, 3.54f, 1.0f}, {0.1f, 3.54f, 1.3f}});
  EXPECT_EQ(candidates_.size(), 1u) << "ball two voxels in front of a wall";
  occupy({{0.1f, 3.0f, 1.0f}, {0.1f, 3.27f, 0.4f}, {0.1f, 3.27f, 0.7f}, {0.1f, 3.27f, 1.0f}, {0.1f, 3.27f, 1.3f}});
  EXPECT_TRUE(candidates_.empty()) << "ball against the wall merges with it";
}

TEST_F(MaskTest, AnotherObjectInsideTheWindowFails) {
  // Small objects two voxels to either side: every core placement around the middle one holds
  // one of them in its core or shell.
  occupy({{-0.5f, 3.0f, 1.0f}, {0.1f, 3.0f, 1.0f}, {0.7f, 3.0f, 1.0f}});
  for (const auto& candidate : candidates_) {
    EXPECT_NE(candidate.min[0], grid_.indexOf({0.1f, 3.0f, 1.0f})[0]) << "the middle one must fail";
  }
  EXPECT_EQ(candidates_.size(), 2u) << "the outer two have room on their outer side";
}

TEST_F(MaskTest, BlobLargerThanTheCoreFails) {
  occupy({{0.1f, 3.0f, 1.0f}, {0.4f, 3.0f, 1.0f}, {0.7f, 3.0f, 1.0f}, {1.0f, 3.0f, 1.0f}});  // 4 voxels wide
  EXPECT_TRUE(candidates_.empty());
}

TEST_F(MaskTest, BallOnTheFloorLayerPasses) {
  occupy({{0.1f, 3.0f, 0.15f}});
  ASSERT_EQ(candidates_.size(), 1u);
  EXPECT_EQ(candidates_[0].min[2], 0) << "floor layer";
}

TEST_F(MaskTest, TwoSeparateBallsAreTwoCandidates) {
  occupy({{-2.0f, 3.0f, 1.0f}, {2.0f, 3.0f, 1.0f}});
  EXPECT_EQ(candidates_.size(), 2u);
}

// ---- Whole detector on the simulator ----------------------------------------------------------

TEST(BallDetector, HungBallMeetsThePaperTable1Targets) {
  for (const int d : {2, 4, 6}) {
    SCOPED_TRACE("hung at " + std::to_string(d) + " m");
    sim::Scene scene = sim::loadScene("hung_" + std::to_string(d) + "m");
    scene.duration_s = 1.0;
    auto frames = sim::runDetectorOnScene(scene, shippedDetector(scene));
    // At 4 m and 6 m the ball lies beyond ball.second_sight_beyond_m from the sensor: it is
    // reported from its second frame on.
    EXPECT_EQ(frames.front().balls.size(), d == 2 ? 1u : 0u);
    frames.erase(frames.begin());
    Eigen::Vector3d sum = Eigen::Vector3d::Zero(), square = Eigen::Vector3d::Zero();
    double error_sum = 0.0;
    for (const auto& f : frames) {
      ASSERT_EQ(f.balls.size(), 1u) << "frame " << f.truth.frame_index;
      const Eigen::Vector3d p = f.balls[0].position_m;
      EXPECT_EQ(f.balls[0].state, fw::BallState::kAir);
      EXPECT_EQ(f.balls[0].frame, fw::Frame::kRobot);
      sum += p;
      square += p.cwiseProduct(p);
      error_sum += (p - f.truth.ball_center_R).norm();
    }
    const double n = frames.size();
    const Eigen::Vector3d std_dev = (square / n - (sum / n).cwiseProduct(sum / n)).cwiseMax(0.0).cwiseSqrt();
    EXPECT_LE(error_sum / n, d <= 4 ? 0.03 : 0.06);
    EXPECT_LE(std_dev.maxCoeff(), 0.02);
  }
}

TEST(BallDetector, ABallRestingOnTheFloorIsCentredOneRadiusUp) {
  // The floor band (points.floor_margin_m) keeps the ball's lowest few centimetres out of its
  // points; its centre must not rise by what was cut, whether the whole ball is in view or the
  // image border cuts it (then its outline gives the centre). Sensor height, noise and the ball's
  // place drawn per case, the sensor tilted to within 8 degrees of looking at the ball; every other
  // case the ball lies at the left or right border, its centre 0.4-0.9 radii inside.
  std::mt19937 random(11);
  std::uniform_real_distribution<double> height_m(0.4, 0.9), aim_deg(-8.0, 8.0), noise(0.8, 1.5), range_m(1.8, 6.5),
      bearing_rad(-0.35, 0.35), inside_r(0.4, 0.9);
  double abs_sum_m = 0.0;
  constexpr int kCases = 16;
  for (int c = 0; c < kCases; ++c) {
    sim::Scene scene = sim::loadScene("hung_6m");
    scene.duration_s = 0.5;
    scene.sensor_pose.z_m = height_m(random);
    scene.noise.axial_noise_scale = noise(random);
    scene.noise.seed = 100 + c;
    const double range = range_m(random);
    const double border_rad = std::atan(scene.intrinsics.cx / scene.intrinsics.fx) - inside_r(random) * 0.11 / range;
    const double bearing = c % 2 == 0 ? bearing_rad(random) : (c % 4 == 1 ? border_rad : -border_rad);
    scene.ball->position_m = Eigen::Vector3d(range * std::sin(bearing), range * std::cos(bearing), 0.11);
    scene.sensor_pose.pitch_rad = std::atan2(scene.sensor_pose.z_m - 0.11, range) + aim_deg(random) * M_PI / 180.0;
    SCOPED_TRACE("case " + std::to_string(c) + ": ball at " + std::to_string(range) + " m, bearing " +
                 std::to_string(bearing) + " rad");
    const auto frames = sim::runDetectorOnScene(scene, shippedDetector(scene));
    double dz_sum_m = 0.0;
    int found = 0;
    for (const auto& f : frames) {
      if (f.balls.size() != 1) continue;
      ++found;
      EXPECT_EQ(f.balls[0].state, fw::BallState::kGround);
      dz_sum_m += f.balls[0].position_m.z() - f.truth.ball_center_R.z();
    }
    ASSERT_GE(found, static_cast<int>(frames.size()) - 2);
    // Before the cut was accounted for: up to 1.1 cm high beyond 3 m, 0.6 cm on average over the
    // cases; since, 0.4 cm low to 0.5 cm high, 0.2 cm on average. Nearer, the sphere fit gives it.
    EXPECT_LE(std::abs(dz_sum_m / found), 0.006);
    abs_sum_m += std::abs(dz_sum_m / found);
  }
  EXPECT_LE(abs_sum_m / kCases, 0.0025);
}

TEST(BallDetector, AFarBallIsReportedOnlyWhenALastFrameCouldHaveHeldIt) {
  // Beyond 4 m a hand or a foot looks like a ball for a frame; a free ball is seen more than once.
  // The 6 m ball, shown in a pattern of frames (its place per frame, none when it is absent), to a
  // detector that sees every frame in turn.
  sim::Scene hung = sim::loadScene("hung_6m");
  hung.duration_s = 0.5;
  sim::Scene moved = hung, empty = hung;
  moved.ball->position_m.x() += 2.5;  // 37 m/s away in two frames: no ball moves so fast
  empty.ball.reset();
  auto ballsPerFrame = [&](const std::vector<const sim::Scene*>& pattern) {
    kinect3d::BallDetector detector(shippedDetector(hung), "kinect3d");
    kinect3d::DepthFrame frame;
    sim::GroundTruth truth;
    kinect3d::Detections detections;
    std::vector<std::size_t> balls;
    for (int i = 0; i < 12; ++i) {
      sim::KinectSimulator(*pattern[i % pattern.size()]).render(i, frame, truth);
      detector.detect(frame, detections);
      balls.push_back(detections.balls.size());
    }
    return balls;
  };
  using Counts = std::vector<std::size_t>;
  const Counts from_the_second = {0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1};
  EXPECT_EQ(ballsPerFrame({&hung}), from_the_second);
  EXPECT_EQ(ballsPerFrame({&moved}), from_the_second);
  // One frame missed between two sights is bridged; two are not.
  EXPECT_EQ(ballsPerFrame({&hung, &empty}), (Counts{0, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0}));
  EXPECT_EQ(ballsPerFrame({&hung, &empty, &empty}), Counts(12, 0));
  // A ball in one place, 2.5 m away the next frame, then gone: never the same ball.
  EXPECT_EQ(ballsPerFrame({&hung, &moved, &empty}), Counts(12, 0));
}

TEST(BallDetector, SeesAHungBallAtItsFieldPlaceFromADrivingTurningRobot) {
  sim::Scene scene = sim::loadScene("hung_3m");
  scene.duration_s = 1.0;
  // The robot drives 0.5 m sideways while turning at 11 degrees per second, starting turned so the
  // ball is straight ahead of the sensor at 3 m; it ends 20 degrees to the left.
  scene.robot.theta_rad = 0.3;
  scene.robot.x_m = 3.0 * std::sin(0.3);
  scene.robot.y_m = -3.0 * std::cos(0.3) + 3.0;
  scene.robot.path_m = {{scene.robot.x_m, scene.robot.y_m}, {scene.robot.x_m + 0.5, scene.robot.y_m}};
  scene.robot.speed_mps = 0.5;
  scene.robot.turn_rate_radps = -0.2;
  const auto frames = sim::runDetectorOnScene(scene, shippedDetector(scene));
  ASSERT_EQ(frames.size(), 30u);
  for (const auto& f : frames) {
    ASSERT_EQ(f.balls.size(), 1u) << "frame " << f.truth.frame_index;
    EXPECT_LT((f.balls[0].position_m - f.truth.ball_center_R).norm(), 0.06) << "frame " << f.truth.frame_index;
    const Eigen::Vector3d p_F = f.truth.robot_pose.T_F_R() * f.balls[0].position_m;
    EXPECT_LT((p_F - Eigen::Vector3d(0.0, 3.0, 1.0)).norm(), 0.06) << "frame " << f.truth.frame_index;
  }
  EXPECT_GT((frames.back().truth.ball_center_R - frames.front().truth.ball_center_R).norm(), 0.5)
      << "the ball moved in the robot frame";
}

TEST(BallDetector, FindsKicksAndShotsAndNothingElse) {
  sim::DetectionScore total;
  for (const std::string name : {"kick_away", "ground_kick", "shot_goalkeeper", "lob_goalkeeper"}) {
    const sim::Scene scene = sim::loadScene(name);
    const sim::DetectionScore score =
        sim::scoreFrames(sim::runDetectorOnScene(scene, shippedDetector(scene)), scene, {});
    EXPECT_EQ(score.off_truth, 0) << name << ": every reported ball within 0.3 m of the truth";
    EXPECT_GT(score.eligible, 10) << name;
    total.add(score);
  }
  EXPECT_GE(total.recall(), 0.95) << total.found << " of " << total.eligible;
}

TEST(BallDetector, NoPhantomsInClutter) {
  sim::Scene scene = sim::loadScene("clutter");
  scene.duration_s = 6.0;
  const sim::DetectionScore score = sim::scoreFrames(sim::runDetectorOnScene(scene, shippedDetector(scene)), scene, {});
  EXPECT_EQ(score.frames, 180);
  EXPECT_EQ(score.reported, 0);
}

TEST(BallDetector, NoPhantomsOnRealKinectFrames) {
  const std::optional<std::string> tum_file = realDataFile("real-depth/tum_depth.png"),
                                   nyu_file = realDataFile("real-depth/nyu_raw_disparity.pgm");
  if (!tum_file || !nyu_file) GTEST_SKIP() << noRealData("real-depth");
  DetectorConfig config = kinect3d::readDetectorConfig(shippedConfig().block("kinect3d"));  // floor search
  const ScopedTempDir temp;
  const std::string dir = temp.path().string();
  std::ofstream(dir + "/depth.txt") << "0 " << *tum_file << "\n";
  auto source = kinect3d::sim::sourcesWithSimulator().open("tum:" + dir);
  DepthFrame frame;
  ASSERT_EQ(source->read(frame), kinect3d::ReadResult::kFrame);
  kinect3d::Detections detections;
  kinect3d::BallDetector tum(config, "kinect3d");
  tum.detect(frame, detections);
  EXPECT_TRUE(detections.aligned) << "the office floor is found";
  EXPECT_TRUE(detections.balls.empty());
  kinect3d::BallDetector nyu(config, "kinect3d");
  nyu.detect(kinect3d::loadRawDisparityPgm(*nyu_file), detections);
  EXPECT_TRUE(detections.aligned) << "the room's floor is found";
  EXPECT_TRUE(detections.balls.empty());
}

TEST(BallDetector, NoPhantomsOnThePclGrabberFramesOfAFloorWithALaptopAndABox) {
  std::vector<std::string> images;
  for (const char* stamp : {"20121214T142255.814212", "20121214T142256.068683", "20121214T142256.332395"}) {
    const std::string name = std::string("realdata/pcl_grabber_sequences/frame_") + stamp + "_depth.tiff";
    const std::optional<std::string> image = realDataFile(name);
    if (!image) GTEST_SKIP() << noRealData(name);
    images.push_back(*image);
  }
  const DetectorConfig config = kinect3d::readDetectorConfig(shippedConfig().block("kinect3d"));  // floor search
  const sim::RealFramesResult result = sim::detectOnDepthImages(images, 320, 240, config);
  EXPECT_EQ(result.frames, 6);
  EXPECT_EQ(result.balls, 0);
  EXPECT_TRUE(result.aligned) << "the floor under the laptop and the box is found";
}

TEST(BallDetector, NoPhantomsInARealOfficeWithItsFloorFoundOrItsMountingGiven) {
  const std::optional<std::string> office = realDataFile("realdata/pcl_single_frames/office1_depth_mm.png");
  if (!office) GTEST_SKIP() << noRealData("realdata/pcl_single_frames/office1_depth_mm.png");
  DetectorConfig config = kinect3d::readDetectorConfig(shippedConfig().block("kinect3d"));  // floor search
  const sim::RealFramesResult found = sim::detectOnDepthImages({*office}, 320, 240, config);
  EXPECT_EQ(found.balls, 0);
  EXPECT_TRUE(found.aligned) << "the floor in the bottom fifth of the view is found";
  config.ground.pose = fw::SensorPose{0.0, 0.0, 1.38, 0.0, 0.0, 0.0};  // measured: level, 1.38 m up
  EXPECT_EQ(sim::detectOnDepthImages({*office}, 320, 240, config).balls, 0);
}

TEST(BallDetector, NoPhantomsOnARealFrameOfFivePeopleWalkingDownACorridor) {
  // People close to the sensor and cut by the view's edge, a wall's strip between a person and
  // the sensor's dead band on the right, a wall's edge between two heads: each was a ball.
  const std::string name = "realdata/pcl_single_frames/five_people_depth_mm.png";
  const std::optional<std::string> people = realDataFile(name);
  if (!people) GTEST_SKIP() << noRealData(name);
  const DetectorConfig config = kinect3d::readDetectorConfig(shippedConfig().block("kinect3d"));  // floor search
  const sim::RealFramesResult found = sim::detectOnDepthImages({*people}, 319.5, 239.5, config);
  EXPECT_EQ(found.balls, 0);
  EXPECT_TRUE(found.aligned) << "the corridor's floor is found";
  // And with each shipped robot's fixed mounting, as the goalkeeper would see them.
  for (const auto& entry : std::filesystem::directory_iterator(std::string(PROJECT_CONFIG_DIR) + "/robots")) {
    SCOPED_TRACE(entry.path().string());
    const fw::Config robot = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", entry.path().string(), {});
    const DetectorConfig mounted = kinect3d::readDetectorConfig(robot.block("kinect3d"));
    EXPECT_EQ(sim::detectOnDepthImages({*people}, 319.5, 239.5, mounted).balls, 0);
  }
}

TEST(BallDetector, PeopleRoundTheRobotAreNotBallsAndABallAmongThemIsFound) {
  // Random crowds of articulated people (close, cut by the view's edges, arms raised or held out,
  // a referee's flag, dark clothes, hair): before the outline and curvature checks their hands,
  // forearms and flags gave 100 balls in these 450 frames; before the smooth-surface check, one (a
  // forearm before a body, seed 8). These seeds are among those the rules were set on: crowds never
  // looked at still give a few (docs/accuracy.md, People).
  int phantoms = 0, frames = 0;
  for (int seed = 1; seed <= 10; ++seed) {
    const sim::Scene scene = sim::crowdScene(seed, sim::CrowdBall::kNone);
    const sim::DetectionScore score =
        sim::scoreFrames(sim::runDetectorOnScene(scene, shippedDetector(scene)), scene, {});
    phantoms += score.reported;
    frames += score.frames;
  }
  EXPECT_EQ(frames, 450);
  EXPECT_EQ(phantoms, 0);
  // A ball lobbed 0.3 m over a head: found once it is clear of the people, and nothing else (a foot
  // on the floor curved less than a ball, seed 2, was one before the curvature bar rose to 0.8 r).
  sim::DetectionScore lobs;
  for (int seed = 1; seed <= 5; ++seed) {
    const sim::Scene scene = sim::crowdScene(seed, sim::CrowdBall::kOverAHead);
    lobs.add(sim::scoreFrames(sim::runDetectorOnScene(scene, shippedDetector(scene)), scene, {}));
  }
  // Most of these lobs are beyond 4 m and seen for 3-8 frames: the first, never reported (second
  // sight), costs them 5-25 % of their frames.
  EXPECT_GT(lobs.eligible, 30);
  EXPECT_GE(lobs.recall(), 0.8);
  EXPECT_EQ(lobs.off_truth, 0);
}

TEST(BallDetector, ABallWithDarkPanelsIsFoundAndAnotherKinectMakesNoBall) {
  sim::Scene dark = sim::loadScene("hung_3m");
  dark.duration_s = 0.5;
  dark.ball->dark_panels = true;
  const sim::DetectionScore found = sim::scoreFrames(sim::runDetectorOnScene(dark, shippedDetector(dark)), dark, {});
  EXPECT_GE(found.found, found.frames - 1);
  EXPECT_EQ(found.off_truth, 0);
  sim::Scene facing = sim::loadScene("clutter");
  facing.duration_s = 2.0;
  facing.noise.interference = 1.0;
  EXPECT_EQ(sim::scoreFrames(sim::runDetectorOnScene(facing, shippedDetector(facing)), facing, {}).reported, 0);
}

// A classic ball's black panels notch its outline where they cross the limb and, far away, leave it
// few pixels; another Kinect's specks of false depth fall inside the ball's box beside it. Neither
// makes it less a ball. The detector before the notch and speck rules found 81 % and 88 % of the
// kicks' frames.
TEST(BallDetector, KicksOfABallWithDarkPanelsOrBesideAnotherKinectsSpecksAreFound) {
  const auto darkPanels = [](sim::Scene& scene) { scene.ball->dark_panels = true; };
  auto scoreWith = [](const auto& change, std::initializer_list<const char*> names = {"kick_away", "ground_kick"}) {
    sim::DetectionScore score;
    for (const char* name : names) {
      for (int seed = 1; seed <= 3; ++seed) {
        sim::Scene scene = sim::loadScene(name);
        scene.noise.seed = static_cast<std::uint64_t>(seed);
        change(scene);
        score.add(sim::scoreFrames(sim::runDetectorOnScene(scene, shippedDetector(scene)), scene, {}));
      }
    }
    return score;
  };
  const sim::DetectionScore dark = scoreWith(darkPanels);
  EXPECT_GT(dark.eligible, 200);
  EXPECT_GE(dark.recall(), 0.92);
  EXPECT_EQ(dark.off_truth, 0);
  const sim::DetectionScore facing = scoreWith([](sim::Scene& scene) { scene.noise.interference = 1.0; });
  EXPECT_GT(facing.eligible, 200);
  EXPECT_GE(facing.recall(), 0.93);
  EXPECT_EQ(facing.off_truth, 0);
  // Beyond 5 m the surface test left a ball with dark panels too few pixels for its size: it drops
  // those round each panel's hole. Counting them too, the lob to the goalkeeper is found in 45 of
  // its 48 counted frames; without, in 38.
  const sim::DetectionScore far = scoreWith(darkPanels, {"lob_goalkeeper"});
  EXPECT_GT(far.eligible, 40);
  EXPECT_GE(far.recall(), 0.9);
  EXPECT_EQ(far.off_truth, 0);
}

// A speck that another Kinect throws into a ball's box is left out (the test above); a piece of a
// person's arm or body that only grazes a hand's box is not a speck, and keeps the hand wider than a
// ball. Taking such pieces for specks made a ball of a hand or a head in each of these crowds.
TEST(BallDetector, APieceOfABodyBesideAHandIsNotTakenForASpeck) {
  int phantoms = 0;
  for (const auto& [seed, ball] : {std::pair{108, sim::CrowdBall::kNone}, {26, sim::CrowdBall::kThrownFromHands}}) {
    const sim::Scene scene = sim::crowdScene(seed, ball);
    phantoms += sim::scoreFrames(sim::runDetectorOnScene(scene, shippedDetector(scene)), scene, {}).off_truth;
  }
  EXPECT_EQ(phantoms, 0);
}

// The notched outline of a ball with black panels: a foot whose long sides, with no depth beyond
// them, were taken for notches fitted the rest of the circle well, but is twice as long as wide.
TEST(BallDetector, AFootWhoseSidesLookLikePanelNotchesIsNotABall) {
  const sim::Scene scene = sim::crowdScene(1008, sim::CrowdBall::kNone);
  EXPECT_EQ(sim::scoreFrames(sim::runDetectorOnScene(scene, shippedDetector(scene)), scene, {}).reported, 0);
}

TEST(BallDetector, CovarianceGrowsWithRangeAlongTheRay) {
  auto covarianceAt = [](int d) {
    sim::Scene scene = sim::loadScene("hung_" + std::to_string(d) + "m");
    scene.duration_s = 0.1;
    const auto frames = sim::runDetectorOnScene(scene, shippedDetector(scene));
    return frames.at(1).balls.at(0).covariance_m2;  // at 6 m the ball is reported from its second frame
  };
  const Eigen::Matrix3d near = covarianceAt(2), far = covarianceAt(6);
  // Straight ahead the ray is the robot's y axis.
  EXPECT_GT(far(1, 1), 4.0 * near(1, 1));
  EXPECT_GT(near(1, 1), near(0, 0)) << "depth is the least certain direction";
}

TEST(DetectorConfig, ShippedRobotFilesConfigureTheDetector) {
  for (const auto& entry : std::filesystem::directory_iterator(std::string(PROJECT_CONFIG_DIR) + "/robots")) {
    SCOPED_TRACE(entry.path().string());
    const fw::Config config =
        fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", entry.path().string(), {});
    const DetectorConfig detector = kinect3d::readDetectorConfig(config.block("kinect3d"));
    EXPECT_TRUE(detector.ground.pose.has_value());
  }
}

TEST(DetectorConfig, BadValuesNameTheKey) {
  auto errorOf = [](const std::string& assignment) {
    try {
      kinect3d::readDetectorConfig(shippedConfig({assignment}).block("kinect3d"));
    } catch (const fw::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(errorOf("kinect3d.grid.voxel_m=-1").find("kinect3d.grid.voxel_m = -1 is out of range"), std::string::npos);
  EXPECT_NE(errorOf("kinect3d.grid.mask_voxels=6").find("the mask must exceed the core by a positive even number"),
            std::string::npos);
  // A wrong core is blamed where the user wrote it, not on the defaults file's mask.
  const std::string core = errorOf("kinect3d.grid.core_voxels=5");
  EXPECT_NE(core.find("kinect3d.grid.core_voxels = 5 (--set kinect3d.grid.core_voxels=5)"), std::string::npos) << core;
  const std::string range = errorOf("kinect3d.points.max_range_m=0.5");
  EXPECT_NE(range.find("--set kinect3d.points.max_range_m=0.5: kinect3d.points.max_range_m = 0.500000 must exceed "
                       "kinect3d.points.min_range_m = 0.500000"),
            std::string::npos)
      << range;
  EXPECT_NE(errorOf("kinect3d.sensor.pose_in_robot={x: 0, y: 0, z: 0.7, yaw: 0}")
                .find("kinect3d.sensor.pose_in_robot.yaw is an unknown key"),
            std::string::npos);
  EXPECT_NE(errorOf("kinect3d.sensor.pose_in_robot={x: 0, y: 0, z: 0.7}")
                .find("kinect3d.sensor.pose_in_robot.yaw_deg is missing"),
            std::string::npos);
}

}  // namespace
