#include <gtest/gtest.h>

#include <chrono>

#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <fstream>
#include <thread>

#include "framework_api/types.h"
#include "kinect3d/depth_source.h"
#include "kinect3d/kinect_disparity.h"
#include "kinect3d/sim/kinect_simulator.h"
#include "kinect3d/sim/sequence_writer.h"
#include "kinect3d/sim/sim_sources.h"
#include "real_data.h"
#include "scoped_temp_dir.h"

namespace {

namespace fs = std::filesystem;
using kinect3d::DepthFrame;
using kinect3d::DepthSourceError;
using kinect3d::ReadResult;

// A TUM depth image of the project's own (tests/data is for generated data): 640x480 at TUM's
// 5000 units per metre, a floor seen from 1.5 m at the top row to 9 m at the bottom, the left 64
// columns without depth (a tenth of the pixels, as Kinect frames have).
constexpr double kFrameNear_m = 1.5, kFrameFar_m = 9.0, kFrameInvalid = 0.1;
std::string writeTumFrame(const fs::path& file) {
  cv::Mat depth(480, 640, CV_16UC1, cv::Scalar(0));
  for (int v = 0; v < depth.rows; ++v) {
    const double z_m = kFrameNear_m + (kFrameFar_m - kFrameNear_m) * v / (depth.rows - 1);
    depth.row(v).colRange(64, depth.cols).setTo(cv::Scalar(std::lround(5000.0 * z_m)));
  }
  cv::imwrite(file.string(), depth);
  return file.string();
}

class TumDir : public ::testing::Test {
 protected:
  void write(const std::string& name, const std::string& text) { std::ofstream(dir_ / name) << text; }
  std::string errorOpening() {
    try {
      auto source = kinect3d::sim::sourcesWithSimulator().open("tum:" + dir_.string());
      DepthFrame frame;
      while (source->read(frame) == ReadResult::kFrame) {
      }
    } catch (const DepthSourceError& e) {
      return e.what();
    }
    ADD_FAILURE() << "expected a DepthSourceError";
    return "";
  }
  // A sequence of one image, opened by its bare folder path: its frame, at its stamp, with TUM's
  // default intrinsics (no camera.yaml), and then the end.
  DepthFrame readTheOnlyFrame(const std::string& image) {
    write("depth.txt", "# one frame\n1305031102.160407 " + image + "\n");
    auto source = kinect3d::sim::sourcesWithSimulator().open(dir_.string());
    DepthFrame frame, after;
    EXPECT_EQ(source->read(frame), ReadResult::kFrame);
    EXPECT_EQ(frame.width(), 640);
    EXPECT_EQ(frame.intrinsics.fx, 525.0) << "TUM default intrinsics without camera.yaml";
    EXPECT_DOUBLE_EQ(frame.source_time_s, 1305031102.160407);
    EXPECT_EQ(source->read(after), ReadResult::kEnd);
    return frame;
  }

  ScopedTempDir temp_;
  const fs::path dir_ = temp_.path();
  const std::string frame_ = writeTumFrame(dir_ / "frame.png");
};

TEST_F(TumDir, ReadsAFrameAtItsStampWithTumsDefaults) {
  const kinect3d::DepthStats stats = kinect3d::computeStats(readTheOnlyFrame(frame_));
  EXPECT_NEAR(stats.invalid_fraction, kFrameInvalid, 1e-9);
  EXPECT_NEAR(stats.min_m, kFrameNear_m, 1e-3);
  EXPECT_NEAR(stats.max_m, kFrameFar_m, 1e-3);
}

TEST_F(TumDir, ReadsTheRealKinectFrame) {
  const std::optional<std::string> real = realDataFile("real-depth/tum_depth.png");
  if (!real) GTEST_SKIP() << noRealData("real-depth/tum_depth.png");
  const DepthFrame frame = readTheOnlyFrame(*real);
  const kinect3d::DepthStats stats = kinect3d::computeStats(frame);
  EXPECT_NEAR(stats.invalid_fraction, 0.19, 0.01);
  EXPECT_NEAR(stats.min_m, 1.46, 0.01);
  EXPECT_NEAR(stats.max_m, 9.33, 0.01);
  const cv::Mat raw = cv::imread(*real, cv::IMREAD_UNCHANGED);
  EXPECT_EQ(frame.at(320, 240), std::lround(raw.at<std::uint16_t>(240, 320) / 5.0));
}

TEST_F(TumDir, CameraFileSetsIntrinsicsAndScale) {
  write("depth.txt", "0.0 " + frame_ + "\n");
  write("camera.yaml", "width: 640\nheight: 480\nfx: 591.1\nfy: 590.1\ncx: 331.0\ncy: 234.0\ndepth_scale: 2500\n");
  auto source = kinect3d::sim::sourcesWithSimulator().open("tum:" + dir_.string());
  DepthFrame frame;
  ASSERT_EQ(source->read(frame), ReadResult::kFrame);
  EXPECT_DOUBLE_EQ(frame.intrinsics.fx, 591.1);
  EXPECT_NEAR(kinect3d::computeStats(frame).max_m, 2 * kFrameFar_m, 1e-3);
}

TEST_F(TumDir, BadInputNamesTheFileAndLine) {
  write("depth.txt", "0.0 a.png\nnot-a-line\n");
  EXPECT_NE(errorOpening().find("depth.txt:2: expected 'timestamp filename'"), std::string::npos);
  write("depth.txt", "0.0 a.png extra\n");
  EXPECT_NE(errorOpening().find("depth.txt:1:"), std::string::npos);
  write("depth.txt", "# nothing\n");
  EXPECT_NE(errorOpening().find("lists no frames"), std::string::npos);
  write("depth.txt", "0.0 " + frame_ + "\n");
  write("camera.yaml", "width: 640\nheight: 480\nfx: 5\nfy: 500\ncx: 320\ncy: 240\ndepth_scale: 5000\n");
  EXPECT_NE(errorOpening().find("camera.yaml:3: fx = 5 is out of range"), std::string::npos);
  write("camera.yaml", "width: 640\nheigth: 480\n");
  EXPECT_NE(errorOpening().find("camera.yaml:2: heigth is an unknown key"), std::string::npos);
  fs::remove(dir_ / "depth.txt");
  EXPECT_NE(errorOpening().find("has no depth.txt"), std::string::npos);
}

TEST_F(TumDir, RealTimePacingDoesNotSleepThroughAJumpInTheTimeStamps) {
  write("depth.txt", "0.0 " + frame_ + "\n0.033 " + frame_ + "\n1000.066 " + frame_ + "\n1000.1 " + frame_ + "\n");
  kinect3d::SourceOptions options;
  options.realtime = true;
  auto source = kinect3d::DepthSourceTable::core().open("tum:" + dir_.string(), options);
  DepthFrame frame;
  const auto start = std::chrono::steady_clock::now();
  int frames = 0;
  while (source->read(frame) == ReadResult::kFrame) ++frames;
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(frames, 4);
  EXPECT_LT(elapsed_s, 5.0) << "paced through the 1000 s jump";
  EXPECT_GT(elapsed_s, 0.05) << "still paced in real time around it";
}

TEST_F(TumDir, RealTimeReadsNeverBlockLongerThanTheirWait) {
  // Half a second between two frames: the reader is handed back control every 0.1 s meanwhile
  // (kNoFrameYet), so a plugin's step stays short and a stop is never held up by pacing.
  write("depth.txt", "0.0 " + frame_ + "\n0.5 " + frame_ + "\n");
  kinect3d::SourceOptions options;
  options.realtime = true;
  auto source = kinect3d::DepthSourceTable::core().open("tum:" + dir_.string(), options);
  DepthFrame frame;
  int frames = 0, waits = 0;
  double longest_call_s = 0.0;
  const auto start = std::chrono::steady_clock::now();
  for (;;) {
    const auto call = std::chrono::steady_clock::now();
    const ReadResult result = source->read(frame);
    longest_call_s =
        std::max(longest_call_s, std::chrono::duration<double>(std::chrono::steady_clock::now() - call).count());
    if (result == ReadResult::kEnd) break;
    frames += result == ReadResult::kFrame;
    waits += result == ReadResult::kNoFrameYet;
  }
  EXPECT_EQ(frames, 2);
  EXPECT_GE(waits, 3);
  EXPECT_LT(longest_call_s, 0.2);
  EXPECT_GT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 0.45);
}

TEST_F(TumDir, StaleTimeStampsAndBlankFramesAreCounted) {
  cv::imwrite((dir_ / "covered.png").string(), cv::Mat(480, 640, CV_16UC1, cv::Scalar(0)));
  write("depth.txt",
        "0.0 " + frame_ + "\n0.033 covered.png\n0.033 " + frame_ + "\n0.01 " + frame_ + "\n0.1 " + frame_ + "\n");
  auto source = kinect3d::DepthSourceTable::core().open("tum:" + dir_.string());
  DepthFrame frame;
  int frames = 0;
  while (source->read(frame) == ReadResult::kFrame) ++frames;
  EXPECT_EQ(frames, 5) << "delivered all the same: the trajectory skips stale frames itself";
  EXPECT_EQ(source->counters().stale_stamps, 2u) << "one repeated, one going backwards";
  EXPECT_EQ(source->counters().blank, 1u);
}

TEST_F(TumDir, UnreadableFramesAreReportedAndSkipped) {
  cv::imwrite((dir_ / "small.png").string(), cv::Mat(240, 320, CV_16UC1, cv::Scalar(1000)));
  cv::imwrite((dir_ / "eight_bit.png").string(), cv::Mat(480, 640, CV_8UC1, cv::Scalar(10)));
  write("depth.txt",
        "0.0 " + frame_ + "\n0.033 small.png\n0.066 missing.png\n0.1 eight_bit.png\n0.133 " + frame_ + "\n");
  auto source = kinect3d::sim::sourcesWithSimulator().open("tum:" + dir_.string());
  DepthFrame frame;
  int frames = 0;
  while (source->read(frame) == ReadResult::kFrame) ++frames;
  EXPECT_EQ(frames, 2);
  EXPECT_EQ(source->counters().skipped, 3u);
  EXPECT_EQ(source->counters().dropped, 0u) << "skipped frames are not dropped frames";

  write("depth.txt", "0.0 small.png\n");
  EXPECT_NE(errorOpening().find("none of the 1 listed frames could be read"), std::string::npos);
}

TEST(DepthSource, UnknownSchemeAndMissingPaths) {
  auto errorOf = [](const std::string& uri) {
    try {
      kinect3d::sim::sourcesWithSimulator().open(uri);
    } catch (const DepthSourceError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(errorOf("kinect:foo").find("unknown depth source scheme 'kinect:'"), std::string::npos);
  EXPECT_NE(errorOf("tum:/nonexistent").find("'/nonexistent' does not exist"), std::string::npos);
  EXPECT_NE(errorOf("/nonexistent/rec.oni").find("recording '/nonexistent/rec.oni' does not exist"), std::string::npos);
  EXPECT_NE(errorOf("sim:no_such_scene").find("no built-in scene 'no_such_scene'"), std::string::npos);
  EXPECT_NE(errorOf("/tmp").find("neither an .oni file nor a folder holding depth.txt or INDEX.txt"),
            std::string::npos);
}

TEST(DepthSourceTable, HoldsOnlyWhatTheApplicationAdds) {
  kinect3d::DepthSourceTable table = kinect3d::DepthSourceTable::core();
  EXPECT_EQ(table.schemes(), (std::vector<std::string>{"fakenect", "freenect", "log", "oni", "openni2", "tum"}));
  try {
    table.open("sim:hung_3m");
    FAIL() << "the core alone opened the simulator";
  } catch (const DepthSourceError& e) {
    EXPECT_NE(std::string(e.what()).find("expected one of fakenect:, freenect:, log:, oni:, openni2:, tum:"),
              std::string::npos)
        << e.what();
  }
  kinect3d::sim::addSimulatorSource(table);
  EXPECT_EQ(table.open("sim:hung_3m")->describe(), "sim:hung_3m");
  EXPECT_THROW(kinect3d::sim::addSimulatorSource(table), std::invalid_argument);
}

TEST(RawDisparity, ConvertsTheRealNyuFrame) {
  const kinect3d::DisparityModel model;
  EXPECT_EQ(model.metres(2047), 0.0);
  EXPECT_NEAR(model.metres(700), 1.0 / (700 * -0.0030711016 + 3.3309495161), 1e-12);
  const ScopedTempDir temp;
  EXPECT_THROW(kinect3d::loadRawDisparityPgm(writeTumFrame(temp.path() / "frame.png")), DepthSourceError)
      << "a PNG is not a raw-disparity PGM";
  const std::optional<std::string> nyu = realDataFile("real-depth/nyu_raw_disparity.pgm");
  if (!nyu) GTEST_SKIP() << noRealData("real-depth/nyu_raw_disparity.pgm");
  const DepthFrame frame = kinect3d::loadRawDisparityPgm(*nyu);
  const kinect3d::DepthStats stats = kinect3d::computeStats(frame);
  EXPECT_NEAR(stats.invalid_fraction, 0.07, 0.02);
  EXPECT_GT(stats.min_m, 0.4);
  EXPECT_LT(stats.max_m, 10.0);
}

TEST(SimSource, DeliversTheSceneThenEnds) {
  auto source = kinect3d::sim::sourcesWithSimulator().open("sim:hung_3m");
  EXPECT_EQ(source->frameCount(), 90u);
  DepthFrame frame;
  std::uint64_t frames = 0;
  double first_t = 0;
  while (source->read(frame) == ReadResult::kFrame) {
    if (frames++ == 0) first_t = frame.source_time_s;
  }
  EXPECT_EQ(frames, 90u);
  EXPECT_NEAR(frame.source_time_s - first_t, 89.0 / 30.0, 1e-6);  // epoch-scale doubles
  EXPECT_EQ(frame.sensor_id, "sim:hung_3m");
}

// In a world several hosts simulate side by side, the simulated Kinect is a live sensor on the wall
// clock: a host that reads it late gets its newest few frames (3, as a driver's buffer holds), not
// a backlog, and what it missed is dropped.
TEST(SimSource, InASharedWorldAHostThatReadsLateGetsTheNewestFrameAndTheMissedOnesAreDropped) {
  kinect3d::SourceOptions options;
  options.realtime = true;
  const double frame_s = 1.0 / 30.0;  // hung_3m's rate
  const double opened_s = fw::wallClockNow_s();
  options.sim_world_start_wall_s = opened_s - 1.5;  // frames 0-45 were taken before this host looked
  auto source = kinect3d::sim::sourcesWithSimulator().open("sim:hung_3m", options);
  DepthFrame frame;
  ASSERT_EQ(source->read(frame), ReadResult::kFrame);
  EXPECT_GE(frame.index, 42u);
  EXPECT_GE(frame.source_time_s, opened_s - 4 * frame_s);
  EXPECT_EQ(source->counters().dropped, 0u);  // frames before the host first read are not its losses

  // The host busy for ten frames' time: the next read is among the newest frames again.
  const std::uint64_t first = frame.index;
  while (fw::wallClockNow_s() < frame.source_time_s + 10 * frame_s) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_EQ(source->read(frame), ReadResult::kFrame);
  EXPECT_GE(frame.index, first + 7);
  EXPECT_EQ(source->counters().dropped, frame.index - first - 1);

  // Every frame to the scene's end is delivered or dropped, in order.
  std::uint64_t last = frame.index;
  while (source->read(frame) == ReadResult::kFrame) {
    EXPECT_GT(frame.index, last);
    last = frame.index;
  }
  EXPECT_EQ(last, 89u);
  EXPECT_EQ(source->counters().frames + source->counters().dropped, 90u - first);
}

// In one host too the simulated Kinect in real time is a live sensor: a host busy for ten frames'
// time (or a renderer slower than the scene) gets one of the newest frames and loses the ones
// between, instead of handing on frames ever further behind the omni camera's images of the same
// moment.
TEST(SimSource, InRealTimeAHostThatReadsLateGetsTheNewestFramesAndTheMissedOnesAreDropped) {
  kinect3d::SourceOptions options;
  options.realtime = true;
  const double frame_s = 1.0 / 30.0;  // hung_3m's rate
  auto source = kinect3d::sim::sourcesWithSimulator().open("sim:hung_3m", options);
  DepthFrame frame;
  ASSERT_EQ(source->read(frame), ReadResult::kFrame);
  const std::uint64_t first = frame.index;
  const double first_due_s = fw::wallClockNow_s();
  while (fw::wallClockNow_s() < first_due_s + 10 * frame_s) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_EQ(source->read(frame), ReadResult::kFrame);
  EXPECT_GE(frame.index, first + 7);
  EXPECT_EQ(source->counters().dropped, frame.index - first - 1);
}

TEST(SimSource, WrittenSequenceReadsBackIdentically) {
  const ScopedTempDir temp;
  const std::string dir = temp.path().string();
  kinect3d::sim::KinectSimulator simulator(kinect3d::sim::loadScene("kick_away"));
  kinect3d::sim::TumSequenceWriter writer(dir);
  std::vector<DepthFrame> written(4);
  std::vector<kinect3d::sim::GroundTruth> truth(4);
  for (int i = 0; i < 4; ++i) {
    simulator.render(i, written[i], truth[i]);
    writer.write(written[i]);
  }
  kinect3d::sim::writeTruthJson(dir + "/truth.json", simulator.scene(), truth);
  auto source = kinect3d::sim::sourcesWithSimulator().open("tum:" + dir);
  DepthFrame frame;
  for (int i = 0; i < 4; ++i) {
    ASSERT_EQ(source->read(frame), ReadResult::kFrame);
    EXPECT_EQ(frame.depth_mm, written[i].depth_mm);
    EXPECT_EQ(frame.intrinsics, written[i].intrinsics);
    EXPECT_NEAR(frame.source_time_s, written[i].source_time_s, 1e-6);
  }
  EXPECT_EQ(source->read(frame), ReadResult::kEnd);
  EXPECT_TRUE(fs::file_size(dir + "/truth.json") > 100);
}

}  // namespace
