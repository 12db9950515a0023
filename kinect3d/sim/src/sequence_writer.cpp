#include "kinect3d/sim/sequence_writer.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include "framework_api/log.h"
#include "kinect3d/camera_file.h"
#include "kinect3d/fakenect_recording.h"
#include "kinect3d/kinect_disparity.h"
#include "kinect3d/oni_recording.h"
#include "kinect3d/sim/sim_sources.h"

namespace kinect3d::sim {

namespace fs = std::filesystem;

TumSequenceWriter::TumSequenceWriter(const std::string& dir) : dir_(dir) {
  std::error_code error;
  fs::create_directories(fs::path(dir) / "depth", error);
  if (error) throw std::runtime_error("cannot create '" + dir + "/depth': " + error.message());
  std::ofstream list(fs::path(dir) / "depth.txt");
  if (!list) throw std::runtime_error("cannot write '" + dir + "/depth.txt'");
  list << "# depth maps written by kinect3d simulate\n# timestamp filename\n";
}

void TumSequenceWriter::write(const DepthFrame& frame) {
  const Intrinsics& in = frame.intrinsics;
  if (!camera_written_ || (frame.colour && !colour_started_)) {
    // The first frame with colour starts rgb.txt and rgb/, as TUM's own, and adds the colour camera.
    std::optional<ColourCamera> colour;
    if (frame.colour) {
      colour = ColourCamera::of(*frame.colour);
      fs::create_directories(fs::path(dir_) / "rgb");
      std::ofstream(fs::path(dir_) / "rgb.txt") << "# colour images written by kinect3d\n# timestamp filename\n";
      colour_started_ = true;
    }
    writeCameraFile(dir_, in, colour, 5000.0);
    camera_written_ = true;
  }
  if (frame.colour) {
    char name[64];
    std::snprintf(name, sizeof name, "rgb/%06llu.png", static_cast<unsigned long long>(frame.index));
    cv::Mat bgr;
    cv::cvtColor(cv::Mat(frame.colour->height, frame.colour->width, CV_8UC3,
                         const_cast<std::uint8_t*>(frame.colour->rgb.data())),
                 bgr, cv::COLOR_RGB2BGR);
    std::ofstream list(fs::path(dir_) / "rgb.txt", std::ios::app);
    char line[128];
    std::snprintf(line, sizeof line, "%.6f %s\n", frame.colour->source_time_s, name);
    list << line;
    if (!cv::imwrite((fs::path(dir_) / name).string(), bgr) || !list) {
      throw std::runtime_error("cannot write '" + dir_ + "/" + name + "'");
    }
  }
  // TUM stores 1/5000 m: millimetres times five (9.5 m max range fits in 16 bits).
  cv::Mat image(in.height, in.width, CV_16UC1);
  for (int v = 0; v < in.height; ++v) {
    auto* row = image.ptr<std::uint16_t>(v);
    for (int u = 0; u < in.width; ++u) {
      const unsigned units = frame.at(u, v) * 5u;
      row[u] = static_cast<std::uint16_t>(units <= 65535u ? units : 0u);
    }
  }
  char name[64];
  std::snprintf(name, sizeof name, "depth/%06llu.png", static_cast<unsigned long long>(frame.index));
  if (!cv::imwrite((fs::path(dir_) / name).string(), image)) {
    throw std::runtime_error("cannot write '" + dir_ + "/" + name + "'");
  }
  std::ofstream list(fs::path(dir_) / "depth.txt", std::ios::app);
  char line[128];
  std::snprintf(line, sizeof line, "%.6f %s\n", frame.source_time_s, name);
  list << line;
  if (!list) throw std::runtime_error("cannot append to '" + dir_ + "/depth.txt'");
}

void writeTruthJson(const std::string& path, const Scene& scene, const std::vector<GroundTruth>& truth) {
  nlohmann::json frames = nlohmann::json::array();
  for (const GroundTruth& t : truth) {
    nlohmann::json entry{{"frame", t.frame_index},
                         {"t", scene.start_time_s + t.time_s},
                         {"robot_pose", {t.robot_pose.x_m, t.robot_pose.y_m, t.robot_pose.theta_rad}},
                         {"has_ball", t.has_ball}};
    if (t.has_ball) {
      entry["ball"] = {t.ball_center_R.x(), t.ball_center_R.y(), t.ball_center_R.z()};
      entry["ball_field"] = {t.ball_center_F.x(), t.ball_center_F.y(), t.ball_center_F.z()};
      entry["velocity"] = {t.ball_velocity_R.x(), t.ball_velocity_R.y(), t.ball_velocity_R.z()};
      entry["state"] = t.airborne ? "air" : "ground";
      entry["visible_pixels"] = t.visible_pixels;
      entry["clearance_m"] = std::isfinite(t.clearance_m) ? nlohmann::json(t.clearance_m) : nlohmann::json(nullptr);
    }
    frames.push_back(entry);
  }
  const nlohmann::json document{{"scene", scene.name},
                                {"frame_rate_hz", scene.fps},
                                {"ball_radius_m", scene.physics.radius_m},
                                {"frame", "robot"},
                                {"frames", frames}};
  std::ofstream out(path);
  out << document.dump(1) << "\n";
  if (!out) throw std::runtime_error("cannot write '" + path + "'");
}

namespace {
// Renders every frame; writes them as a TUM sequence when with_depth; writes truth.json either way.
void renderToDisk(const Scene& scene, const std::string& out_dir, bool with_depth) {
  KinectSimulator simulator(scene);
  std::vector<GroundTruth> truth(simulator.frameCount());
  DepthFrame frame;
  std::unique_ptr<TumSequenceWriter> writer;
  if (with_depth) writer = std::make_unique<TumSequenceWriter>(out_dir);
  fs::create_directories(out_dir);
  for (int i = 0; i < simulator.frameCount(); ++i) {
    simulator.render(i, frame, truth[i]);
    if (writer) writer->write(frame);
  }
  writeTruthJson(out_dir + "/truth.json", scene, truth);
}
}  // namespace

void writeTumSequence(const Scene& scene, const std::string& out_dir) { renderToDisk(scene, out_dir, true); }

void writeFakenectRecording(const Scene& scene, const std::string& out_dir) {
  if (!(scene.intrinsics.width == kFakenectWidth && scene.intrinsics.height == kFakenectHeight)) {
    throw std::runtime_error("scene '" + scene.name + "' is " + std::to_string(scene.intrinsics.width) + "x" +
                             std::to_string(scene.intrinsics.height) + "; a fakenect recording is 640x480");
  }
  KinectSimulator simulator(scene);
  simulator.setColour(true);
  FakenectWriter writer(out_dir);
  writeCameraFile(out_dir, scene.intrinsics, ColourCamera::kinectV1(), std::nullopt);
  const DisparityModel disparity;
  std::vector<GroundTruth> truth(simulator.frameCount());
  std::vector<std::uint16_t> raw;
  DepthFrame frame;
  for (int i = 0; i < simulator.frameCount(); ++i) {
    simulator.render(i, frame, truth[i]);
    raw.resize(frame.depth_mm.size());
    for (std::size_t p = 0; p < raw.size(); ++p) raw[p] = disparity.raw(frame.depth_mm[p] / 1000.0);
    // The device's 60 MHz stamps start kStampFramesBeforeWrap frames before their 32-bit wrap, so
    // that every recording crosses it; the host's clock is the scene's.
    const std::uint64_t first_stamp =
        (std::uint64_t{1} << 32) -
        static_cast<std::uint64_t>(kStampFramesBeforeWrap * KinectStampClock::kTicksPerFrame);
    const auto stamp = static_cast<std::uint32_t>(
        first_stamp + static_cast<std::uint64_t>(std::llround(i * KinectStampClock::kTicksPerSecond / scene.fps)));
    // In the order fakenect-record writes them: depth, colour, then the accelerometer.
    writer.depth(frame.source_time_s, stamp, raw);
    writer.colour(frame.source_time_s, stamp, frame.colour->rgb);
    writer.accelerometer(frame.source_time_s, stamp, accelerometerFromGravity(*frame.gravity_S_mps2));
  }
  writeTruthJson(out_dir + "/truth.json", scene, truth);
}

void writeSimulatedSequence(const std::string& scene_name, const std::string& out_dir, const std::string& format,
                            int frames, int seed) {
  Scene scene = loadScene(scene_name);
  if (seed >= 0) scene.noise.seed = static_cast<std::uint64_t>(seed);
  if (frames > 0) scene.duration_s = frames / scene.fps;
  if (format == "fakenect") {
    writeFakenectRecording(scene, out_dir);
  } else {
    renderToDisk(scene, out_dir, format == "tum");
  }
  if (format == "oni") {
    // The device plays in real time; allow the scene's length and a margin for OpenNI2's start-up.
    constexpr double kStartupMargin_s = 10.0;
    recordOni(simulatedDeviceUri(scene_name, scene.frameCount(), seed), out_dir + "/" + scene.name + ".oni",
              scene.frameCount(), scene.duration_s + kStartupMargin_s);
  }
  fw::logInfo("simulate",
              "wrote " + std::to_string(scene.frameCount()) + " frames of '" + scene.name + "' to " + out_dir);
}

}  // namespace kinect3d::sim
