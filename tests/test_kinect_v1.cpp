// The Kinect v1 path with no hardware: its units (disparity, 60 MHz stamps, accelerometer), the
// fakenect-record folder format both ways, the freenect: source over Debian's fakenect replay
// library inside vision_host, colour from TUM folders, and the moved-sensor alarm from gravity.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>

#include "host_process.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/camera_file.h"
#include "kinect3d/depth_source.h"
#include "kinect3d/fakenect_recording.h"
#include "kinect3d/kinect_disparity.h"
#include "kinect3d/sensor_calibration.h"
#include "kinect3d/sim/scene.h"
#include "kinect3d/sim/sequence_writer.h"
#include "match_view.h"
#include "matchlog/match_log.h"
#include "random_draws.h"
#include "real_data.h"
#include "run_command.h"
#include "scoped_temp_dir.h"

namespace {

namespace fs = std::filesystem;
using kinect3d::DepthFrame;
using kinect3d::DepthSourceError;
using kinect3d::ReadResult;

constexpr double kDeg = M_PI / 180.0;

TEST(KinectUnits, DisparityRoundTripsAndADeviceLineIsNearTheDefault) {
  const kinect3d::DisparityModel model;
  for (std::uint16_t raw = 300; raw < 1080; raw += 7) EXPECT_EQ(model.raw(model.metres(raw)), raw) << raw;
  EXPECT_EQ(model.raw(0.0), kinect3d::kRawDisparityInvalid);
  EXPECT_EQ(model.metres(kinect3d::kRawDisparityInvalid), 0.0);
  // A unit's constants (zero plane 120 mm, pixel 0.1042 mm, emitter 7.5 cm, shift 200) give its
  // own line: near the default fit between 1 and 5 m, but several per cent off it, which is why
  // the unit's own line is used when libfreenect can read it.
  const auto unit = kinect3d::DisparityModel::fromDeviceConstants(120.0, 0.1042, 7.5, 200.0);
  for (double z = 1.0; z <= 5.0; z += 0.5) EXPECT_NEAR(unit.metres(model.raw(z)), z, 0.08 * z) << z;
  EXPECT_GT(std::abs(unit.metres(model.raw(1.5)) - 1.5), 0.01) << "the constants are used";
  const kinect3d::DisparityTable table(model);
  EXPECT_EQ(table.millimetres(700), std::lround(model.metres(700) * 1000.0));
  EXPECT_EQ(table.millimetres(kinect3d::kRawDisparityInvalid), 0);
}

TEST(KinectUnits, StampsUnwrapWithoutAJumpAndGapsAreDroppedFrames) {
  kinect3d::KinectStampClock clock;
  const std::uint32_t start = 0xFFFFFFFFu - 3'000'000u;  // the wrap comes between the 2nd and 3rd frame
  std::vector<kinect3d::KinectStampClock::Time> times;
  for (std::uint32_t k : {0u, 1u, 2u, 3u, 5u}) times.push_back(clock.next(start + k * 2'000'000u));
  for (std::size_t i = 1; i < times.size(); ++i) EXPECT_GT(times[i].seconds, times[i - 1].seconds);
  EXPECT_NEAR(times[3].seconds, 3.0 / 30.0, 1e-9);
  EXPECT_EQ(times[3].index, 3);
  EXPECT_EQ(times[4].index, 5) << "one frame missing: the index says so";
  // A colour stamp a little older than the depth before it goes back a little, not forward by 71.6 s.
  EXPECT_NEAR(clock.next(start + 5 * 2'000'000u - 100'000u).seconds, 5.0 / 30.0 - 100'000 / 60e6, 1e-9);
}

TEST(KinectUnits, AccelerometerGivesGravityInTheOpticalFrame) {
  const Eigen::Vector3d level = kinect3d::gravityFromAccelerometer(0, 819, 0);
  EXPECT_NEAR((level - Eigen::Vector3d(0.0, kinect3d::kStandardGravity_mps2, 0.0)).norm(), 0.0, 1e-9);
  // Tilted down by 10 degrees: gravity leans towards the optical axis (+z), the raw z goes negative.
  const Eigen::Vector3d down10 =
      kinect3d::kStandardGravity_mps2 * Eigen::Vector3d(0.0, std::cos(10 * kDeg), std::sin(10 * kDeg));
  const auto counts = kinect3d::accelerometerFromGravity(down10);
  EXPECT_LT(counts[2], 0);
  EXPECT_NEAR((kinect3d::gravityFromAccelerometer(counts[0], counts[1], counts[2]) - down10).norm(), 0.0, 0.02);
}

// A scene written by `kinect3d simulate --format fakenect`.
kinect3d::sim::Scene hungBall(double seconds) {
  kinect3d::sim::Scene scene = kinect3d::sim::loadScene("hung_3m");
  scene.duration_s = seconds;
  return scene;
}

TEST(FakenectFolder, PlaysWhatTheSimulatorWroteWithColourGravityAndTimeAcrossTheWrap) {
  const ScopedTempDir temp;
  const kinect3d::sim::Scene scene = hungBall(1.0);
  kinect3d::sim::writeFakenectRecording(scene, temp.path().string());
  const auto index = kinect3d::readFakenectIndex(temp.path().string());
  ASSERT_EQ(index.size(), 90u) << "depth, colour and accelerometer for each of 30 frames";
  EXPECT_EQ(index[0].type, 'd');
  EXPECT_GT(index[0].stamp, index[30].stamp) << "the stamps wrap within the recording";

  kinect3d::SourceOptions options;
  options.colour = true;
  auto source = kinect3d::DepthSourceTable::core().open(temp.path().string(), options);  // a bare folder
  EXPECT_EQ(source->describe(), "fakenect:" + temp.path().string());
  kinect3d::DetectorConfig config;
  config.ground.pose = scene.sensor_pose;
  kinect3d::BallDetector detector(config, "kinect3d");
  kinect3d::Detections detections;
  DepthFrame frame;
  std::vector<double> times_s;
  int frames = 0, ball_right = 0;
  while (source->read(frame) == ReadResult::kFrame) {
    times_s.push_back(frame.source_time_s);
    ASSERT_TRUE(frame.gravity_S_mps2.has_value());
    EXPECT_NEAR(frame.gravity_S_mps2->y(), kinect3d::kStandardGravity_mps2, 0.02);
    ASSERT_TRUE(frame.colour.has_value());
    EXPECT_EQ(frame.colour->rgb.size(), 640u * 480u * 3u);
    EXPECT_NEAR(frame.colour->offset_S_m.x(), 0.025, 1e-9);
    detector.detect(frame, detections);
    ball_right +=
        !detections.balls.empty() && (detections.balls.front().position_m - scene.ball->position_m).norm() < 0.05;
    ++frames;
  }
  EXPECT_EQ(frames, 30);
  EXPECT_GE(ball_right, 28) << "the ball within 5 cm of where the simulator hung it";
  for (std::size_t i = 1; i < times_s.size(); ++i) {
    EXPECT_NEAR(times_s[i] - times_s[i - 1], 1.0 / 30.0, 1e-6) << "frame " << i << ": no jump at the wrap";
  }
  EXPECT_EQ(source->counters().dropped, 0u);
  EXPECT_NEAR(index[0].host_time_s, scene.start_time_s, 1e-6);
}

std::string openError(const std::string& uri) {
  try {
    auto source = kinect3d::DepthSourceTable::core().open(uri);
    DepthFrame frame;
    while (source->read(frame) == ReadResult::kFrame) {
    }
  } catch (const DepthSourceError& e) {
    return e.what();
  }
  return "";
}

TEST(FakenectFolder, BadFoldersSayWhatIsWrongWhere) {
  const ScopedTempDir temp;
  const std::string dir = temp.path().string();
  EXPECT_NE(openError("fakenect:" + dir).find("has no readable INDEX.txt"), std::string::npos);
  std::ofstream(temp.path() / "INDEX.txt") << "d-1.0-5.pgm\nnot a name\n";
  std::ofstream(temp.path() / "d-1.0-5.pgm") << "P5 640 480 65535\n";
  EXPECT_NE(openError("fakenect:" + dir).find("INDEX.txt:2: 'not a name' is not a fakenect file name"),
            std::string::npos);
  std::ofstream(temp.path() / "INDEX.txt") << "d-1.0-5.pgm\nr-1.0-5.ppm\n";
  EXPECT_NE(openError("fakenect:" + dir).find("INDEX.txt:2: 'r-1.0-5.ppm' does not exist"), std::string::npos);
  std::ofstream(temp.path() / "INDEX.txt") << "d-1.0-5.pgm\n";
  EXPECT_NE(openError("fakenect:" + dir).find("none of its depth frames could be read"), std::string::npos)
      << "the one depth file is truncated";
}

// A hung ball and a sensor that is knocked 4 degrees down at 1 s, with the floor out of view:
// only gravity can tell.
std::string writeKnockedScene(const fs::path& dir) {
  const fs::path file = dir / "knocked.yaml";
  std::ofstream(file)
      << "name: knocked\nduration_s: 4.0\nfloor: false\n"
         "sensor:\n  pose_in_robot: {x: 0.0, y: 0.0, z: 0.7, yaw_deg: 0.0, pitch_deg: 0.0, roll_deg: 0.0}\n"
         "  knocked:\n    at_s: 1.0\n    pose_in_robot: {x: 0.0, y: 0.0, z: 0.7, yaw_deg: 0.0, pitch_deg: 4.0, "
         "roll_deg: 0.0}\n"
         "objects:\n  - {type: box, center: [0.0, 7.7, 1.5], size: [16.0, 0.2, 3.0]}\n"
         "ball:\n  position: [0.0, 3.0, 1.0]\n  hanging: true\n";
  return file.string();
}

TEST(FreenectOverFakenect, TheKinectPathPlaysARecordingIntoTheHostAndGravityAloneRaisesTheAlarm) {
  const ScopedTempDir temp;
  const fs::path recording = temp.path() / "recording";
  const kinect3d::sim::Scene scene = kinect3d::sim::loadScene(writeKnockedScene(temp.path()));
  kinect3d::sim::writeFakenectRecording(scene, recording.string());
  const fs::path robot = temp.path() / "robot.yaml";
  std::ofstream(robot) << "host:\n  robot_name: kinect\n  plugins: [kinect3d, logger]\n"
                          "kinect3d:\n  source: \"freenect:0\"\n  colour: true\n  sensor:\n"
                          "    pose_in_robot: {x: 0.0, y: 0.0, z: 0.7, yaw_deg: 0.0, pitch_deg: 0.0, roll_deg: 0.0}\n"
                          "  calibration_check: {confirmations: 2}\n"
                          "logger:\n  folder: "
                       << (temp.path() / "logs").string() << "\n";
  // Debian's fakenect takes libfreenect's place in the host's process only.
  setenv("LD_LIBRARY_PATH", FAKENECT_LIBRARY_DIR, 1);
  setenv("FAKENECT_PATH", recording.c_str(), 1);
  HostProcess host({"--robot", robot.string(), "--defaults", PROJECT_CONFIG_DIR "/defaults"});
  unsetenv("LD_LIBRARY_PATH");
  unsetenv("FAKENECT_PATH");
  ASSERT_TRUE(host.waitForOutput("THE SENSOR HAS MOVED since its calibration: gravity", std::chrono::seconds(120)))
      << host.readAll();
  // The end of the recording is an unplugged device: reported, reopened, the host goes on.
  ASSERT_TRUE(host.waitForOutput("libfreenect stopped delivering", std::chrono::seconds(120))) << host.readAll();
  host.signal(SIGTERM);
  ASSERT_EQ(host.waitExit(std::chrono::seconds(60)), 0) << host.readAll();
  const std::string output = host.readAll();
  const std::string said = "gravity puts it at pitch ";
  const std::size_t at = output.find(said);
  ASSERT_NE(at, std::string::npos) << output;
  EXPECT_NEAR(std::stod(output.substr(at + said.size(), 8)), 4.0, 0.2) << "the pitch gravity implies: " << output;

  const fs::path log = *fs::directory_iterator(temp.path() / "logs");
  const fw::MatchLogReader reader(log.string());
  const auto frames = reader.depthFrameStamps("kinect3d");
  ASSERT_GE(frames.size(), 110u) << "of the recording's 120 frames";
  const fw::DepthImage image = reader.depthFrame(frames[10].seq);
  ASSERT_TRUE(image.gravity_S_mps2.has_value());
  EXPECT_NEAR(image.gravity_S_mps2->y(), kinect3d::kStandardGravity_mps2, 0.05);
  ASSERT_TRUE(image.colour.has_value());
  EXPECT_EQ(image.colour->width, 640);
  EXPECT_LT(std::abs(image.colour->source_time_s - image.stamp.source_time_s), 0.05);
  int alarms = 0, balls_right = 0;
  for (const fw::JournalEntry& entry : reader.entries()) {
    if (const auto* event = std::get_if<fw::Event>(&entry.item)) {
      alarms += event->kind == "calibration_alarm" && event->message.find("gravity") != std::string::npos;
    }
    if (const auto* balls = std::get_if<fw::BallFrame>(&entry.item);
        balls && !balls->balls.empty() && balls->stamp.source_time_s < image.stamp.source_time_s + 0.5) {
      balls_right += (balls->balls.front().position_m - scene.ball->position_m).norm() < 0.05;
    }
  }
  EXPECT_EQ(alarms, 1);
  EXPECT_GE(balls_right, 20) << "the ball where the simulator hung it, before the knock";

  // The viewer shows the colour image and the gravity reading of a frame.
  kinect3d::MatchView view(log.string());
  const std::optional<nlohmann::json> shown = view.frame(10);
  ASSERT_TRUE(shown.has_value());
  EXPECT_TRUE(shown->at("colour").get<bool>());
  EXPECT_NEAR(shown->at("gravity_S_mps2").at(1).get<double>(), kinect3d::kStandardGravity_mps2, 0.05);
  const std::optional<std::string> colour_png = view.colourPng(10);
  ASSERT_TRUE(colour_png.has_value());
  const cv::Mat shown_colour =
      cv::imdecode(std::vector<unsigned char>(colour_png->begin(), colour_png->end()), cv::IMREAD_COLOR);
  EXPECT_EQ(shown_colour.cols, 640);

  // Exported, the colour comes along: a TUM folder with rgb.txt that plays with its colour.
  const fs::path tum = temp.path() / "tum";
  const auto [status, export_output] =
      runCommand(std::string(KINECT3D_EXE) + " export " + log.string() + " --tum " + tum.string() + " 2>&1");
  ASSERT_EQ(status, 0) << export_output;
  kinect3d::SourceOptions options;
  options.colour = true;
  auto exported = kinect3d::DepthSourceTable::core().open("tum:" + tum.string(), options);
  DepthFrame frame;
  for (int i = 0; i <= 10; ++i) ASSERT_EQ(exported->read(frame), ReadResult::kFrame);
  ASSERT_TRUE(frame.colour.has_value());
  EXPECT_NEAR(frame.colour->offset_S_m.x(), 0.025, 1e-9) << "the colour camera in camera.yaml";
  EXPECT_EQ(frame.colour->rgb.size(), image.colour->rgb.size());
}

// Gravity readings from a sensor with a bias, noise and a robot that brakes now and then.
struct GravityRun {
  std::optional<fw::SensorPose> alarm;
  double alarm_t_s = NAN;
};
GravityRun runGravity(unsigned seed, double bias_rad, double knock_at_s, double knock_pitch_rad) {
  std::mt19937 random(seed);
  std::normal_distribution<double> noise(0.0, 0.004);  // per axis, in g: about 3 counts
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const fw::SensorPose calibrated{0.0, 0.0, 0.7, 0.0, 5.0 * kDeg, 0.0};
  kinect3d::GravityCalibrationCheck check({}, calibrated);
  const double bias_axis_z = uniform(random) - 0.5;
  const double bias_axis_x = uniform(random) - 0.5;
  const Eigen::Vector3d bias_axis = Eigen::Vector3d(bias_axis_x, 0.0, bias_axis_z).normalized();
  GravityRun run;
  for (int i = 0; i < 30 * 20; ++i) {
    const double t = i / 30.0;
    fw::SensorPose now = calibrated;
    if (t >= knock_at_s) now.pitch_rad += knock_pitch_rad;
    Eigen::Vector3d specific_force_R(0.0, 0.0, 1.0);           // in g
    if (std::fmod(t, 3.0) < 0.4) specific_force_R.y() = 0.25;  // braking hard for 0.4 s every 3 s
    const Eigen::Vector3d g_S = -(now.T_R_S().linear().transpose() * specific_force_R);
    DepthFrame frame;
    frame.source_time_s = t;
    frame.gravity_S_mps2 =
        kinect3d::kStandardGravity_mps2 * (Eigen::AngleAxisd(bias_rad, bias_axis) * g_S + drawVector3(noise, random));
    if (const auto moved = check.check(frame); moved && !run.alarm) {
      run.alarm = moved;
      run.alarm_t_s = t;
    }
  }
  return run;
}

TEST(GravityCheck, AKnockAfterTheStartIsAnAlarmAndBrakingOrAUnitsBiasIsNot) {
  for (unsigned seed = 1; seed <= 10; ++seed) {
    const double bias = std::uniform_real_distribution<double>(0.0, 2.5)(*std::make_unique<std::mt19937>(seed)) * kDeg;
    EXPECT_FALSE(runGravity(seed, bias, 1e9, 0.0).alarm) << "seed " << seed << ": a level robot that brakes";
    const GravityRun knocked = runGravity(seed, bias, 5.0, 4.0 * kDeg);
    ASSERT_TRUE(knocked.alarm) << "seed " << seed;
    EXPECT_LT(knocked.alarm_t_s, 10.0) << "seed " << seed;
    EXPECT_NEAR(knocked.alarm->pitch_rad, 9.0 * kDeg, 0.5 * kDeg) << "seed " << seed;
    EXPECT_NEAR(knocked.alarm->z_m, 0.7, 1e-12) << "gravity cannot see height";
    EXPECT_TRUE(runGravity(seed, bias, 0.0, 8.0 * kDeg).alarm) << "seed " << seed << ": knocked before the start";
  }
}

TEST(TumColour, EachDepthFrameGetsTheColourImageNearestInTimeWithinTumsLimit) {
  const std::optional<std::string> depth = realDataFile("realdata/pcl_single_frames/five_people_depth_mm.png");
  const std::optional<std::string> rgb = realDataFile("realdata/pcl_single_frames/five_people_rgb.png");
  if (!depth || !rgb) GTEST_SKIP() << noRealData("realdata/pcl_single_frames/five_people_rgb.png");
  const ScopedTempDir temp;
  std::ofstream(temp.path() / "depth.txt") << "1.000 " << *depth << "\n2.000 " << *depth << "\n";
  std::ofstream(temp.path() / "rgb.txt") << "# timestamp filename\n1.015 " << *rgb << "\n2.100 " << *rgb << "\n";
  std::ofstream(temp.path() / "camera.yaml") << "fx: 525\nfy: 525\ncx: 319.5\ncy: 239.5\nwidth: 640\nheight: 480\n"
                                                "depth_scale: 1000\n";
  kinect3d::SourceOptions options;
  options.colour = true;
  auto source = kinect3d::DepthSourceTable::core().open("tum:" + temp.path().string(), options);
  DepthFrame frame;
  ASSERT_EQ(source->read(frame), ReadResult::kFrame);
  ASSERT_TRUE(frame.colour.has_value()) << "15 ms apart";
  EXPECT_DOUBLE_EQ(frame.colour->source_time_s, 1.015);
  long sum = 0;
  for (std::uint8_t c : frame.colour->rgb) sum += c;
  EXPECT_GT(sum, 640L * 480 * 3 * 20) << "a real, lit image";
  ASSERT_EQ(source->read(frame), ReadResult::kFrame);
  EXPECT_FALSE(frame.colour.has_value()) << "100 ms apart: beyond TUM's 20 ms";
  options.colour = false;
  auto without = kinect3d::DepthSourceTable::core().open("tum:" + temp.path().string(), options);
  ASSERT_EQ(without->read(frame), ReadResult::kFrame);
  EXPECT_FALSE(frame.colour.has_value()) << "colour off";
}

}  // namespace
