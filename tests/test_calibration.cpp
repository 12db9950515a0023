// Calibrating the depth sensor's pose from balls on known marks: the solver on exact and corrupted
// marks, the layouts it must refuse, rewriting a robot file, and `kinect3d calibrate` end to end on
// a simulated session.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "calibrate_pose.h"
#include "framework_api/config.h"
#include "framework_api/host.h"
#include "kinect3d/sensor_calibration.h"
#include "kinect3d/sim/calibration_scene.h"
#include "run_command.h"
#include "run_host.h"
#include "scoped_temp_dir.h"

namespace {

namespace fs = std::filesystem;

const fw::SensorPose kTruth{0.08, 0.21, 0.64, 0.2, 0.15, -0.05};  // yawed, pitched, rolled

// The floor's view of the truth: height, pitch and roll; x, y and yaw unknown (zero).
Eigen::Isometry3d floorPose(const fw::SensorPose& truth) {
  return fw::SensorPose{0.0, 0.0, truth.z_m, 0.0, truth.pitch_rad, truth.roll_rad}.T_R_S();
}

std::vector<kinect3d::CalibrationMark> marksAt(const std::vector<Eigen::Vector2d>& xy) {
  std::vector<kinect3d::CalibrationMark> marks;
  for (const Eigen::Vector2d& p : xy) {
    const Eigen::Vector3d ball_R(p.x(), p.y(), 0.11);
    marks.push_back({"mark", ball_R, kTruth.T_R_S().inverse() * ball_R, 0.0});
  }
  return marks;
}

void expectPose(const fw::SensorPose& found, const fw::SensorPose& truth, double tol_m, double tol_rad) {
  EXPECT_NEAR(found.x_m, truth.x_m, tol_m);
  EXPECT_NEAR(found.y_m, truth.y_m, tol_m);
  EXPECT_NEAR(found.z_m, truth.z_m, tol_m);
  EXPECT_NEAR(found.yaw_rad, truth.yaw_rad, tol_rad);
  EXPECT_NEAR(found.pitch_rad, truth.pitch_rad, tol_rad);
  EXPECT_NEAR(found.roll_rad, truth.roll_rad, tol_rad);
}

std::string refusal(const std::vector<kinect3d::CalibrationMark>& marks, bool floor) {
  try {
    kinect3d::calibrateSensorPose(marks, floor ? std::optional(floorPose(kTruth)) : std::nullopt);
  } catch (const kinect3d::CalibrationError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(SensorCalibration, RecoversThePoseExactlyFromNoiseFreeMarks) {
  const auto marks = marksAt({{0.0, 2.0}, {-0.6, 2.8}, {0.6, 3.0}, {0.1, 3.8}});
  const auto with_floor = kinect3d::calibrateSensorPose(marks, floorPose(kTruth));
  expectPose(with_floor.pose, kTruth, 1e-9, 1e-9);
  EXPECT_TRUE(with_floor.used_floor);
  ASSERT_TRUE(with_floor.sigma);
  EXPECT_LT(with_floor.sigma->norm(), 1e-9);
  const auto without = kinect3d::calibrateSensorPose(marks, std::nullopt);
  expectPose(without.pose, kTruth, 1e-9, 1e-9);
  for (double residual : without.residuals_m) EXPECT_LT(residual, 1e-9);
  // Two marks are enough with the floor.
  expectPose(kinect3d::calibrateSensorPose(marksAt({{0.0, 2.0}, {0.6, 3.0}}), floorPose(kTruth)).pose, kTruth, 1e-9,
             1e-9);
}

TEST(SensorCalibration, RefusesLayoutsThatCannotDetermineThePoseSayingWhatToAdd) {
  EXPECT_NE(refusal(marksAt({{0.0, 2.0}}), true).find("1 mark(s) with a ball: with the floor in view two marks fix"),
            std::string::npos);
  EXPECT_NE(refusal(marksAt({{0.0, 2.0}, {0.6, 3.0}}), false).find("three marks off one line are needed; add 1 more"),
            std::string::npos);
  EXPECT_NE(refusal(marksAt({{0.0, 2.0}, {0.3, 2.2}, {0.1, 2.4}}), true).find("spread them at least 1.00 m apart"),
            std::string::npos);
  EXPECT_NE(refusal(marksAt({{0.0, 2.0}, {0.5, 3.0}, {1.0, 4.0}}), false).find("the marks lie on one line"),
            std::string::npos);
  EXPECT_EQ(refusal(marksAt({{0.0, 2.0}, {0.5, 3.0}, {1.0, 4.0}}), true), "accepted");  // the floor fixes the roll
}

TEST(SensorCalibration, DropsAMislabelledMarkWhenFourOrMoreAreGiven) {
  auto marks = marksAt({{0.0, 2.0}, {-0.6, 2.8}, {0.6, 3.0}, {0.1, 3.8}, {-0.4, 2.3}});
  // Centimetre noise on every mark, and mark 2 written 0.5 m off.
  const double noise[5][3] = {{0.004, -0.003, 0.002},
                              {-0.002, 0.004, 0.0},
                              {0.003, 0.001, -0.004},
                              {-0.004, -0.002, 0.003},
                              {0.001, 0.003, -0.001}};
  for (int i = 0; i < 5; ++i) marks[i].ball_S_m += Eigen::Vector3d(noise[i][0], noise[i][1], noise[i][2]);
  marks[1].ball_R_m.x() += 0.5;
  for (bool floor : {true, false}) {
    const auto result = kinect3d::calibrateSensorPose(marks, floor ? std::optional(floorPose(kTruth)) : std::nullopt);
    EXPECT_EQ(result.used, (std::vector<bool>{true, false, true, true, true})) << floor;
    EXPECT_GT(result.residuals_m[1], 0.4);
    expectPose(result.pose, kTruth, 0.01, 0.3 * M_PI / 180.0);
  }
}

TEST(SensorCalibration, WritesThePoseIntoTheRobotFileChangingNothingElse) {
  ScopedTempDir dir;
  const fs::path robot = dir.path() / "robot.yaml";
  const std::vector<std::string> original = {
      "# My keeper.",
      "host:",
      "  robot_name: keeper   # the name in logs",
      "  plugins: [kinect3d, console]",
      "kinect3d:",
      "  source: \"openni2:\"",
      "  sensor:",
      "    pose_in_robot: {x: 0.0, y: 0.1, z: 0.75, yaw_deg: 0.0, pitch_deg: 3.0, roll_deg: 0.0}  # measured by hand",
      "    baseline_m: 0.075",
      "console:",
      "  rate_hz: 2.0"};
  {
    std::ofstream out(robot);
    for (const std::string& line : original) out << line << "\n";
  }
  const std::string backup = kinect3d::writePoseInRobotFile(robot.string(), kTruth);
  std::vector<std::string> written;
  std::ifstream in(robot);
  for (std::string line; std::getline(in, line);) written.push_back(line);
  ASSERT_EQ(written.size(), original.size());
  for (std::size_t i = 0; i < original.size(); ++i) {
    if (i == 7) continue;
    EXPECT_EQ(written[i], original[i]) << "line " << i + 1;
  }
  EXPECT_EQ(written[7].rfind("    pose_in_robot: {x: 0.0800, y: 0.2100, z: 0.6400, yaw_deg: 11.459", 0), 0u)
      << written[7];
  EXPECT_NE(written[7].find("}  # measured by hand"), std::string::npos) << written[7];
  std::ifstream old(backup);
  std::string first;
  std::getline(old, first);
  EXPECT_EQ(first, original[0]);
  // The file still loads, with the new pose.
  const fw::Config config = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", robot.string(), {});
  EXPECT_DOUBLE_EQ(config.block("kinect3d").child("sensor").child("pose_in_robot").getDouble("z", 0, 3), 0.64);

  // A file without a sensor block gets one under kinect3d.
  const fs::path bare = dir.path() / "bare.yaml";
  std::ofstream(bare) << "host:\n  robot_name: bare\n  plugins: [kinect3d]\nkinect3d:\n  source: \"openni2:\"\n";
  kinect3d::writePoseInRobotFile(bare.string(), kTruth);
  const fw::Config bare_config = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", bare.string(), {});
  EXPECT_DOUBLE_EQ(bare_config.block("kinect3d").child("sensor").child("pose_in_robot").getDouble("y", -3, 3), 0.21);
  EXPECT_EQ(bare_config.block("kinect3d").getString("source"), "openni2:");
}

// What a team does on the field: a recording of the ball on four marks, the marks file, one command.
TEST(CalibrateCommand, FindsASimulatedSensorsPoseAndWritesItIntoTheRobotFile) {
  ScopedTempDir dir;
  const fw::SensorPose truth{-0.10, 0.15, 0.70, -5.0 * M_PI / 180, 5.0 * M_PI / 180, 4.0 * M_PI / 180};
  kinect3d::sim::writeCalibrationSession({truth, {{0.0, 2.0}, {-0.6, 2.8}, {0.6, 3.0}, {0.1, 3.8}}, 0.7, 3},
                                         dir.path().string());
  const fs::path robot = dir.path() / "robot.yaml";
  std::ofstream(robot) << "host:\n  robot_name: r\n  plugins: [kinect3d]\nkinect3d:\n  sensor:\n"
                       << "    pose_in_robot: {x: 0.0, y: 0.0, z: 0.7, yaw_deg: 0.0, pitch_deg: 0.0, roll_deg: 0.0}\n";
  const auto [status, out] =
      runCommand(std::string(KINECT3D_EXE) + " calibrate --source tum:" + dir.path().string() + " --marks " +
                 (dir.path() / "marks.yaml").string() + " --config " + robot.string() + " --write --plot " +
                 (dir.path() / "plot").string() + " 2>/dev/null");
  ASSERT_EQ(status, 0) << out;
  EXPECT_NE(out.find("# 1 sigma: x "), std::string::npos) << out;
  EXPECT_NE(out.find("height, pitch and roll from the floor"), std::string::npos) << out;
  const fw::ConfigView pose = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", robot.string(), {})
                                  .block("kinect3d")
                                  .child("sensor")
                                  .child("pose_in_robot");
  const fw::SensorPose found{pose.getDouble("x", -9, 9),
                             pose.getDouble("y", -9, 9),
                             pose.getDouble("z", -9, 9),
                             pose.getDouble("yaw_deg", -180, 180) * M_PI / 180,
                             pose.getDouble("pitch_deg", -90, 90) * M_PI / 180,
                             pose.getDouble("roll_deg", -180, 180) * M_PI / 180};
  expectPose(found, truth, 0.01, 0.3 * M_PI / 180.0);
  // The page draws, as a person opening it sees it.
  const auto [page_status, dom] =
      runCommand("chromium --headless --no-sandbox --disable-gpu --virtual-time-budget=5000 --dump-dom file://" +
                 (dir.path() / "plot" / "index.html").string() + " 2>/dev/null");
  ASSERT_EQ(page_status, 0);
  EXPECT_NE(dom.find("data-drawn=\"yes\""), std::string::npos);
  EXPECT_NE(dom.find("pose_in_robot: {x: -0.1"), std::string::npos);
}

TEST(CalibrateCommand, AMarkWithoutABallIsNamedWithItsLine) {
  ScopedTempDir dir;
  kinect3d::sim::writeCalibrationSession({kTruth, {{0.0, 2.0}, {0.6, 3.0}}, 0.5, 3}, dir.path().string());
  const fs::path marks = dir.path() / "late.yaml";
  std::ofstream(marks) << "marks:\n  - {x: 0.0, y: 2.0, from_s: 0.1, to_s: 0.4}\n"
                       << "  - {x: 0.6, y: 3.0, from_s: 5.0, to_s: 6.0}   # after the recording ends\n";
  const auto [status, out] = runCommand(std::string(KINECT3D_EXE) + " calibrate --source tum:" + dir.path().string() +
                                        " --marks " + marks.string() + " 2>&1");
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("mark 2 (" + marks.string() + ":3): no ball found between 5"), std::string::npos) << out;
}

// Live (a device, no time ranges): one prompt per mark, a second of frames averaged after each Enter.
// The simulated device shows one hung ball, so both marks see it at the same place: the solve then
// refuses the layout, which it only reaches when both captures found the ball.
TEST(CalibrateCommand, LiveAsksForEachMarkAndCapturesAfterEnter) {
  ScopedTempDir dir;
  const fs::path marks = dir.path() / "marks.yaml";
  std::ofstream(marks) << "marks:\n  - {x: 0.0, y: 3.0, z: 1.0}\n  - {x: 0.0, y: 3.0, z: 1.0}\n";
  const auto [status, out] =
      runCommand("printf '\\n\\n' | " + std::string(KINECT3D_EXE) +
                 " calibrate --source 'openni2:kinect3d-sim://hung_3m?frames=600' --marks " + marks.string() + " 2>&1");
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("Put the ball on mark 1 (" + marks.string() + ":2) at (0, 3) and press Enter"), std::string::npos)
      << out;
  EXPECT_NE(out.find("Put the ball on mark 2"), std::string::npos) << out;
  EXPECT_NE(out.find("the marks lie within 0.00 m of each other"), std::string::npos) << out;
}

// The calibration alarms of the kinect3d plugin on the hung ball scene (sensor level, 0.7 m up), with
// pose_in_robot as given: the truth, or a sensor knocked since (tilted, or lowered).
std::vector<fw::Event> alarmsWithPose(const std::string& pose) {
  const fw::Config config = fw::Config::load(
      std::string(PROJECT_CONFIG_DIR) + "/defaults", std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml",
      {"host.plugins=[kinect3d]", "kinect3d.source=sim:hung_3m", "kinect3d.realtime=false",
       "kinect3d.calibration_check.interval_frames=10", "kinect3d.sensor.pose_in_robot=" + pose});
  fw::Host host(config, PRODUCT_PLUGIN_DIR);
  host.world().openJournal(false);
  runUntilSourcesEnd(host);
  std::vector<fw::Event> alarms;
  for (const fw::JournalEntry& entry : host.world().takeJournal(nullptr)) {
    const auto* event = std::get_if<fw::Event>(&entry.item);
    if (event != nullptr && event->kind == "calibration_alarm") alarms.push_back(*event);
  }
  return alarms;
}

TEST(CalibrationAlarm, RaisedOnAKnockedSensorAndNotOtherwise) {
  EXPECT_TRUE(alarmsWithPose("{x: 0.0, y: 0.0, z: 0.7, yaw_deg: 0.0, pitch_deg: 0.0, roll_deg: 0.0}").empty());
  // Yaw and the offset on the robot are invisible to the floor: no alarm either.
  EXPECT_TRUE(alarmsWithPose("{x: 0.1, y: 0.2, z: 0.7, yaw_deg: 10.0, pitch_deg: 0.0, roll_deg: 0.0}").empty());
  const auto tilted = alarmsWithPose("{x: 0.0, y: 0.0, z: 0.7, yaw_deg: 0.0, pitch_deg: 3.0, roll_deg: 0.0}");
  ASSERT_EQ(tilted.size(), 1u);  // once per episode, not once per check
  EXPECT_NE(tilted[0].message.find("THE SENSOR HAS MOVED"), std::string::npos);
  EXPECT_NE(tilted[0].message.find("pose_in_robot says z 0.700 m, pitch 3.00 deg"), std::string::npos)
      << tilted[0].message;
  const std::size_t estimate = tilted[0].message.find("Estimated pose_in_robot: {x: 0.0000, y: 0.0000, z: ");
  ASSERT_NE(estimate, std::string::npos) << tilted[0].message;
  EXPECT_NEAR(std::stod(tilted[0].message.substr(estimate + 51)), 0.70, 0.005) << tilted[0].message;
  const auto lowered = alarmsWithPose("{x: 0.0, y: 0.0, z: 0.78, yaw_deg: 0.0, pitch_deg: 0.0, roll_deg: 0.0}");
  ASSERT_EQ(lowered.size(), 1u);
  const std::size_t floor_z = lowered[0].message.find("the floor puts it at z ");
  ASSERT_NE(floor_z, std::string::npos) << lowered[0].message;
  EXPECT_NEAR(std::stod(lowered[0].message.substr(floor_z + 23)), 0.70, 0.005) << lowered[0].message;
}

}  // namespace
