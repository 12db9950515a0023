// The match log: its round trip, its errors, the logger plugin in the real host (a whole demo run, a
// small budget, a SIGKILL mid-run), and what the team does with a log afterwards (replay, export).
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <thread>
#include <tuple>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "demo_log.h"
#include "framework_api/host.h"
#include "fusion/json_lines.h"
#include "host_process.h"
#include "kinect3d/depth_source.h"
#include "matchlog/match_log.h"
#include "published_log.h"
#include "run_command.h"
#include "scoped_temp_dir.h"
#include "small_depth_image.h"

namespace {

namespace fs = std::filesystem;

// Rewrites the match log in dir as an older version wrote it: sql (the schema's other changes) run on
// its database, then its depth frames as that version held them (from version 5 to 9 zstd on row
// differences in a column depth_zstd, before that PNG in a column png), and its version set.
void rewriteAsOlderVersion(const fs::path& dir, const std::string& sql, int version) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((dir / fw::kMatchLogFile).c_str(), &db), SQLITE_OK);
  EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK) << sql;
  const std::string column = version >= 5 ? "depth_zstd" : "png";
  std::vector<std::tuple<sqlite3_int64, int, int, std::vector<std::uint8_t>>> frames;
  sqlite3_stmt* q = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT seq, width, height, depth FROM depth_frame", -1, &q, nullptr), SQLITE_OK);
  while (sqlite3_step(q) == SQLITE_ROW) {
    const auto* blob = static_cast<const std::uint8_t*>(sqlite3_column_blob(q, 3));
    frames.emplace_back(sqlite3_column_int64(q, 0), sqlite3_column_int(q, 1), sqlite3_column_int(q, 2),
                        std::vector<std::uint8_t>(blob, blob + sqlite3_column_bytes(q, 3)));
  }
  sqlite3_finalize(q);
  const std::string rename = "ALTER TABLE depth_frame RENAME COLUMN depth TO " + column;
  EXPECT_EQ(sqlite3_exec(db, rename.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
  ASSERT_EQ(
      sqlite3_prepare_v2(db, ("UPDATE depth_frame SET " + column + " = ? WHERE seq = ?").c_str(), -1, &q, nullptr),
      SQLITE_OK);
  fw::DepthEncoder row_differences(fw::DepthCodec::kZstdRowDelta);
  for (const auto& [seq, width, height, bytes] : frames) {
    std::vector<std::uint16_t> depth_mm;
    fw::decodeDepth(fw::DepthCodec::kZstdPalette, bytes.data(), bytes.size(), width, height, depth_mm);
    std::vector<std::uint8_t> old;
    if (version >= 5) {
      const fw::DepthEncoder::Bytes encoded = row_differences.encode(depth_mm.data(), width, height);
      old.assign(encoded.data, encoded.data + encoded.size);
    } else {
      cv::imencode(".png", cv::Mat(height, width, CV_16UC1, depth_mm.data()), old);
    }
    sqlite3_bind_blob(q, 1, old.data(), static_cast<int>(old.size()), SQLITE_TRANSIENT);
    sqlite3_bind_int64(q, 2, seq);
    EXPECT_EQ(sqlite3_step(q), SQLITE_DONE);
    sqlite3_reset(q);
  }
  sqlite3_finalize(q);
  EXPECT_EQ(sqlite3_exec(db, ("PRAGMA user_version=" + std::to_string(version)).c_str(), nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
}

// The SQL that drops columns from a table.
std::string droppingColumns(const std::string& table, const std::vector<std::string>& columns) {
  std::string sql;
  for (const std::string& column : columns) sql += "ALTER TABLE " + table + " DROP COLUMN " + column + "; ";
  return sql;
}

std::string errorOf(const std::string& folder) {
  try {
    fw::MatchLogReader log(folder);
  } catch (const fw::MatchLogError& e) {
    return e.what();
  }
  return "no error";
}

TEST(MatchLog, RoundTripsEveryKindOfPublication) {
  ScopedTempDir dir;
  const std::string folder = (dir.path() / "run").string();
  fw::RunInfo run{"keeper", "0.1.0", "host:\n  robot_name: keeper\n", 1700000000.5, ""};
  fw::BallObservation ball = fw::BallObservation::inRobotFrame({0.1, 2.5, 0.7}, Eigen::Matrix3d::Identity() * 1e-4,
                                                               fw::BallState::kAir, "kinect3d", {100.0, 2000.01});
  ball.covariance_m2(0, 1) = ball.covariance_m2(1, 0) = 2e-5;
  ball.support_points = 310;
  fw::OmniBallObservation omni;
  omni.bearing_rad = 0.3;
  omni.distance_m = 2.2;
  omni.source = "omni";
  fw::BallTrajectory trajectory;
  trajectory.source = "kinect3d";
  trajectory.time_s = 100.0;
  trajectory.position_m = {0.1, 2.5, 0.7};
  trajectory.velocity_mps = {0.0, -4.0, 3.0};
  trajectory.drag_per_m = 0.021;
  trajectory.touchdown = fw::Touchdown{{0.1, 0.4}, 100.7, 0.05};
  fw::FusedBall fused;
  fused.position_F = {1.0, 2.0, 0.5};
  fused.sources = {"kinect3d", "omni"};
  fused.covariance_F(2, 0) = fused.covariance_F(0, 2) = 0.25;
  fused.goal_crossing = fw::GoalCrossing{1, -0.3, 0.6, 100.9, 0.08, 0.03};
  fw::PluginHealth health;
  health.plugin = "kinect3d";
  health.frames = 30;
  health.processing_p99_s = 0.004;
  health.processing_total_s = 0.09;
  health.latency_p50_s = 0.0021;
  health.latency_p99_s = 0.0048;
  health.dropped_frames = 2;
  fw::TeamMessage teammate;
  teammate.team_id = 5;
  teammate.robot_id = 3;
  teammate.sequence = 1700000000123456ull;
  teammate.robot_name = "defender";
  teammate.kinect_balls = {ball};
  teammate.clock_offset_s = -0.8;
  teammate.receive_time_s = 2000.05;
  const std::vector<fw::JournalEntry> written = {
      {1.0, fw::BallFrame{ball.stamp, {ball, ball}, ball.source}},
      {1.1, fw::OmniFrame{{99.9, 2000.02}, {omni}, omni.source}},
      {1.15, fw::OmniFrame{{99.95, 2000.03}, {}, {}}},
      {1.2, trajectory},
      {1.3, fw::TrajectoryCleared{"kinect3d"}},
      {1.4, fused},
      {1.5, fw::FusedBallCleared{{100.1, 2000.04}}},
      {1.6, fw::RobotPose{1.0, -2.0, 0.3, {99.8, 2000.0}, std::nullopt}},
      {1.7, fw::Event{"fusion", "omni_latency", "42 ms", {100.0, 2000.0}, 0.042}},
      {1.8, health},
      {1.85, teammate},
      {1.9, smallDepthImage(0)},
  };
  {
    fw::MatchLogWriter writer(folder, run);
    for (const fw::JournalEntry& entry : written) writer.write(entry);
    writer.write({2.0, smallDepthImage(1)});
    writer.commit();
  }
  const fw::MatchLogReader log(folder);
  EXPECT_EQ(log.run().robot, "keeper");
  EXPECT_EQ(log.run().config_yaml, run.config_yaml);
  EXPECT_DOUBLE_EQ(log.run().start_wall_time_s, 1700000000.5);
  const std::vector<fw::JournalEntry> read = log.entries();
  ASSERT_EQ(read.size(), written.size() - 1);  // the depth is read on its own
  for (std::size_t i = 0; i + 1 < written.size(); ++i) {
    EXPECT_DOUBLE_EQ(read[i].wall_time_s, written[i].wall_time_s) << i;
    EXPECT_EQ(read[i].item.index(), written[i].item.index()) << i;
  }
  const auto& frame = std::get<fw::BallFrame>(read[0].item);
  ASSERT_EQ(frame.balls.size(), 2u);
  EXPECT_TRUE(frame.balls[1].isApprox(ball, 0.0));
  EXPECT_EQ(frame.balls[1].covariance_m2, ball.covariance_m2);
  EXPECT_EQ(frame.balls[1].support_points, 310);
  EXPECT_DOUBLE_EQ(frame.balls[1].stamp.receive_time_s, 2000.01);
  EXPECT_DOUBLE_EQ(std::get<fw::OmniFrame>(read[1].item).balls.at(0).bearing_rad, 0.3);
  EXPECT_TRUE(std::get<fw::OmniFrame>(read[2].item).balls.empty());
  const auto& fit = std::get<fw::BallTrajectory>(read[3].item);
  EXPECT_EQ(fit.velocity_mps, trajectory.velocity_mps);
  EXPECT_DOUBLE_EQ(fit.drag_per_m, 0.021);
  ASSERT_TRUE(fit.touchdown);
  EXPECT_DOUBLE_EQ(fit.touchdown->sigma_m, 0.05);
  EXPECT_FALSE(fit.crossing);
  EXPECT_EQ(std::get<fw::TrajectoryCleared>(read[4].item).source, "kinect3d");
  EXPECT_EQ(std::get<fw::FusedBall>(read[5].item).sources, fused.sources);
  EXPECT_EQ(std::get<fw::FusedBall>(read[5].item).covariance_F, fused.covariance_F);
  const auto& goal_crossing = std::get<fw::FusedBall>(read[5].item).goal_crossing;
  ASSERT_TRUE(goal_crossing);
  EXPECT_EQ(goal_crossing->goal, 1);
  EXPECT_DOUBLE_EQ(goal_crossing->x_m, -0.3);
  EXPECT_DOUBLE_EQ(goal_crossing->z_m, 0.6);
  EXPECT_DOUBLE_EQ(goal_crossing->time_s, 100.9);
  EXPECT_DOUBLE_EQ(goal_crossing->sigma_m, 0.08);
  EXPECT_DOUBLE_EQ(goal_crossing->time_sigma_s, 0.03);
  EXPECT_DOUBLE_EQ(std::get<fw::RobotPose>(read[7].item).theta_rad, 0.3);
  EXPECT_DOUBLE_EQ(std::get<fw::FusedBallCleared>(read[6].item).stamp.source_time_s, 100.1);
  EXPECT_DOUBLE_EQ(std::get<fw::FusedBallCleared>(read[6].item).stamp.receive_time_s, 2000.04);
  EXPECT_EQ(std::get<fw::Event>(read[8].item).kind, "omni_latency");
  EXPECT_EQ(std::get<fw::Event>(read[8].item).value, std::optional<double>(0.042));
  EXPECT_EQ(std::get<fw::PluginHealth>(read[9].item).dropped_frames, 2u);
  EXPECT_DOUBLE_EQ(std::get<fw::PluginHealth>(read[9].item).processing_p99_s, 0.004);
  EXPECT_DOUBLE_EQ(std::get<fw::PluginHealth>(read[9].item).processing_total_s, 0.09);
  EXPECT_DOUBLE_EQ(std::get<fw::PluginHealth>(read[9].item).latency_p50_s, 0.0021);
  EXPECT_DOUBLE_EQ(std::get<fw::PluginHealth>(read[9].item).latency_p99_s, 0.0048);
  const auto& message = std::get<fw::TeamMessage>(read[10].item);
  EXPECT_EQ(message.robot_id, 3);
  EXPECT_EQ(message.sequence, teammate.sequence);
  EXPECT_EQ(message.robot_name, "defender");
  EXPECT_DOUBLE_EQ(message.clock_offset_s, -0.8);
  EXPECT_DOUBLE_EQ(message.receive_time_s, 2000.05);
  ASSERT_EQ(message.kinect_balls.size(), 1u);
  EXPECT_TRUE(message.kinect_balls[0].position_m.isApprox(ball.position_m));

  ASSERT_EQ(log.depthSources(), (std::vector<std::pair<std::string, std::uint64_t>>{{"kinect3d", 2}}));
  fw::MatchLogReader::DepthFrames frames(log, "kinect3d");
  fw::DepthImage image;
  double wall_s = 0.0;
  for (std::uint64_t i = 0; i < 2; ++i) {
    ASSERT_TRUE(frames.next(image, wall_s));
    const fw::DepthImage expected = smallDepthImage(i);
    EXPECT_EQ(image.depth_mm, expected.depth_mm);  // lossless
    EXPECT_EQ(image.index, i);
    EXPECT_DOUBLE_EQ(image.stamp.source_time_s, expected.stamp.source_time_s);
    EXPECT_DOUBLE_EQ(image.fx, 57.5);
  }
  EXPECT_FALSE(frames.next(image, wall_s));
}

TEST(MatchLog, AVersion3LogFromBeforeTheTeamStillReads) {
  ScopedTempDir dir;
  {
    fw::MatchLogWriter writer(dir.path().string(), {});
    writer.write({1.0, fw::RobotPose{1.0, -2.0, 0.3, {99.8, 2000.0}, std::nullopt}});
  }
  ASSERT_NO_FATAL_FAILURE(rewriteAsOlderVersion(dir.path(), "DROP TABLE team_message", 3));
  std::int64_t last_seq = -1;
  const std::vector<fw::JournalEntry> read = fw::MatchLogReader(dir.path().string()).entries(0, &last_seq);
  ASSERT_EQ(read.size(), 1u);
  EXPECT_DOUBLE_EQ(std::get<fw::RobotPose>(read[0].item).y_m, -2.0);
  EXPECT_GT(last_seq, 0);
}

TEST(MatchLog, AVersion6LogFromBeforeTheGoalLineCrossingStillReads) {
  ScopedTempDir dir;
  {
    fw::MatchLogWriter writer(dir.path().string(), {});
    fw::FusedBall ball;
    ball.position_F = {1.0, 2.0, 0.5};
    ball.goal_crossing = fw::GoalCrossing{1, -0.3, 0.6, 100.9, 0.08};
    writer.write({1.0, ball});
  }
  // Made as version 6 wrote it: the world ball's rows without the crossing's columns.
  ASSERT_NO_FATAL_FAILURE(rewriteAsOlderVersion(
      dir.path(),
      droppingColumns("fused_ball", {"goal_line", "goal_crossing_x_m", "goal_crossing_z_m", "goal_crossing_time_s",
                                     "goal_crossing_sigma_m", "goal_crossing_time_sigma_s"}),
      6));
  const std::vector<fw::JournalEntry> read = fw::MatchLogReader(dir.path().string()).entries();
  ASSERT_EQ(read.size(), 1u);
  const auto& ball = std::get<fw::FusedBall>(read[0].item);
  EXPECT_DOUBLE_EQ(ball.position_F.y(), 2.0);
  EXPECT_FALSE(ball.goal_crossing);
}

TEST(MatchLog, ThePosesOdometryIsKeptAndAVersion7LogsPosesReadWithout) {
  ScopedTempDir dir;
  {
    fw::MatchLogWriter writer(dir.path().string(), {});
    fw::RobotPose with{1.0, 2.0, 0.5, {10.0, 10.01}, fw::RobotPose::Odometry{-3.0, 4.5, 7.25}};
    fw::RobotPose without{1.1, 2.1, 0.6, {10.1, 10.11}, std::nullopt};
    writer.write({1.0, with});
    writer.write({1.1, without});
  }
  {
    const std::vector<fw::JournalEntry> read = fw::MatchLogReader(dir.path().string()).entries();
    ASSERT_EQ(read.size(), 2u);
    const auto& with = std::get<fw::RobotPose>(read[0].item);
    ASSERT_TRUE(with.odometry);
    EXPECT_DOUBLE_EQ(with.odometry->x_m, -3.0);
    EXPECT_DOUBLE_EQ(with.odometry->y_m, 4.5);
    EXPECT_DOUBLE_EQ(with.odometry->theta_rad, 7.25);
    EXPECT_DOUBLE_EQ(with.theta_rad, 0.5);
    EXPECT_FALSE(std::get<fw::RobotPose>(read[1].item).odometry);
  }
  // Made as version 7 wrote it: the poses' rows without the odometry's columns.
  ASSERT_NO_FATAL_FAILURE(rewriteAsOlderVersion(
      dir.path(), droppingColumns("robot_pose", {"odometry_x_m", "odometry_y_m", "odometry_theta_rad"}), 7));
  const std::vector<fw::JournalEntry> read = fw::MatchLogReader(dir.path().string()).entries();
  ASSERT_EQ(read.size(), 2u);
  const auto& pose = std::get<fw::RobotPose>(read[0].item);
  EXPECT_DOUBLE_EQ(pose.y_m, 2.0);
  EXPECT_FALSE(pose.odometry);
}

TEST(MatchLog, TheRobotsAnOmniImageSawAreKeptAndAVersion8LogsImagesReadWithout) {
  ScopedTempDir dir;
  {
    fw::MatchLogWriter writer(dir.path().string(), {});
    fw::OmniFrame image{{10.0, 10.01}, {}, "omni"};
    image.robots = {{0.4, 3.5, 0.17, 0.01}, {-2.0, 6.25, 0.28, 0.01}};
    writer.write({1.0, image});
  }
  {
    const std::vector<fw::JournalEntry> read = fw::MatchLogReader(dir.path().string()).entries();
    ASSERT_EQ(read.size(), 1u);
    const auto& robots = std::get<fw::OmniFrame>(read[0].item).robots;
    ASSERT_EQ(robots.size(), 2u);
    EXPECT_DOUBLE_EQ(robots[1].bearing_rad, -2.0);
    EXPECT_DOUBLE_EQ(robots[1].distance_m, 6.25);
    EXPECT_DOUBLE_EQ(robots[1].distance_sigma_m, 0.28);
    EXPECT_DOUBLE_EQ(robots[1].bearing_sigma_rad, 0.01);
  }
  // Made as version 8 wrote it: no table of robots.
  ASSERT_NO_FATAL_FAILURE(rewriteAsOlderVersion(dir.path(), "DROP TABLE omni_robot", 8));
  const std::vector<fw::JournalEntry> read = fw::MatchLogReader(dir.path().string()).entries();
  ASSERT_EQ(read.size(), 1u);
  EXPECT_TRUE(std::get<fw::OmniFrame>(read[0].item).robots.empty());
}

// Version 4 held its depth as PNG, versions 5 to 9 as zstd on row differences.
TEST(MatchLog, LogsWithTheDepthCodecsOfVersions4And9StillRead) {
  for (const int version : {4, 9}) {
    ScopedTempDir dir;
    {
      fw::MatchLogWriter writer(dir.path().string(), {});
      for (std::uint64_t i = 0; i < 3; ++i) writer.write({1.0 + i, smallDepthImage(i)});
    }
    ASSERT_NO_FATAL_FAILURE(rewriteAsOlderVersion(dir.path(), "", version));
    const fw::MatchLogReader log(dir.path().string());
    fw::MatchLogReader::DepthFrames frames(log, "kinect3d");
    fw::DepthImage image;
    double wall_s = 0.0;
    for (std::uint64_t i = 0; i < 3; ++i) {
      ASSERT_TRUE(frames.next(image, wall_s)) << "version " << version;
      EXPECT_EQ(image.depth_mm, smallDepthImage(i).depth_mm) << "version " << version << ", frame " << i;
    }
    EXPECT_FALSE(frames.next(image, wall_s));
    EXPECT_EQ(log.depthFrame(log.depthFrameStamps("kinect3d").at(1).seq).depth_mm, smallDepthImage(1).depth_mm)
        << "version " << version;
  }
}

TEST(MatchLog, ColourIsKeptAtTheJpegQualityItIsGiven) {
  fw::DepthImage image = smallDepthImage(0);
  fw::ColourImage colour;
  colour.width = 64;
  colour.height = 48;
  colour.rgb.resize(64 * 48 * 3);
  for (std::size_t i = 0; i < colour.rgb.size(); ++i) colour.rgb[i] = static_cast<std::uint8_t>((i * 37) % 251);
  image.colour = colour;
  ScopedTempDir dir;
  const auto logged = [&](int quality) {
    const std::string folder = (dir.path() / std::to_string(quality)).string();
    { fw::MatchLogWriter(folder, {}, quality).write({1.0, image}); }
    sqlite3* db = nullptr;
    EXPECT_EQ(sqlite3_open((folder + "/match.sqlite").c_str(), &db), SQLITE_OK);
    sqlite3_stmt* size = nullptr;
    sqlite3_prepare_v2(db, "SELECT length(jpeg) FROM colour_frame", -1, &size, nullptr);
    EXPECT_EQ(sqlite3_step(size), SQLITE_ROW);
    const int bytes = sqlite3_column_int(size, 0);
    sqlite3_finalize(size);
    sqlite3_close(db);
    const fw::DepthImage read = fw::MatchLogReader(folder).depthFrame(1);
    EXPECT_TRUE(read.colour.has_value()) << quality;
    return bytes;
  };
  EXPECT_LT(logged(30), logged(95));
  try {
    fw::MatchLogWriter((dir.path() / "zero").string(), {}, 0);
    ADD_FAILURE() << "a quality of 0 was taken";
  } catch (const fw::MatchLogError& e) {
    EXPECT_NE(std::string(e.what()).find("zero: a colour JPEG quality of 0 (1 to 100)"), std::string::npos) << e.what();
  }
  // The writer's default is the logger's shipped one.
  const fw::Config shipped = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", "", {});
  EXPECT_EQ(shipped.block("logger").getInt("colour_jpeg_quality", 1, 100),
            fw::MatchLogWriter::kDefaultColourJpegQuality);
}

TEST(MatchLog, NeverWritesOverAnotherLog) {
  ScopedTempDir dir;
  { fw::MatchLogWriter first(dir.path().string(), {}); }
  EXPECT_THROW(fw::MatchLogWriter(dir.path().string(), {}), fw::MatchLogError);
}

TEST(MatchLog, ABadLogIsNamedWithItsFileAndWhatIsWrong) {
  ScopedTempDir dir;
  const fs::path file = dir.path() / "match.sqlite";
  EXPECT_NE(errorOf((dir.path() / "nowhere").string()).find("nowhere/match.sqlite: no match log here (no such folder)"),
            std::string::npos);
  EXPECT_NE(errorOf(dir.path().string()).find("match.sqlite: no match log here (the folder has no match.sqlite)"),
            std::string::npos);

  std::ofstream(file) << std::string(8192, 'x');
  EXPECT_NE(errorOf(dir.path().string()).find(file.string() + ": file is not a database"), std::string::npos)
      << errorOf(dir.path().string());
  fs::remove(file);

  {
    fw::MatchLogWriter writer(dir.path().string(), {});
    for (int i = 0; i < 200; ++i) writer.write({i * 1.0, smallDepthImage(i)});
  }
  fs::remove(file.string() + "-wal");
  fs::resize_file(file, fs::file_size(file) / 2);  // a copy cut short
  const std::string truncated = errorOf(dir.path().string());
  EXPECT_EQ(truncated.rfind(file.string() + ": ", 0), 0u) << truncated;
  EXPECT_NE(truncated.find("malformed"), std::string::npos) << truncated;
  fs::remove(file);

  { fw::MatchLogWriter writer(dir.path().string(), {}); }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  sqlite3_exec(db, "PRAGMA user_version=99", nullptr, nullptr, nullptr);
  sqlite3_close(db);
  EXPECT_NE(
      errorOf(dir.path().string()).find(file.string() + ": schema version 99, this program reads versions 2 to 10"),
      std::string::npos)
      << errorOf(dir.path().string());
}

class LoggedDemo : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new ScopedTempDir;
    summaries_ = runDemo(dir_->path().string());
    folder_ = onlySubfolder(dir_->path());
  }
  static void TearDownTestSuite() { delete dir_; }
  static ScopedTempDir* dir_;
  static std::vector<fw::PluginSummary> summaries_;
  static std::string folder_;
};
ScopedTempDir* LoggedDemo::dir_ = nullptr;
std::vector<fw::PluginSummary> LoggedDemo::summaries_;
std::string LoggedDemo::folder_;

TEST_F(LoggedDemo, HoldsTheWholeRunInItsOwnFolder) {
  EXPECT_NE(fs::path(folder_).filename().string().find("_demo"), std::string::npos) << folder_;
  const fw::MatchLogReader log(folder_);
  EXPECT_EQ(log.run().robot, "demo");
  EXPECT_NE(log.run().config_yaml.find("sim:lob_over_robot"), std::string::npos);
  const auto entries = log.entries();
  std::map<std::string, std::uint64_t> frames;
  for (const fw::PluginSummary& summary : summaries_) frames[summary.name] = summary.frames;
  // Every frame each plugin processed is in the log.
  ASSERT_EQ(log.depthSources().size(), 1u);
  EXPECT_EQ(log.depthSources()[0].second, frames["kinect3d"]);
  EXPECT_EQ(itemsOf<fw::RobotPose>(entries).size(), frames["localisation"]);
  EXPECT_EQ(itemsOf<fw::OmniFrame>(entries).size(), frames["omni"]);
  EXPECT_GT(itemsOf<fw::BallFrame>(entries).size(), 20u);
  EXPECT_GT(itemsOf<fw::BallTrajectory>(entries).size(), 10u);
  EXPECT_GT(itemsOf<fw::FusedBall>(entries).size(), 50u);
  const auto events = itemsOf<fw::Event>(entries);
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.front().kind, "floor_found");
  // Health once a second for every plugin: the depth plugin's own processing time, not its wait.
  std::map<std::string, int> health_rows;
  std::vector<double> kinect_p50_s;
  std::vector<fw::PluginHealth> fusion_seconds;
  for (const fw::PluginHealth& health : itemsOf<fw::PluginHealth>(entries)) {
    ++health_rows[health.plugin];
    if (health.plugin == "kinect3d" && health.frames > 0) {
      kinect_p50_s.push_back(health.processing_p50_s);
      // The second's total: at least its median frame, at most the second.
      EXPECT_GE(health.processing_total_s, health.processing_p50_s);
      EXPECT_LT(health.processing_total_s, 1.0);
    }
    if (health.plugin == "fusion") {
      // A second with a depth frame in it (one with only omni images has none to measure).
      if (!std::isnan(health.latency_p50_s)) fusion_seconds.push_back(health);
    } else {
      EXPECT_TRUE(std::isnan(health.latency_p50_s)) << health.plugin << " reports no latency";
    }
  }
  // The fusion reports the robot's latency, from a depth frame's arrival to its world ball.
  ASSERT_FALSE(fusion_seconds.empty());
  for (const fw::PluginHealth& second : fusion_seconds) {
    EXPECT_GT(second.latency_p50_s, 0.0);
    EXPECT_GE(second.latency_p99_s, second.latency_p50_s);
  }
  // Over the whole run, in the host's summary: every depth frame the fusion took, each measured once.
  const auto fusion =
      std::find_if(summaries_.begin(), summaries_.end(), [](const auto& s) { return s.name == "fusion"; });
  ASSERT_NE(fusion, summaries_.end());
  EXPECT_LE(fusion->latency_s.count(), frames["kinect3d"]);
  EXPECT_GE(fusion->latency_s.count() + 2, frames["kinect3d"]) << "at most the last frames before the stop unfused";
  EXPECT_GT(fusion->latency_s.quantile(0.5), 0.0);
  EXPECT_GE(fusion->latency_s.quantile(0.99), fusion->latency_s.quantile(0.5));
  ASSERT_GE(kinect_p50_s.size(), 2u);
  // A frame comes every 33 ms; the detector's median on the demo is a few ms even under sanitizers.
  EXPECT_LT(*std::min_element(kinect_p50_s.begin(), kinect_p50_s.end()), 0.030);
  for (const char* plugin : {"localisation", "kinect3d", "omni", "fusion", "logger"}) {
    EXPECT_GE(health_rows[plugin], 2) << plugin;
  }
}

TEST_F(LoggedDemo, ReplayReproducesEveryDetectionTrajectoryEventAndWorldBallTheRobotPublished) {
  ScopedTempDir out;
  const Published live = publishedIn(folder_);
  ASSERT_GT(live.detections.size(), 20u);
  ASSERT_GT(live.world_balls.size(), 100u);
  const Published replayed = publishedIn(replayInto(folder_, out.path()));
  expectSame(live.detections, replayed.detections, "detection");
  expectSame(live.trajectories, replayed.trajectories, "trajectory");
  expectSame(live.events, replayed.events, "event");
  expectSame(live.world_balls, replayed.world_balls, "world ball");
}

TEST_F(LoggedDemo, ReplayGivesTheSameLogTwiceAndChangesOnlyWhatASettingTouches) {
  ScopedTempDir out;
  const std::string a = replayInto(folder_, out.path() / "a"), b = replayInto(folder_, out.path() / "b");
  const std::string c = replayInto(folder_, out.path() / "c", "--set fusion.pose.sigma_xy_m=0.3");
  // Twice: the same log, entry for entry, its wall clock included (a replay stamps the robot's moments).
  const auto entriesA = fw::MatchLogReader(a).entries(), entriesB = fw::MatchLogReader(b).entries();
  ASSERT_EQ(entriesA.size(), entriesB.size());
  for (std::size_t i = 0; i < entriesA.size(); ++i) {
    ASSERT_EQ(entriesA[i].item.index(), entriesB[i].item.index()) << i;
    EXPECT_EQ(entriesA[i].wall_time_s, entriesB[i].wall_time_s) << i;
  }
  expectSame(publishedIn(a).world_balls, publishedIn(b).world_balls, "world ball");
  // A fusion setting changes the world balls and nothing before them.
  const Published publishedA = publishedIn(a), publishedC = publishedIn(c);
  expectSame(publishedA.detections, publishedC.detections, "detection");
  expectSame(publishedA.trajectories, publishedC.trajectories, "trajectory");
  EXPECT_EQ(itemsOf<fw::RobotPose>(fw::MatchLogReader(c).entries()).size(), itemsOf<fw::RobotPose>(entriesA).size());
  // Fusion told that localisation is ten times worse gives less certain world balls.
  const auto fusedA = itemsOf<fw::FusedBall>(entriesA),
             fusedC = itemsOf<fw::FusedBall>(fw::MatchLogReader(c).entries());
  int differ = 0;
  for (std::size_t i = 0; i < std::min(fusedA.size(), fusedC.size()); ++i) {
    differ += (fusedA[i].covariance_F - fusedC[i].covariance_F).norm() > 1e-9;
  }
  EXPECT_GT(differ, 10);
  EXPECT_EQ(fw::MatchLogReader(c).run().replayed_from, folder_);
  EXPECT_TRUE(fw::MatchLogReader(folder_).run().replayed_from.empty());
}

TEST_F(LoggedDemo, ExportsTheFilesTheOtherCommandsRead) {
  ScopedTempDir out;
  const fs::path omni = out.path() / "omni.jsonl", pose = out.path() / "pose.jsonl",
                 detections = out.path() / "detections.jsonl", tum = out.path() / "tum";
  ASSERT_EQ(runCommand(std::string(KINECT3D_EXE) + " export " + folder_ + " --omni " + omni.string() + " --pose " +
                       pose.string() + " --detections " + detections.string() + " --tum " + tum.string() + " 2>&1")
                .first,
            0);
  const fw::MatchLogReader log(folder_);
  const auto entries = log.entries();
  const std::vector<fw::OmniFrame> omni_read = fusion::readOmniFile(omni.string(), "omni");
  ASSERT_EQ(omni_read.size(), itemsOf<fw::OmniFrame>(entries).size());
  // The robots each image saw go with its balls (the demo's lob_over_robot has a robot driving by).
  const std::vector<fw::OmniFrame> omni_logged = itemsOf<fw::OmniFrame>(entries);
  std::size_t robots_logged = 0, robots_read = 0;
  for (std::size_t i = 0; i < omni_read.size(); ++i) {
    robots_logged += omni_logged[i].robots.size();
    robots_read += omni_read[i].robots.size();
  }
  EXPECT_GT(robots_logged, omni_read.size() / 2);
  EXPECT_EQ(robots_read, robots_logged);
  EXPECT_EQ(fusion::readPoseFile(pose.string()).size(), itemsOf<fw::RobotPose>(entries).size());
  // The simulated localisation publishes the wheels' odometry, and the pose file carries it on.
  EXPECT_TRUE(fusion::readPoseFile(pose.string()).back().odometry);
  const auto frames = fusion::readDetectionsFile(detections.string(), "kinect3d");
  ASSERT_EQ(frames.size(), log.depthSources()[0].second);
  std::size_t with_ball = 0;
  for (const fw::BallFrame& frame : frames) with_ball += !frame.balls.empty();
  EXPECT_EQ(with_ball, itemsOf<fw::BallFrame>(entries).size());
  // The TUM folder is a depth source `detect` reads, frame for frame.
  const auto [status, out_lines] =
      runCommand(std::string(KINECT3D_EXE) + " detect --source tum:" + tum.string() + " 2>/dev/null | wc -l");
  ASSERT_EQ(status, 0);
  EXPECT_EQ(std::stoul(out_lines), frames.size());
}

TEST_F(LoggedDemo, TheWholeHostReRunsTheMatchFromItsLog) {
  ScopedTempDir out;
  const std::string source = "log:" + folder_;
  const auto summaries = runDemo(out.path().string(), {"kinect3d.source=" + source, "omni.source=" + source,
                                                       "localisation.source=" + source, "kinect3d.realtime=false"});
  std::map<std::string, std::uint64_t> frames;
  for (const fw::PluginSummary& summary : summaries) frames[summary.name] = summary.frames;
  const fw::MatchLogReader original(folder_);
  const auto entries = original.entries();
  EXPECT_EQ(frames["kinect3d"], original.depthSources().at(0).second);
  EXPECT_EQ(frames["omni"], itemsOf<fw::OmniFrame>(entries).size());
  EXPECT_EQ(frames["localisation"], itemsOf<fw::RobotPose>(entries).size());
  const fw::MatchLogReader rerun(onlySubfolder(out.path()));
  const auto rerun_balls = itemsOf<fw::BallFrame>(rerun.entries());
  EXPECT_GT(rerun_balls.size(), itemsOf<fw::BallFrame>(entries).size() / 2);
  EXPECT_GT(itemsOf<fw::FusedBall>(rerun.entries()).size(), 50u);
}

// Opened as a person would: Debian's Chromium renders the page; the DOM and the picture are checked.
TEST_F(LoggedDemo, MatchReportShowsTheLobToAPersonOpeningIt) {
  ScopedTempDir out;
  ASSERT_EQ(
      runCommand(std::string(KINECT3D_EXE) + " report match " + folder_ + " --out " + out.path().string() + " 2>&1")
          .first,
      0);
  const std::string page = "file://" + (out.path() / "index.html").string();
  const std::string chromium =
      "chromium --headless --no-sandbox --disable-gpu --window-size=1200,2600 --virtual-time-budget=5000 ";
  const auto [status, dom] = runCommand(chromium + "--dump-dom " + page + " 2>/dev/null");
  ASSERT_EQ(status, 0);
  EXPECT_NE(dom.find("data-drawn=\"yes\""), std::string::npos);  // every chart drawn without a script error
  EXPECT_NE(dom.find("Match report: demo"), std::string::npos);
  // The timeline holds every ball each source saw.
  const auto entries = fw::MatchLogReader(folder_).entries();
  std::size_t seen = itemsOf<fw::FusedBall>(entries).size();
  for (const fw::BallFrame& frame : itemsOf<fw::BallFrame>(entries)) seen += frame.balls.size();
  for (const fw::OmniFrame& frame : itemsOf<fw::OmniFrame>(entries)) seen += frame.balls.size();
  EXPECT_NE(dom.find("data-points=\"" + std::to_string(seen) + "\""), std::string::npos);
  EXPECT_NE(dom.find("data-title=\"air at "), std::string::npos);  // the lob is among the flights
  EXPECT_NE(dom.find("floor_found"), std::string::npos);
  for (const char* plugin : {"localisation", "kinect3d", "omni", "fusion", "logger"}) {
    EXPECT_NE(dom.find("<td class=\"text\">" + std::string(plugin) + "</td>"), std::string::npos) << plugin;
  }
  // The fusion's row gives the robot's latency, a number of milliseconds.
  const std::size_t latency = dom.find("data-plugin=\"fusion\" data-latency-p50-ms=\"");
  ASSERT_NE(latency, std::string::npos);
  EXPECT_GT(std::stod(dom.substr(latency + std::string("data-plugin=\"fusion\" data-latency-p50-ms=\"").size())), 0.0);
  const fs::path shot = out.path() / "shot.png";
  ASSERT_EQ(runCommand(chromium + "--screenshot=" + shot.string() + " " + page + " 2>/dev/null").first, 0);
  const cv::Mat picture = cv::imread(shot.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(picture.empty());
  // The depth sensor's balls are drawn in their red (#d62728) in the timeline, the height and the flights.
  cv::Mat red;
  cv::inRange(picture, cv::Scalar(30, 30, 200), cv::Scalar(50, 50, 225), red);
  EXPECT_GT(cv::countNonZero(red), 2000);
}

TEST(MatchLog, ADepthFrameOfNoSensorsSizeIsRefusedBeforeItIsDecoded) {
  ScopedTempDir dir;
  const std::string folder = (dir.path() / "run").string();
  {
    fw::MatchLogWriter writer(folder, {});
    for (std::uint64_t i = 0; i < 3; ++i) writer.write({1.0 + i, smallDepthImage(i)});
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((folder + "/match.sqlite").c_str(), &db), SQLITE_OK);
  // Frame 1 claims 10000x10000 (880 MB to decode, were it believed); frame 2's image is not the size
  // its row says.
  ASSERT_EQ(sqlite3_exec(db,
                         "UPDATE depth_frame SET width = 10000, height = 10000 WHERE frame_index = 1;"
                         "UPDATE depth_frame SET width = 32 WHERE frame_index = 2;",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  const fw::MatchLogReader log(folder);
  fw::MatchLogReader::DepthFrames frames(log, "kinect3d");
  fw::DepthImage image;
  double wall_s = 0.0;
  ASSERT_TRUE(frames.next(image, wall_s));
  try {
    frames.next(image, wall_s);
    ADD_FAILURE() << "a 10000x10000 frame was read";
  } catch (const fw::MatchLogError& e) {
    EXPECT_NE(std::string(e.what()).find("depth frame 1 (seq 2): 10000x10000 is no depth sensor's size (each side 8 "
                                         "to 4096 pixels)"),
              std::string::npos)
        << e.what();
  }
  const auto frame2 = log.depthFrameStamps("kinect3d").at(2).seq;
  try {
    log.depthFrame(frame2);
    ADD_FAILURE() << "a frame whose image is not its row's size was read";
  } catch (const fw::MatchLogError& e) {
    EXPECT_NE(
        std::string(e.what()).find("depth frame 2 (seq 3): its depth is not a 32x48 image (it holds more pixels)"),
        std::string::npos)
        << e.what();
  }
}

TEST(MatchLog, StampsThatAreNotFiniteAreRefusedOneByOneOrSkippedByTheLogSource) {
  ScopedTempDir dir;
  const std::string folder = (dir.path() / "run").string();
  {
    fw::MatchLogWriter writer(folder, {});
    std::uint64_t index = 0;
    for (const double stamp_s : {0.0, std::numeric_limits<double>::quiet_NaN(), HUGE_VAL, -HUGE_VAL, 0.1}) {
      fw::DepthImage image = smallDepthImage(index++);
      image.stamp.source_time_s = stamp_s;
      if (std::isnan(stamp_s)) {
        // SQLite keeps no NaN: this one publication is refused, the batch goes on.
        EXPECT_THROW(writer.write({1.0, image}), fw::MatchLogRefused);
        continue;
      }
      writer.write({1.0, image});
    }
  }
  const auto source = kinect3d::DepthSourceTable::core().open("log:" + folder);
  kinect3d::DepthFrame frame;
  std::vector<double> stamps;
  for (kinect3d::ReadResult result; (result = source->read(frame)) != kinect3d::ReadResult::kEnd;) {
    if (result == kinect3d::ReadResult::kFrame) stamps.push_back(frame.source_time_s);
  }
  EXPECT_EQ(stamps, (std::vector<double>{0.0, 0.1})) << "the two frames that can be placed in time";
  EXPECT_EQ(source->counters().skipped, 2u);
}

TEST(MatchLog, AnImageWhosePixelsDoNotFillItsSizeIsRefusedAndTheNextIsKept) {
  ScopedTempDir dir;
  const std::string folder = (dir.path() / "run").string();
  {
    fw::MatchLogWriter writer(folder, {});
    fw::DepthImage short_depth = smallDepthImage(0);
    short_depth.depth_mm.pop_back();
    fw::DepthImage short_colour = smallDepthImage(1);
    fw::ColourImage colour;
    colour.width = short_colour.width;
    colour.height = short_colour.height;
    colour.rgb.assign(static_cast<std::size_t>(colour.width) * colour.height * 3 - 1, 128);
    short_colour.colour = colour;
    for (const fw::DepthImage* image : {&short_depth, &short_colour}) {
      try {
        writer.write({1.0, *image});
        ADD_FAILURE() << "frame " << image->index << " was taken";
      } catch (const fw::MatchLogRefused& e) {
        EXPECT_NE(std::string(e.what()).find("(frame " + std::to_string(image->index) +
                                             ") not recorded: its pixels do not fill its size"),
                  std::string::npos)
            << e.what();
      }
    }
    writer.write({1.0, smallDepthImage(2)});
  }
  const fw::MatchLogReader log(folder);
  const auto stamps = log.depthFrameStamps("kinect3d");
  ASSERT_EQ(stamps.size(), 1u);
  EXPECT_EQ(log.depthFrame(stamps.at(0).seq).depth_mm, smallDepthImage(2).depth_mm);
}

TEST(Logger, StopsAtItsBudgetLoudlyAndDetectionGoesOn) {
  ScopedTempDir dir;
  const auto summaries = runDemo(dir.path().string(), {"logger.budget_mb=1"});
  std::map<std::string, std::uint64_t> frames;
  for (const fw::PluginSummary& summary : summaries) {
    EXPECT_EQ(summary.errors, 0u) << summary.name;
    frames[summary.name] = summary.frames + summary.dropped_frames;
  }
  EXPECT_EQ(frames["kinect3d"], 105u);  // every frame of the scene, detected or dropped by the source on a busy machine
  const fw::MatchLogReader log(onlySubfolder(dir.path()));
  const auto events = itemsOf<fw::Event>(log.entries());
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().kind, "recording_stopped");
  EXPECT_NE(events.back().message.find("budget"), std::string::npos) << events.back().message;
  ASSERT_EQ(log.depthSources().size(), 1u);
  EXPECT_LT(log.depthSources()[0].second, 60u);
  EXPECT_GT(log.depthSources()[0].second, 0u);
}

TEST(Logger, AHostKilledMidRunLeavesALogThatOpensWithEveryCommittedBatch) {
  ScopedTempDir dir;
  HostProcess host({"--robot", std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml", "--plugin-dir",
                    PRODUCT_PLUGIN_DIR, "--set", "host.plugins=[localisation, kinect3d, omni, fusion, logger]", "--set",
                    "logger.folder=" + dir.path().string()});
  // Killed once the log holds 30 depth frames, however long that takes on this machine.
  std::uint64_t committed = 0;
  for (const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
       committed < 30 && std::chrono::steady_clock::now() < deadline;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    host.drainOutput();
    try {
      const auto sources = fw::MatchLogReader(onlySubfolder(dir.path())).depthSources();
      committed = sources.empty() ? 0 : sources[0].second;
    } catch (const std::exception&) {
      // not there yet
    }
  }
  ASSERT_GE(committed, 30u) << "the log never held 30 depth frames";
  host.signal(SIGKILL);
  ASSERT_EQ(host.waitExit(std::chrono::seconds(60)), 128 + SIGKILL);

  const fw::MatchLogReader log(onlySubfolder(dir.path()));  // opens cleanly
  ASSERT_FALSE(log.entries().empty());
  ASSERT_EQ(log.depthSources().size(), 1u);
  fw::MatchLogReader::DepthFrames frames(log, "kinect3d");
  fw::DepthImage image;
  double wall_s = 0.0;
  std::uint64_t count = 0;
  while (frames.next(image, wall_s)) ++count;
  EXPECT_GE(count, committed) << "every batch committed before the kill is there, depth included";
}

}  // namespace
