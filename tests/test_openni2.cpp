// The OpenNI2 code paths end to end, without a Kinect: the simulator served as an OpenNI2 device
// by kinect3d's driver (build/openni2/OpenNI2/Drivers), recorded with openni::Recorder, played back
// through OpenNI2's own file device.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include "framework_api/host.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/depth_source.h"
#include "kinect3d/oni_recording.h"
#include "kinect3d/sim/kinect_simulator.h"
#include "kinect3d/sim/sim_sources.h"
#include "run_host.h"
#include "scoped_temp_dir.h"

namespace {

namespace fs = std::filesystem;
using kinect3d::DepthFrame;
using kinect3d::ReadResult;

// Up to `count` frames from a source, waiting at most a generous minute in all (a busy machine under a
// sanitizer renders the simulated device's frames slowly; the device may even be reopened meanwhile).
std::vector<DepthFrame> readFrames(kinect3d::DepthSource& source, int count) {
  std::vector<DepthFrame> frames;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  DepthFrame frame;
  while (static_cast<int>(frames.size()) < count && std::chrono::steady_clock::now() < deadline) {
    const ReadResult result = source.read(frame);
    if (result == ReadResult::kEnd) break;
    if (result == ReadResult::kFrame) frames.push_back(frame);
  }
  return frames;
}

std::vector<DepthFrame> simulatorFrames(const std::string& scene, int count) {
  kinect3d::sim::KinectSimulator simulator(kinect3d::sim::loadScene(scene));
  std::vector<DepthFrame> frames(count);
  kinect3d::sim::GroundTruth truth;
  for (int i = 0; i < count; ++i) simulator.render(i, frames[i], truth);
  return frames;
}

class OniRecording : public ::testing::Test {
 protected:
  ScopedTempDir temp_;
  const fs::path dir_ = temp_.path();
};

TEST(OpenNI2Device, DeliversTheSimulatorsFrames) {
  auto source =
      kinect3d::sim::sourcesWithSimulator().open("openni2:" + kinect3d::sim::simulatedDeviceUri("hung_3m", 8));
  EXPECT_EQ(source->frameCount(), 0u) << "a live device has no known length";
  const std::vector<DepthFrame> live = readFrames(*source, 8);
  const std::vector<DepthFrame> expected = simulatorFrames("hung_3m", 8);
  ASSERT_EQ(live.size(), 8u);
  for (std::size_t i = 0; i < live.size(); ++i) {
    EXPECT_EQ(live[i].depth_mm, expected[i].depth_mm) << "frame " << i;
    EXPECT_EQ(live[i].index, i + 1) << "OpenNI2 counts frames from 1";
  }
  // Intrinsics come back from the stream's field of view.
  EXPECT_NEAR(live[0].intrinsics.fx, 575.8, 0.01);
  EXPECT_NEAR(live[0].intrinsics.cx, 319.5, 1e-9);
  EXPECT_NEAR(live[1].source_time_s - live[0].source_time_s, 1.0 / 30.0, 1e-5);
  EXPECT_EQ(source->counters().dropped, 0u);
}

TEST_F(OniRecording, RecordingPlaysBackIdentically) {
  const std::string path = (dir_ / "hung_3m.oni").string();
  kinect3d::recordOni(kinect3d::sim::simulatedDeviceUri("hung_3m", 10), path, 10, 10.0);
  auto playback = kinect3d::sim::sourcesWithSimulator().open(path);
  EXPECT_EQ(playback->describe(), "oni:" + path);
  EXPECT_EQ(playback->frameCount(), 10u);
  const std::vector<DepthFrame> played = readFrames(*playback, 20);
  const std::vector<DepthFrame> expected = simulatorFrames("hung_3m", 10);
  ASSERT_EQ(played.size(), 10u) << "and then the end of the recording";
  for (std::size_t i = 0; i < played.size(); ++i) EXPECT_EQ(played[i].depth_mm, expected[i].depth_mm) << "frame " << i;
  DepthFrame frame;
  EXPECT_EQ(playback->read(frame), ReadResult::kEnd);

  // The detector reads a recording like any other source.
  kinect3d::DetectorConfig config;
  config.ground.pose = fw::SensorPose{0.0, 0.0, 0.7, 0.0, 0.0, 0.0};
  kinect3d::BallDetector detector(config, "kinect3d");
  kinect3d::Detections detections;
  detector.detect(played[5], detections);
  ASSERT_EQ(detections.balls.size(), 1u);
  EXPECT_LT((detections.balls[0].position_m - Eigen::Vector3d(0.0, 3.0, 1.0)).norm(), 0.03);
}

TEST_F(OniRecording, TruncatedRecordingIsAnErrorNamingTheFile) {
  const std::string path = (dir_ / "full.oni").string();
  kinect3d::recordOni(kinect3d::sim::simulatedDeviceUri("hung_3m", 6), path, 6, 10.0);
  const std::string cut = (dir_ / "cut.oni").string();
  {
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 3);
  }
  try {
    auto playback = kinect3d::sim::sourcesWithSimulator().open("oni:" + cut);
    readFrames(*playback, 10);
    FAIL() << "a truncated recording must not read as complete";
  } catch (const kinect3d::DepthSourceError& e) {
    EXPECT_NE(std::string(e.what()).find(cut), std::string::npos) << e.what();
  }
}

// A recording of `frames` frames of hung_3m whose frame record `damaged` (0-based) has its header
// overwritten: OpenNI2's player then retries that record for ever and delivers nothing more.
std::string recordingWithADamagedFrame(const fs::path& dir, int frames, int damaged) {
  const std::string path = (dir / "damaged.oni").string();
  kinect3d::recordOni(kinect3d::sim::simulatedDeviceUri("hung_3m", frames), path, frames, 10.0);
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  // Every record starts "NIR\0"; a depth frame's is the one followed by tens of kilobytes.
  const std::string magic("NIR\0", 4);
  std::vector<std::size_t> frame_records;
  for (std::size_t at = bytes.find(magic); at != std::string::npos;) {
    const std::size_t next = bytes.find(magic, at + 1);
    if (next != std::string::npos && next - at > 10'000) frame_records.push_back(at);
    at = next;
  }
  if (static_cast<int>(frame_records.size()) != frames) throw std::runtime_error("unexpected .oni layout");
  bytes.replace(frame_records[damaged], 4, "XXXX");
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  return path;
}

TEST_F(OniRecording, ADamagedFrameIsAnErrorNamingItNotAWaitForEver) {
  const std::string path = recordingWithADamagedFrame(dir_, 6, 3);
  auto playback = kinect3d::sim::sourcesWithSimulator().open(path);
  DepthFrame frame;
  int delivered = 0;
  try {
    // Without a bound on the wait this read never returns (and the test times out).
    for (ReadResult result; (result = playback->read(frame)) != ReadResult::kEnd;) {
      if (result == ReadResult::kFrame) ++delivered;
    }
    FAIL() << "a damaged recording must not read as complete";
  } catch (const kinect3d::DepthSourceError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("oni:" + path + ": frame 4 of 6"), std::string::npos) << message;
    EXPECT_NE(message.find("damaged"), std::string::npos) << message;
  }
  EXPECT_EQ(delivered, 3) << "the frames before the damage";
}

TEST_F(OniRecording, TheHostGivesUpOnADamagedRecordingAndSaysWhere) {
  const std::string path = recordingWithADamagedFrame(dir_, 6, 3);
  const fw::Config config = fw::Config::load(
      std::string(PROJECT_CONFIG_DIR) + "/defaults", std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml",
      {"host.plugins=[kinect3d]", "kinect3d.source=oni:" + path, "kinect3d.realtime=false"});
  fw::Host host(config, PRODUCT_PLUGIN_DIR);
  runUntilSourcesEnd(host);
  ASSERT_TRUE(host.sourcesFinished()) << "the host still waits on the damaged frame";
  const fw::PluginSummary kinect = host.summaries().at(0);  // summaries() is a copy
  EXPECT_EQ(kinect.frames, 3u);
  EXPECT_TRUE(kinect.gave_up);
  EXPECT_EQ(kinect.stuck, 0u) << "each read waits a slice at a time";
  EXPECT_NE(kinect.last_error.find("frame 4 of 6"), std::string::npos) << kinect.last_error;
}

TEST(OpenNI2Device, CountsDroppedFrames) {
  // Every 4th frame of 12 never arrives: indices 4, 8 and 12. The first two show as gaps.
  auto source = kinect3d::sim::sourcesWithSimulator().open("openni2:kinect3d-sim://hung_3m?frames=12&drop=4");
  const std::vector<DepthFrame> frames = readFrames(*source, 9);
  ASSERT_EQ(frames.size(), 9u);
  EXPECT_EQ(frames[3].index, 5u);
  EXPECT_EQ(source->counters().dropped, 2u);
  EXPECT_EQ(source->counters().frames, 9u);
}

TEST(OpenNI2Device, DeliversTheColourStreamPairedByTimeWithTheBallWhereTheDepthPutsIt) {
  kinect3d::SourceOptions options;
  options.colour = true;
  auto source = kinect3d::sim::sourcesWithSimulator().open("openni2:kinect3d-sim://hung_3m?frames=300", options);
  // How many depth frames pair depends on the machine: the streams start on their own threads, the
  // depth frames queued before the colour stream's first frame have none, and a slow (sanitized,
  // busy) reader may see the device go quiet and reopen it. So frames are read until five came with
  // their colour, under a generous deadline, not a fixed number of them.
  std::vector<DepthFrame> with_colour;
  int read = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  DepthFrame frame;
  while (with_colour.size() < 5 && std::chrono::steady_clock::now() < deadline) {
    const ReadResult result = source->read(frame);
    if (result == ReadResult::kEnd) break;
    if (result != ReadResult::kFrame) continue;
    ++read;
    if (frame.colour) with_colour.push_back(frame);
  }
  ASSERT_EQ(with_colour.size(), 5u) << "of " << read << " depth frames";
  const Eigen::Vector3d ball_S(0.0, 0.7 - 1.0, 3.0);  // hung_3m: the ball 3 m ahead, 1 m up; the sensor 0.7 m up
  for (const DepthFrame& paired : with_colour) {
    const fw::ColourImage& colour = *paired.colour;
    // A reader that lags behind the device still gets each frame's own colour: pairing is by time.
    EXPECT_LE(std::abs(colour.source_time_s - paired.source_time_s), 1.5 / 30.0);
    // The simulated device is unregistered: the colour camera 2.5 cm to the right, fx about 525.
    EXPECT_NEAR(colour.offset_S_m.x(), 0.025, 1e-9);
    EXPECT_NEAR(colour.fx, 525.0, 1.0);
    const Eigen::Vector3d p_C = ball_S - colour.offset_S_m;
    const int u = static_cast<int>(std::lround(colour.cx + colour.fx * p_C.x() / p_C.z()));
    const int v = static_cast<int>(std::lround(colour.cy + colour.fy * p_C.y() / p_C.z()));
    const std::uint8_t* rgb = &colour.rgb[(static_cast<std::size_t>(v) * colour.width + u) * 3];
    EXPECT_TRUE(rgb[0] > 150 && rgb[1] < 150 && rgb[2] < 80)
        << "the ball's centre, projected through the colour camera, is orange: " << int(rgb[0]) << " " << int(rgb[1])
        << " " << int(rgb[2]);
  }
  kinect3d::SourceOptions depth_only;
  auto without = kinect3d::sim::sourcesWithSimulator().open("openni2:kinect3d-sim://hung_3m?frames=3", depth_only);
  const std::vector<DepthFrame> plain = readFrames(*without, 3);
  ASSERT_EQ(plain.size(), 3u);
  EXPECT_FALSE(plain.back().colour.has_value()) << "colour off: the stream is not opened";
}

TEST(OpenNI2Device, QuietDeviceIsReopenedWithoutStoppingTheReader) {
  // The device sends 3 frames and goes quiet, as an unplugged Kinect does; after a second of
  // silence the source reopens it and frames flow again, counted from the start.
  auto source = kinect3d::sim::sourcesWithSimulator().open("openni2:kinect3d-sim://hung_3m?frames=3");
  const std::vector<DepthFrame> frames = readFrames(*source, 6);
  ASSERT_EQ(frames.size(), 6u);
  EXPECT_GE(source->counters().reconnects, 1u);
  EXPECT_EQ(frames[3].index, 1u);
  EXPECT_EQ(frames[3].depth_mm, frames[0].depth_mm);
  EXPECT_EQ(source->counters().dropped, 0u) << "a restarted counter is not a gap";
}

TEST(OpenNI2Device, ADeviceAbsentAtStartIsWaitedForAndOpenedWhenItAppears) {
  const std::string uri = "openni2:kinect3d-sim://hung_3m?frames=5&appear=3";
  EXPECT_THROW(kinect3d::sim::sourcesWithSimulator().open(uri), kinect3d::DepthSourceError)
      << "a command gets an error at once";
  kinect3d::SourceOptions options;
  options.wait_for_device = true;
  // The same URI again: its first attempt above started the 3 s clock, so this one waits ~3 s.
  const auto start = std::chrono::steady_clock::now();
  auto source = kinect3d::sim::sourcesWithSimulator().open(uri, options);
  const std::vector<DepthFrame> frames = readFrames(*source, 5);
  const double waited_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_GT(waited_s, 2.0) << "nothing arrived before the device appeared";
  EXPECT_EQ(frames.front().index, 1u);
  EXPECT_EQ(source->counters().reconnects, 0u) << "a first opening is not a reconnection";
}

TEST(OpenNI2Device, UnknownDeviceIsAnError) {
  EXPECT_THROW(kinect3d::sim::sourcesWithSimulator().open("openni2:kinect3d-sim://no_such_scene"),
               kinect3d::DepthSourceError);
  EXPECT_THROW(kinect3d::sim::sourcesWithSimulator().open("openni2:/dev/no-such-device"), kinect3d::DepthSourceError);
}

}  // namespace
