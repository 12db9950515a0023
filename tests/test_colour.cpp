// The colour check (#27): the simulator's colour, the learnt ball colours, the verdicts on simulated
// scenes and real frames, and what the rest of the product does with a verdict.
#include <gtest/gtest.h>

#include <array>
#include <fstream>

#include <opencv2/imgproc.hpp>

#include "framework_api/config.h"
#include "fusion/ball_fusion.h"
#include "fusion/fusion_config.h"
#include "kinect3d/camera_file.h"
#include "kinect3d/colour_check.h"
#include "kinect3d/config_io.h"
#include "kinect3d/sim/evaluation.h"
#include "kinect3d/sim/people.h"
#include "kinect3d/trajectory.h"
#include "real_data.h"
#include "run_command.h"
#include "scoped_temp_dir.h"

namespace {

using kinect3d::ColourCheckConfig;

fw::Config shipped() { return fw::Config::load(PROJECT_CONFIG_DIR "/defaults", "", {}); }

kinect3d::sim::CalibrationSession sessionWith(const std::string& ball) {
  kinect3d::sim::CalibrationSession session;
  session.pose = fw::SensorPose{0.0, 0.0, 0.7, 0.0, fw::degreesToRadians(-6.0), 0.0};
  session.marks_xy_m = {{0.0, 2.0}, {-0.6, 2.8}, {0.6, 3.0}};
  session.seconds_per_mark = 0.5;
  session.colour = kinect3d::sim::ColourLook::withBall(ball);
  return session;
}

kinect3d::BallColourModel learnt(const std::string& ball) {
  return kinect3d::sim::learnBallColourInSession(sessionWith(ball),
                                                 kinect3d::readDetectorConfig(shipped().block("kinect3d")))
      .model;
}

TEST(SimulatedColour, TheBallShowsInItsColoursWhereTheDepthPutsItAndAFrameRendersTheSameTwice) {
  kinect3d::sim::Scene scene = kinect3d::sim::loadScene("hung_3m");
  scene.look = kinect3d::sim::ColourLook::withBall("yellow");
  kinect3d::sim::KinectSimulator simulator(scene);
  simulator.setColour(true);
  kinect3d::DepthFrame frame, again;
  kinect3d::sim::GroundTruth truth;
  simulator.render(3, frame, truth);
  simulator.render(3, again, truth);
  ASSERT_TRUE(frame.colour && again.colour);
  EXPECT_EQ(frame.colour->rgb, again.colour->rgb);
  // The ball's centre, through the colour camera's own offset: yellow (red and green high, blue low).
  const Eigen::Vector3d centre_S = scene.sensor_pose.T_R_S().inverse() * truth.ball_center_R;
  const std::optional<kinect3d::BallDisc> disc = kinect3d::discOf(*frame.colour, centre_S, scene.physics.radius_m);
  ASSERT_TRUE(disc);
  const std::size_t at = 3 * (static_cast<std::size_t>(std::lround(disc->centre_px.y())) * frame.colour->width +
                              static_cast<std::size_t>(std::lround(disc->centre_px.x())));
  const std::uint8_t r = frame.colour->rgb[at], g = frame.colour->rgb[at + 1], b = frame.colour->rgb[at + 2];
  EXPECT_GT(r, 150);
  EXPECT_GT(g, 120);
  EXPECT_LT(b, 90);
  // Beside the disc (two radii to the right) is the wall, not the ball.
  const std::size_t beside = at + 3 * static_cast<std::size_t>(std::lround(2.0 * disc->radius_px));
  EXPECT_GT(std::abs(frame.colour->rgb[beside + 2] - b), 30);
}

TEST(BallColour, EachMatchBallIsLearntAndToldFromTheRestOfItsSession) {
  const kinect3d::DetectorConfig detector = kinect3d::readDetectorConfig(shipped().block("kinect3d"));
  for (const std::string& ball : kinect3d::sim::ColourLook::ballNames()) {
    SCOPED_TRACE(ball);
    const kinect3d::BallColourFit fit = kinect3d::sim::learnBallColourInSession(sessionWith(ball), detector);
    EXPECT_GE(fit.frames, 30);
    EXPECT_GT(fit.ball_explained, 0.9);
    EXPECT_GE(fit.ball_score_p10, 0.5);   // the ball's own discs would be confirmed
    EXPECT_LT(fit.other_score_p99, 0.2);  // discs elsewhere would be rejected
    if (ball == "white_black") {
      ASSERT_EQ(fit.model.size(), 2u);  // white and black: two colours, told apart by lightness
      EXPECT_GT(fit.model[0].lab.x(), 60.0);
      EXPECT_LT(fit.model[1].lab.x(), 30.0);
    } else {
      ASSERT_EQ(fit.model.size(), 1u);        // one colour, in light and shade
      EXPECT_GT(fit.model[0].lab.z(), 40.0);  // yellow and orange: strongly b* (yellow-blue axis)
    }
  }
}

TEST(ColourCheck, RejectsThePhantomsOfPeopleLampsAndLoudspeakersAndKeepsTheBall) {
  const fw::Config config = shipped();
  const kinect3d::BallColourModel model = learnt("orange");
  kinect3d::sim::DetectionScore off, on;
  int confirmed_balls = 0;
  std::vector<kinect3d::sim::Scene> scenes = {kinect3d::sim::loadScene("colour_confusers"),
                                              kinect3d::sim::loadScene("lamp_in_view")};
  for (int seed = 1; seed <= 3; ++seed) {
    scenes.push_back(kinect3d::sim::crowdScene(seed, kinect3d::sim::CrowdBall::kOverAHead));
    scenes.push_back(kinect3d::sim::crowdScene(seed, kinect3d::sim::CrowdBall::kThrownFromHands));
  }
  for (const kinect3d::sim::Scene& scene : scenes) {
    kinect3d::DetectorConfig detector = kinect3d::readDetectorConfig(config.block("kinect3d"));
    detector.ground.pose = scene.sensor_pose;
    detector.colour.mode = ColourCheckConfig::Mode::kOn;
    detector.colour.ball_colours = model;
    const auto frames = kinect3d::sim::runDetectorOnScene(scene, detector);
    off.add(kinect3d::sim::scoreFrames(frames, scene, {}));
    on.add(kinect3d::sim::scoreFrames(kinect3d::sim::followedOnly(frames), scene, {}));
    for (const auto& f : frames) {
      for (const fw::BallObservation& b : f.balls) {
        EXPECT_NE(b.colour, fw::ColourVerdict::kNotChecked);
        confirmed_balls += b.colour == fw::ColourVerdict::kConfirmed;
      }
    }
  }
  EXPECT_GT(off.off_truth, 100);  // the depth alone reports the lamps and the loudspeaker
  // Each of them with its distance from the sensor, within what a Kinect sees (the report's ranges).
  ASSERT_EQ(off.off_truth_ranges_m.size(), static_cast<std::size_t>(off.off_truth));
  for (const double range_m : off.off_truth_ranges_m) EXPECT_TRUE(range_m > 0.5 && range_m < 10.0) << range_m;
  EXPECT_EQ(on.off_truth, 0);
  EXPECT_GT(confirmed_balls, 100);
  EXPECT_GE(on.recall(), off.recall() - 0.01);
}

TEST(ColourCheck, AFarBallTheColourConfirmsIsReportedFromItsFirstFrame) {
  // Beyond 4 m the depth alone reports a ball from its second frame; the colour image can tell it
  // from a hand in the first.
  kinect3d::sim::Scene scene = kinect3d::sim::loadScene("hung_6m");
  scene.duration_s = 0.1;
  kinect3d::DetectorConfig detector = kinect3d::readDetectorConfig(shipped().block("kinect3d"));
  detector.ground.pose = scene.sensor_pose;
  const auto depth_only = kinect3d::sim::runDetectorOnScene(scene, detector);
  ASSERT_EQ(depth_only.size(), 3u);
  EXPECT_TRUE(depth_only[0].balls.empty());
  detector.colour.mode = ColourCheckConfig::Mode::kOn;
  detector.colour.ball_colours = learnt("orange");
  const auto with_colour = kinect3d::sim::runDetectorOnScene(scene, detector);
  ASSERT_EQ(with_colour.size(), 3u);
  ASSERT_EQ(with_colour[0].balls.size(), 1u);
  EXPECT_EQ(with_colour[0].balls[0].colour, fw::ColourVerdict::kConfirmed);
  EXPECT_LT((with_colour[0].balls[0].position_m - with_colour[0].truth.ball_center_R).norm(), 0.06);
}

TEST(ColourCheck, AWhiteBallWithBlackPanelsSmearedInFlightIsNeverRejected) {
  const fw::Config config = shipped();
  const kinect3d::sim::ColourLook look = kinect3d::sim::ColourLook::withBall("white_black");
  int balls = 0, rejected = 0, blurred = 0;
  // Learnt in whole sessions (four marks, a second each), each with its own camera noise: the
  // narrower the white learnt, the more a smeared disc's greys fall outside it in the session's light.
  for (const std::uint64_t noise_seed : {3u, 5u}) {
    kinect3d::sim::CalibrationSession session = sessionWith("white_black");
    session.marks_xy_m = kinect3d::sim::CalibrationSession().marks_xy_m;
    session.seconds_per_mark = 1.0;
    session.noise_seed = noise_seed;
    const kinect3d::BallColourModel model =
        kinect3d::sim::learnBallColourInSession(session, kinect3d::readDetectorConfig(config.block("kinect3d"))).model;
    for (const char* name : {"lob_goalkeeper", "shot_goalkeeper_low"}) {
      kinect3d::sim::Scene scene = kinect3d::sim::loadScene(name);
      scene.look.ball_albedo = look.ball_albedo;
      scene.look.panel_albedo = look.panel_albedo;
      kinect3d::DetectorConfig detector = kinect3d::readDetectorConfig(config.block("kinect3d"));
      detector.ground.pose = scene.sensor_pose;
      detector.colour.mode = ColourCheckConfig::Mode::kOn;
      detector.colour.ball_colours = model;
      for (const auto& frame : kinect3d::sim::runDetectorOnScene(scene, detector)) {
        for (const fw::BallObservation& b : frame.balls) {
          ++balls;
          rejected += b.colour == fw::ColourVerdict::kRejected;
          blurred += b.colour_note == fw::ColourNote::kBlurred;
        }
      }
    }
  }
  EXPECT_GT(balls, 60);
  EXPECT_GT(blurred, 20) << "fast shots at the goalkeeper: the panels go grey";
  EXPECT_EQ(rejected, 0);
}

TEST(ColourCheck, SaysWhyThereIsNoEvidenceAndRequiredRejectsWhatItCannotConfirm) {
  ColourCheckConfig config;
  config.mode = ColourCheckConfig::Mode::kOn;
  config.ball_colours = {{{60.0, 20.0, 50.0}, {5.0, 3.0, 3.0}, 1.0}};
  const kinect3d::ColourCheck check(config);
  const Eigen::Vector3d ahead(0.0, 0.0, 3.0);
  EXPECT_EQ(check.check(kinect3d::DepthFrame{}, ahead, 0.11).note, fw::ColourNote::kNoImage);
  kinect3d::DepthFrame dark;
  dark.colour = kinect3d::ColourCamera::kinectV1().image(std::vector<std::uint8_t>(640 * 480 * 3, 2), 0.0);
  const kinect3d::ColourEvidence in_the_dark = check.check(dark, ahead, 0.11);
  EXPECT_EQ(in_the_dark.verdict, fw::ColourVerdict::kNoEvidence);
  EXPECT_EQ(in_the_dark.note, fw::ColourNote::kTooDark);
  EXPECT_EQ(check.check(dark, Eigen::Vector3d(0.0, 0.0, -1.0), 0.11).note, fw::ColourNote::kOutsideImage);
  EXPECT_EQ(check.check(dark, Eigen::Vector3d(3.0, 0.0, 1.0), 0.11).note, fw::ColourNote::kOutsideImage);
  EXPECT_EQ(check.check(dark, Eigen::Vector3d(0.0, 0.0, 40.0), 0.11).note, fw::ColourNote::kTooSmall);

  config.mode = ColourCheckConfig::Mode::kRequired;
  const kinect3d::ColourEvidence required = kinect3d::ColourCheck(config).check(dark, ahead, 0.11);
  EXPECT_EQ(required.verdict, fw::ColourVerdict::kRejected);
  EXPECT_EQ(required.note, fw::ColourNote::kTooDark);

  config.mode = ColourCheckConfig::Mode::kOff;
  EXPECT_EQ(kinect3d::ColourCheck(config).check(dark, ahead, 0.11).verdict, fw::ColourVerdict::kNotChecked);
}

TEST(ColourCheck, AColourInShadeOrInMoreLightIsStillThatColour) {
  const kinect3d::BallColourModel orange = {{{64.0, 24.0, 57.0}, {6.0, 2.5, 2.5}, 1.0}};
  // A matt surface in k times the light: linear RGB times k, so (L* + 16, a*, b*) times k^(1/3).
  const auto lit = [](const Eigen::Vector3d& lab, double k) {
    const double s = std::cbrt(k);
    return Eigen::Vector3f(static_cast<float>((lab.x() + 16.0) * s - 16.0), static_cast<float>(lab.y() * s),
                           static_cast<float>(lab.z() * s));
  };
  // A disc of the ball in k times the session's light, its shaded side darker still.
  const auto disc = [&](double k) {
    std::vector<Eigen::Vector3f> pixels;
    for (const double shade : {0.7, 0.85, 1.0, 1.0, 1.0, 1.1}) pixels.push_back(lit(orange[0].lab, k * shade));
    return pixels;
  };
  for (const double k : {0.3, 0.5, 1.0, 1.5, 1.9}) {
    EXPECT_GT(kinect3d::colourMatch(orange, disc(k)).score, 0.99) << "in " << k << " times the light";
  }
  EXPECT_EQ(kinect3d::colourMatch(orange, disc(0.05)).score, 0.0) << "far darker: brown";
  EXPECT_EQ(kinect3d::colourMatch(orange, disc(1.0), 0.63).score, 0.0) << "judged at a quarter of the light";
  EXPECT_EQ(kinect3d::explainingColour(orange, Eigen::Vector3f(65.0f, 15.0f, 20.0f), 1.0), -1) << "skin";
  EXPECT_EQ(kinect3d::explainingColour(orange, Eigen::Vector3f(60.0f, 45.0f, 45.0f), 1.0), -1) << "red";

  // A white ball with black panels in one light: a grey between them is neither.
  const kinect3d::BallColourModel white_black = {{{80.0, 0.0, 0.0}, {6.0, 2.5, 2.5}, 0.7},
                                                 {{15.0, 0.0, 0.0}, {4.0, 2.5, 2.5}, 0.3}};
  EXPECT_EQ(kinect3d::explainingColour(white_black, Eigen::Vector3f(80.0f, 0.0f, 0.0f), 1.0), 0);
  EXPECT_EQ(kinect3d::explainingColour(white_black, Eigen::Vector3f(15.0f, 0.0f, 0.0f), 1.0), 1);
  EXPECT_EQ(kinect3d::explainingColour(white_black, Eigen::Vector3f(45.0f, 0.0f, 0.0f), 1.0), -1);

  // Far away its panels are a few pixels wide and blend with the white: a grey a quarter white and
  // three quarters black (in linear light: L* 47) shows the black that no pixel shows alone.
  std::vector<Eigen::Vector3f> far(7, Eigen::Vector3f(80.0f, 0.0f, 0.0f));
  far.insert(far.end(), 3, Eigen::Vector3f(46.9f, 0.0f, 0.0f));
  const kinect3d::ColourMatch far_match = kinect3d::colourMatch(white_black, far, 1.0, /*panels_blend=*/true);
  EXPECT_NEAR(far_match.explained, 0.7, 1e-9) << "the greys are neither colour";
  EXPECT_GT(far_match.score, 0.5) << "but show both";
  EXPECT_EQ(kinect3d::colourMatch(white_black, far, 1.0).score, 0.0) << "near, panels show whole: no black";
  const std::vector<Eigen::Vector3f> shirt(10, Eigen::Vector3f(80.0f, 0.0f, 0.0f));
  EXPECT_EQ(kinect3d::colourMatch(white_black, shirt, 1.0, true).score, 0.0) << "a white shirt shows no black";
  const std::vector<Eigen::Vector3f> grey(10, Eigen::Vector3f(46.9f, 0.0f, 0.0f));
  EXPECT_EQ(kinect3d::colourMatch(white_black, grey, 1.0, true).score, 0.0) << "a grey shirt is neither colour";
}

// A white ball with black panels 3 m ahead on the green field, its colour image smeared sideways by
// smear_px (a fast ball in a long exposure), or a disc of one grey.
kinect3d::DepthFrame whiteBallWithPanels(int smear_px, bool grey_disc) {
  kinect3d::DepthFrame frame;
  frame.colour = kinect3d::ColourCamera::kinectV1().image(std::vector<std::uint8_t>(640 * 480 * 3), 0.0);
  fw::ColourImage& colour = *frame.colour;
  const kinect3d::BallDisc disc = *kinect3d::discOf(colour, Eigen::Vector3d(0.0, 0.0, 3.0), 0.11);
  cv::Mat image(480, 640, CV_8UC3, colour.rgb.data());
  image.setTo(cv::Scalar(40, 140, 50));
  const cv::Point centre(static_cast<int>(disc.centre_px.x()), static_cast<int>(disc.centre_px.y()));
  const int r = static_cast<int>(disc.radius_px);
  if (grey_disc) {
    cv::circle(image, centre, r, cv::Scalar(110, 110, 110), cv::FILLED);
  } else {
    cv::circle(image, centre, r, cv::Scalar(205, 205, 205), cv::FILLED);
    // Panels on every row: smeared sideways, no part of the ball stays white.
    for (const cv::Point panel : {cv::Point(-r / 3, -2 * r / 3), cv::Point(r / 3, -r / 3), cv::Point(-r / 3, 0),
                                  cv::Point(r / 3, r / 3), cv::Point(-r / 3, 2 * r / 3)}) {
      cv::circle(image, centre + panel, r / 4, cv::Scalar(25, 25, 25), cv::FILLED);
    }
  }
  if (smear_px > 1) cv::blur(image, image, cv::Size(smear_px, 1));
  return frame;
}

TEST(ColourCheck, ASmearedBallIsKeptAsBlurredAndAStillGreyDiscIsRejected) {
  ColourCheckConfig config;
  config.mode = ColourCheckConfig::Mode::kOn;
  config.ball_colours = {{{82.0, 0.0, 0.0}, {6.0, 2.5, 2.5}, 0.7}, {{10.0, 0.0, 0.0}, {4.0, 2.5, 2.5}, 0.3}};
  const kinect3d::ColourCheck check(config);
  const Eigen::Vector3d ball_S(0.0, 0.0, 3.0);
  EXPECT_EQ(check.check(whiteBallWithPanels(1, false), ball_S, 0.11).verdict, fw::ColourVerdict::kConfirmed);
  // Smeared over most of its width: white and black mix into greys.
  const kinect3d::ColourEvidence smeared = check.check(whiteBallWithPanels(25, false), ball_S, 0.11);
  EXPECT_EQ(smeared.verdict, fw::ColourVerdict::kNoEvidence);
  EXPECT_EQ(smeared.note, fw::ColourNote::kBlurred);
  // A still grey thing with a sharp outline is no ball with panels.
  EXPECT_EQ(check.check(whiteBallWithPanels(1, true), ball_S, 0.11).verdict, fw::ColourVerdict::kRejected);
}

// A ball 3 m ahead, drawn orange where the colour camera sees it, on a grey-blue wall 5 m away; a
// green board 2 m away hides the disc's left side up to `hidden_to` (a share of its width).
kinect3d::DepthFrame ballBehindABoard(double hidden_to, bool with_depth) {
  const Eigen::Vector3d ball_S(0.0, 0.0, 3.0);
  kinect3d::DepthFrame frame;
  frame.resize(kinect3d::Intrinsics{640, 480, 525.0, 525.0, 319.5, 239.5});
  frame.colour = kinect3d::ColourCamera::kinectV1().image(std::vector<std::uint8_t>(640 * 480 * 3), 0.0);
  fw::ColourImage& colour = *frame.colour;
  const kinect3d::BallDisc disc = *kinect3d::discOf(colour, ball_S, 0.11);
  const double board_end_px = disc.centre_px.x() - disc.radius_px + hidden_to * 2.0 * disc.radius_px;
  // What the colour camera sees at column u the depth camera sees at u + this, at the thing's distance.
  const auto parallax_px = [&](double z_m) { return 525.0 * colour.offset_S_m.x() / z_m; };
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      std::uint8_t* rgb = &colour.rgb[3 * (static_cast<std::size_t>(v) * 640 + u)];
      const bool board = u < board_end_px, ball = (Eigen::Vector2d(u, v) - disc.centre_px).norm() <= disc.radius_px;
      const std::array<std::uint8_t, 3> paint = board  ? std::array<std::uint8_t, 3>{40, 140, 50}
                                                : ball ? std::array<std::uint8_t, 3>{230, 110, 20}
                                                       : std::array<std::uint8_t, 3>{100, 100, 140};
      std::copy(paint.begin(), paint.end(), rgb);
      const bool depth_board = u < board_end_px + parallax_px(2.0);
      const bool depth_ball = (Eigen::Vector2d(u - parallax_px(3.0), v) - disc.centre_px).norm() <= disc.radius_px;
      if (with_depth)
        frame.depth_mm[static_cast<std::size_t>(v) * 640 + u] = depth_board ? 2000 : depth_ball ? 2900 : 5000;
    }
  }
  return frame;
}

TEST(ColourCheck, AnOccludedBallIsJudgedOnWhatOfItShows) {
  ColourCheckConfig config;
  config.mode = ColourCheckConfig::Mode::kOn;
  config.ball_colours = {{{59.9, 42.2, 64.1}, {4.0, 3.0, 3.0}, 1.0}};  // the L*a*b* of the orange drawn
  const kinect3d::ColourCheck check(config);
  const Eigen::Vector3d ball_S(0.0, 0.0, 3.0);
  const kinect3d::ColourEvidence whole = check.check(ballBehindABoard(0.0, true), ball_S, 0.11);
  EXPECT_EQ(whole.verdict, fw::ColourVerdict::kConfirmed);
  EXPECT_GT(whole.score, 0.9);

  // More than half behind the board: the colour image alone sees a disc mostly green; the depth says
  // the green is nearer than the ball, and what shows of the ball is orange with its outline.
  const kinect3d::ColourEvidence colour_alone = check.check(ballBehindABoard(0.55, false), ball_S, 0.11);
  EXPECT_NE(colour_alone.verdict, fw::ColourVerdict::kConfirmed);
  EXPECT_LT(colour_alone.score, 0.5);
  const kinect3d::ColourEvidence with_depth = check.check(ballBehindABoard(0.55, true), ball_S, 0.11);
  EXPECT_EQ(with_depth.verdict, fw::ColourVerdict::kConfirmed);
  EXPECT_GT(with_depth.score, 0.9);
  EXPECT_GT(with_depth.outline, 0.8) << "the board's edge is not counted against the outline";

  const kinect3d::ColourEvidence nearly_all = check.check(ballBehindABoard(0.9, true), ball_S, 0.11);
  EXPECT_EQ(nearly_all.verdict, fw::ColourVerdict::kNoEvidence);
  EXPECT_EQ(nearly_all.note, fw::ColourNote::kHidden);
}

TEST(ColourCheck, ConfirmsNothingAnywhereInTheRealColourFrames) {
  const std::string people = "realdata/pcl_single_frames/five_people_depth_mm.png";
  if (!realDataFile(people)) GTEST_SKIP() << noRealData(people);
  const std::string dir = *realDataFile("realdata");
  int places = 0;
  for (const std::string& ball : kinect3d::sim::ColourLook::ballNames()) {
    const kinect3d::BallColourModel model = learnt(ball);
    for (const auto& [depth, colour, cx] :
         {std::tuple{"pcl_single_frames/five_people_depth_mm.png", "pcl_single_frames/five_people_rgb.png", 319.5},
          std::tuple{"pcl_single_frames/office1_depth_mm.png", "pcl_single_frames/office1_rgb.png", 320.0},
          std::tuple{"pcl_grabber_sequences/frame_20121214T142255.814212_depth.tiff",
                     "pcl_grabber_sequences/frame_20121214T142255.814212_rgb.tiff", 320.0},
          std::tuple{"pcl_grabber_sequences/frame_20121214T142256.068683_depth.tiff",
                     "pcl_grabber_sequences/frame_20121214T142256.068683_rgb.tiff", 320.0},
          std::tuple{"pcl_grabber_sequences/frame_20121214T142256.332395_depth.tiff",
                     "pcl_grabber_sequences/frame_20121214T142256.332395_rgb.tiff", 320.0}}) {
      SCOPED_TRACE(ball + " ball on " + depth);
      const kinect3d::sim::RealColourCheck r =
          kinect3d::sim::checkEverywhere(dir + "/" + depth, dir + "/" + colour, cx, cx == 319.5 ? 239.5 : 240.0, model);
      EXPECT_GT(r.places, 500);
      EXPECT_EQ(r.confirmed, 0);
      places += r.places;
    }
  }
  EXPECT_GT(places, 8000);
}

TEST(ColourCheck, TheDemoRobotsLearntBallIsConfirmedInItsOwnScene) {
  const fw::Config config = fw::Config::load(PROJECT_CONFIG_DIR "/defaults", PROJECT_CONFIG_DIR "/robots/demo.yaml",
                                             {"kinect3d.colour=true", "kinect3d.colour_check.mode=on"});
  const kinect3d::DetectorConfig detector = kinect3d::readDetectorConfig(config.block("kinect3d"));
  ASSERT_FALSE(detector.colour.ball_colours.empty()) << "demo.yaml holds the colours learnt from a simulated session";
  const kinect3d::sim::Scene scene = kinect3d::sim::loadScene("lob_over_robot");
  int confirmed = 0, rejected = 0, balls = 0;
  for (const auto& frame : kinect3d::sim::runDetectorOnScene(scene, detector)) {
    for (const fw::BallObservation& b : frame.balls) {
      ASSERT_TRUE(frame.truth.has_ball);
      EXPECT_LT((b.position_m - frame.truth.ball_center_R).norm(), 0.3) << "no phantom in this scene";
      ++balls;
      confirmed += b.colour == fw::ColourVerdict::kConfirmed;
      rejected += b.colour == fw::ColourVerdict::kRejected;
    }
  }
  EXPECT_GT(balls, 20);
  EXPECT_GT(confirmed, balls / 2) << "the ball lit as in the session, flying and rolling";
  EXPECT_EQ(rejected, 0);
}

TEST(ColourCheck, TrajectoriesAndFusionDoNotFollowARejectedBall) {
  const fw::Config config = shipped();
  // A flight the trajectory would report, every detection rejected by colour.
  auto estimator = kinect3d::makeTrajectoryEstimator(kinect3d::readTrajectoryConfig(config.block("kinect3d")));
  std::optional<fw::BallTrajectory> fitted;
  for (int i = 0; i < 20; ++i) {
    const double t = i / 30.0;
    fw::BallObservation ball =
        fw::BallObservation::inRobotFrame({0.5, 4.0 - 5.0 * t, 1.0 + 4.0 * t - 4.905 * t * t},
                                          Eigen::Matrix3d::Identity() * 1e-4, fw::BallState::kAir, "kinect3d", {t, t});
    ball.colour = fw::ColourVerdict::kRejected;
    fitted = estimator->update(t, {ball});
  }
  EXPECT_FALSE(fitted);

  // The same flight: the world's ball while its colour is not judged, never once it is rejected.
  std::map<fw::ColourVerdict, int> world_balls;
  for (const fw::ColourVerdict verdict : {fw::ColourVerdict::kNotChecked, fw::ColourVerdict::kRejected}) {
    fusion::BallFusion fusion(fusion::readFusionConfig(config.block("fusion")));
    for (int i = 0; i < 20; ++i) {
      const double t = i / 30.0;
      fw::BallObservation ball = fw::BallObservation::inRobotFrame({0.5, 4.0 - 5.0 * t, 1.0 + 4.0 * t - 4.905 * t * t},
                                                                   Eigen::Matrix3d::Identity() * 1e-4,
                                                                   fw::BallState::kAir, "kinect3d", {t, t});
      ball.colour = verdict;
      world_balls[verdict] += fusion.addKinectFrame(t, {ball}).ball ? 1 : 0;
    }
  }
  EXPECT_GT(world_balls[fw::ColourVerdict::kNotChecked], 10);
  EXPECT_EQ(world_balls[fw::ColourVerdict::kRejected], 0);
}

TEST(ColourCheck, AnOnCheckWithoutLearntColoursOrColourIsAConfigErrorNamingTheKey) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"kinect3d.colour=true", "kinect3d.colour_check.mode=on"}, "ball_colours is empty"},
      {{"kinect3d.colour_check.mode=required",
        "kinect3d.colour_check.ball_colours=[{lab: [60, 20, 50], sigma: [5, 3, 3], share: 1.0}]"},
       "kinect3d.colour is false"}};
  for (const auto& [overrides, expected] : cases) {
    try {
      kinect3d::readDetectorConfig(fw::Config::load(PROJECT_CONFIG_DIR "/defaults", "", overrides).block("kinect3d"));
      ADD_FAILURE() << "no error for " << overrides.back();
    } catch (const fw::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("kinect3d.colour_check.mode"), std::string::npos) << e.what();
    }
  }
}

TEST(CalibrateBallColourCommand, LearnsTheBallFromASimulatedSessionAndWritesItIntoTheRobotFileTheCheckThenReads) {
  const ScopedTempDir dir;
  const std::filesystem::path robot = dir.path() / "robot.yaml", session = dir.path() / "session";
  std::ofstream(robot) << "kinect3d:\n  source: \"openni2:\"  # the robot's own sensor\n  sensor:\n"
                          "    pose_in_robot: {x: 0.0, y: 0.1, z: 0.65, yaw_deg: 0.0, pitch_deg: 4.0, roll_deg: 0.0}\n";
  const auto [simulated, simulate_output] =
      runCommand(std::string(KINECT3D_EXE) + " simulate-session --ball yellow --out " + session.string() +
                 " --config " + robot.string() + " 2>&1");
  ASSERT_EQ(simulated, 0) << simulate_output;
  EXPECT_TRUE(std::filesystem::exists(session / "rgb.txt")) << simulate_output;
  EXPECT_TRUE(std::filesystem::exists(session / "marks.yaml")) << "for kinect3d calibrate too";
  const auto [status, output] =
      runCommand(std::string(KINECT3D_EXE) + " calibrate ball-colour --source tum:" + session.string() + " --config " +
                 robot.string() + " --write 2>&1");
  ASSERT_EQ(status, 0) << output;
  EXPECT_NE(output.find("Separability"), std::string::npos) << output;
  const fw::Config config = fw::Config::load(PROJECT_CONFIG_DIR "/defaults", robot.string(),
                                             {"kinect3d.colour=true", "kinect3d.colour_check.mode=on"});
  const kinect3d::ColourCheckConfig check = kinect3d::readColourCheckConfig(config.block("kinect3d"));
  ASSERT_EQ(check.ball_colours.size(), 1u);
  EXPECT_LT(check.ball_colours[0].lab.y(), 0.0);                        // yellow: red-green axis towards green ...
  EXPECT_GT(check.ball_colours[0].lab.z(), 50.0);                       // ... and far towards yellow
  EXPECT_EQ(config.block("kinect3d").getString("source"), "openni2:");  // the rest of the file as it was

  std::ofstream(dir.path() / "level.yaml") << "kinect3d:\n  source: \"openni2:\"\n";
  const auto [refused, refused_output] =
      runCommand(std::string(KINECT3D_EXE) + " simulate-session --out " + (dir.path() / "x").string() + " --config " +
                 (dir.path() / "level.yaml").string() + " 2>&1");
  EXPECT_NE(refused, 0);
  EXPECT_NE(refused_output.find("kinect3d.sensor.pose_in_robot"), std::string::npos) << refused_output;
}

}  // namespace
