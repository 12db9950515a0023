// kinect3d: the depth pipeline's command line. See docs/cli.md.
#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <iostream>

#include "kinect3d/sim/accuracy_report.h"
#include "kinect3d/sim/trajectory_report.h"
#include "framework_api/config.h"
#include "framework_api/log.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/depth_source.h"
#include "kinect3d/sim/sim_sources.h"
#include "kinect3d/oni_recording.h"
#include "kinect3d/trajectory.h"
#include "kinect3d/sim/kinect_simulator.h"
#include "kinect3d/sim/sequence_writer.h"

namespace {

int runInfo(const std::string& uri) {
  auto source = kinect3d::sim::sourcesWithSimulator().open(uri);
  kinect3d::DepthFrame frame;
  std::uint64_t frames = 0;
  double invalid_sum = 0.0, min_m = 0.0, max_m = 0.0, first_t = 0.0, last_t = 0.0;
  kinect3d::Intrinsics intrinsics;
  // A live device never ends: one second of frames is enough, two without any is a dead device.
  const bool live = source->frameCount() == 0;
  auto last_frame = std::chrono::steady_clock::now();
  for (;;) {
    const kinect3d::ReadResult result = source->read(frame);
    if (result == kinect3d::ReadResult::kEnd) break;
    if (result == kinect3d::ReadResult::kNoFrameYet) {
      if (std::chrono::steady_clock::now() - last_frame > std::chrono::seconds(2)) break;
      continue;
    }
    last_frame = std::chrono::steady_clock::now();
    const kinect3d::DepthStats stats = kinect3d::computeStats(frame);
    if (frames == 0) {
      intrinsics = frame.intrinsics;
      first_t = frame.source_time_s;
      min_m = stats.min_m;
    }
    if (stats.min_m > 0.0) min_m = min_m > 0.0 ? std::min(min_m, stats.min_m) : stats.min_m;
    max_m = std::max(max_m, stats.max_m);
    invalid_sum += stats.invalid_fraction;
    last_t = frame.source_time_s;
    ++frames;
    if (live && frames >= 30) break;
  }
  if (frames == 0) throw kinect3d::DepthSourceError(uri + ": delivered no frame");
  std::printf("source:            %s\n", source->describe().c_str());
  std::printf("frames:            %llu (%llu skipped, %llu dropped)\n",
              static_cast<unsigned long long>(frames),
              static_cast<unsigned long long>(source->counters().skipped),
              static_cast<unsigned long long>(source->counters().dropped));
  std::printf("rate:              %.2f Hz\n",
              frames > 1 && last_t > first_t ? (frames - 1) / (last_t - first_t) : source->frameRate_hz());
  std::printf("size:              %dx%d\n", intrinsics.width, intrinsics.height);
  std::printf("intrinsics:        fx %.1f fy %.1f cx %.1f cy %.1f\n", intrinsics.fx, intrinsics.fy,
              intrinsics.cx, intrinsics.cy);
  std::printf("invalid pixels:    %.1f %%\n", 100.0 * invalid_sum / frames);
  std::printf("depth range:       %.3f - %.3f m\n", min_m, max_m);
  return 0;
}

// One frame of each source (frame_numbers: one for all, or one per source), colour-mapped on one
// fixed 0-8 m scale (no data in black), side by side in one PNG, so simulated and real frames can
// be compared by eye.
int runSnapshot(const std::vector<std::string>& uris, const std::vector<int>& frame_numbers,
                const std::string& out) {
  if (frame_numbers.size() > 1 && frame_numbers.size() != uris.size()) {
    throw std::runtime_error("--frame: give one frame number, or one per source");
  }
  constexpr double kMaxDepth_mm = 8000.0;
  std::vector<cv::Mat> panels;
  for (std::size_t i = 0; i < uris.size(); ++i) {
    const std::string& uri = uris[i];
    const int index = frame_numbers.empty() ? 0 : frame_numbers[frame_numbers.size() > 1 ? i : 0];
    auto source = kinect3d::sim::sourcesWithSimulator().open(uri);
    kinect3d::DepthFrame frame;
    int seen = 0;
    for (;;) {
      const kinect3d::ReadResult result = source->read(frame);
      if (result == kinect3d::ReadResult::kEnd) {
        throw kinect3d::DepthSourceError(uri + ": has no frame " + std::to_string(index));
      }
      if (result == kinect3d::ReadResult::kFrame && seen++ == index) break;
    }
    cv::Mat depth(frame.height(), frame.width(), CV_16UC1, frame.depth_mm.data());
    cv::Mat scaled, coloured;
    depth.convertTo(scaled, CV_8UC1, 255.0 / kMaxDepth_mm);
    cv::applyColorMap(scaled, coloured, cv::COLORMAP_TURBO);
    coloured.setTo(cv::Scalar(0, 0, 0), depth == 0);
    cv::putText(coloured, uri.substr(uri.find_last_of('/') + 1), {10, 25}, cv::FONT_HERSHEY_SIMPLEX,
                0.7, cv::Scalar(255, 255, 255), 2);
    panels.push_back(coloured);
  }
  cv::Mat joined;
  cv::hconcat(panels, joined);
  if (!cv::imwrite(out, joined)) throw std::runtime_error("cannot write '" + out + "'");
  return 0;
}

// One detect line: {"frame", "t", "balls": [{"x", "y", "z", "state", "points"}], "process_ms",
// "trajectory": null or {"p", "v", "state", "support", "rms_m", "touchdown", "crossing"}};
// positions to 0.1 mm, times to 1 us (docs/cli.md).
std::string detectLine(const kinect3d::DepthFrame& frame, const kinect3d::Detections& detections,
                       const std::optional<fw::BallTrajectory>& trajectory) {
  char text[512];
  std::snprintf(text, sizeof text, "{\"frame\": %llu, \"t\": %.6f, \"balls\": [",
                static_cast<unsigned long long>(frame.index), frame.source_time_s);
  std::string line = text;
  for (std::size_t i = 0; i < detections.balls.size(); ++i) {
    const fw::BallObservation& ball = detections.balls[i];
    std::snprintf(text, sizeof text,
                  "%s{\"x\": %.4f, \"y\": %.4f, \"z\": %.4f, \"state\": \"%s\", \"points\": %d}",
                  i ? ", " : "", ball.position_m.x(), ball.position_m.y(), ball.position_m.z(),
                  fw::toString(ball.state), ball.support_points);
    line += text;
  }
  std::snprintf(text, sizeof text, "], \"process_ms\": %.3f, \"trajectory\": ", detections.times.total() * 1e3);
  line += text;
  if (!trajectory) return line + "null}";
  const Eigen::Vector3d& p = trajectory->position_m;
  const Eigen::Vector3d& v = trajectory->velocity_mps;
  std::snprintf(text, sizeof text,
                "{\"p\": [%.4f, %.4f, %.4f], \"v\": [%.4f, %.4f, %.4f], \"state\": \"%s\", "
                "\"support\": %d, \"rms_m\": %.4f, \"touchdown\": ",
                p.x(), p.y(), p.z(), v.x(), v.y(), v.z(), fw::toString(trajectory->state), trajectory->support,
                trajectory->rms_m);
  line += text;
  if (const auto& touchdown = trajectory->touchdown) {
    std::snprintf(text, sizeof text, "{\"x\": %.4f, \"y\": %.4f, \"t\": %.6f, \"sigma_m\": %.4f}",
                  touchdown->point_m.x(), touchdown->point_m.y(), touchdown->time_s, touchdown->sigma_m);
    line += text;
  } else {
    line += "null";
  }
  line += ", \"crossing\": ";
  if (const auto& crossing = trajectory->crossing) {
    std::snprintf(text, sizeof text, "{\"x\": %.4f, \"z\": %.4f, \"t\": %.6f}", crossing->x_m, crossing->z_m,
                  crossing->time_s);
    line += text;
  } else {
    line += "null";
  }
  return line + "}}";
}

int runDetect(const std::string& source_uri, const fw::Config& config, const std::string& output,
              bool realtime) {
  const fw::ConfigView block = config.block("kinect3d");
  const std::string uri = source_uri.empty() ? block.getString("source") : source_uri;
  kinect3d::BallDetector detector(kinect3d::readDetectorConfig(block));
  const auto trajectory = kinect3d::makeTrajectoryEstimator(kinect3d::readTrajectoryConfig(block));
  kinect3d::SourceOptions options;
  options.realtime = realtime;
  auto source = kinect3d::sim::sourcesWithSimulator().open(uri, options);

  std::ofstream file;
  if (!output.empty()) {
    file.open(output);
    if (!file) throw std::runtime_error("cannot write '" + output + "'");
  }
  std::ostream& out = output.empty() ? std::cout : file;
  kinect3d::DepthFrame frame;
  kinect3d::Detections detections;
  std::uint64_t frames = 0, with_ball = 0;
  for (;;) {
    const kinect3d::ReadResult result = source->read(frame);
    if (result == kinect3d::ReadResult::kEnd) break;
    if (result == kinect3d::ReadResult::kNoFrameYet) continue;
    detector.detect(frame, detections);
    out << detectLine(frame, detections, trajectory->update(frame.source_time_s, detections.balls)) << "\n";
    out.flush();
    ++frames;
    with_ball += !detections.balls.empty();
  }
  fw::logInfo("detect", source->describe() + ": " + std::to_string(frames) + " frames, ball in " +
                            std::to_string(with_ball));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Kinect3D: 3D ball perception from depth frames."};
  app.require_subcommand(1);

  std::string scene, out_dir, format = "tum";
  int frames = 0, seed = -1;
  CLI::App* simulate = app.add_subcommand("simulate", "Render a simulated scene to a sequence on disk");
  simulate->add_option("scene", scene, "Built-in scene name or scene file (.yaml)")->required();
  simulate->add_option("--out", out_dir, "Output folder")->required();
  simulate->add_option("--format", format, "Sequence format")->check(CLI::IsMember({"tum", "oni"}))->capture_default_str();
  simulate->add_option("--frames", frames, "Number of frames (default: the scene's duration)")->check(CLI::PositiveNumber);
  simulate->add_option("--seed", seed, "Noise seed (default: the scene's)")->check(CLI::NonNegativeNumber);

  std::string uri;
  CLI::App* info = app.add_subcommand("info", "Print what a depth source delivers");
  info->add_option("source", uri, "Depth source URI: openni2:, oni:<file>, tum:<dir>, sim:<scene>")->required();

  std::vector<std::string> snapshot_uris;
  std::string snapshot_out;
  std::vector<int> snapshot_frames;
  CLI::App* snapshot = app.add_subcommand("snapshot", "Colour-map one frame of each source, side by side, to a PNG");
  snapshot->add_option("sources", snapshot_uris, "Depth source URIs")->required();
  snapshot->add_option("--frame", snapshot_frames, "Frame number (0 = first): one for all sources, or one per source")
      ->check(CLI::NonNegativeNumber);
  snapshot->add_option("--out", snapshot_out, "PNG file to write")->required();

  std::string detect_source, robot_file, detect_output, defaults_dir = KINECT3D_CONFIG_DIR "/defaults";
  std::vector<std::string> overrides;
  bool detect_realtime = false;
  CLI::App* detect = app.add_subcommand("detect", "Detect balls in every frame; one JSON line per frame");
  detect->add_option("--source", detect_source, "Depth source URI (default: kinect3d.source of the configuration)");
  detect->add_option("--config", robot_file, "Robot configuration file (default: the shipped defaults)")
      ->check(CLI::ExistingFile);
  detect->add_option("--defaults", defaults_dir, "Folder of per-plugin defaults")->capture_default_str();
  detect->add_option("--set", overrides, "Override a value: --set kinect3d.grid.voxel_m=0.2")->take_all();
  detect->add_option("--output", detect_output, "Write the JSON lines here instead of stdout");
  detect->add_flag("--realtime", detect_realtime, "Pace recordings and the simulator at their frame rate");

  kinect3d::ReportOptions report_options;
  report_options.real_depth_dir = KINECT3D_REAL_DEPTH_DIR;
  std::string report_out, report_kind;
  CLI::App* report = app.add_subcommand("report", "Measure detection accuracy or trajectory prediction on simulated scenes");
  report->add_option("kind", report_kind, "detection (docs/accuracy.md) or trajectory (docs/trajectory.md)")
      ->required()
      ->check(CLI::IsMember({"detection", "trajectory"}));
  report->add_option("--out", report_out, "Markdown file to write, e.g. docs/accuracy.md")->required();
  report->add_option("--seeds", report_options.seeds, "detection: noise seeds per kick/shot scene")->capture_default_str();
  report->add_option("--clutter-frames", report_options.clutter_frames, "detection: frames of the clutter scene")->capture_default_str();
  report->add_option("--real-depth", report_options.real_depth_dir, "detection: folder of the real Kinect frames")->capture_default_str();
  report->add_option("--defaults", defaults_dir, "Folder of per-plugin defaults")->capture_default_str();

  CLI11_PARSE(app, argc, argv);
  try {
    if (*simulate) return kinect3d::sim::writeSimulatedSequence(scene, out_dir, format, frames, seed), 0;
    if (*info) return runInfo(uri);
    if (*snapshot) return runSnapshot(snapshot_uris, snapshot_frames, snapshot_out);
    if (*report) {
      const fw::Config config = fw::Config::load(defaults_dir, "", {});
      if (report_kind == "trajectory") {
        kinect3d::writeTrajectoryReport(config, report_out);
      } else {
        kinect3d::writeAccuracyReport(config, report_options, report_out);
      }
      return 0;
    }
    if (*detect) {
      // The shipped defaults, the robot file if given, then --set overrides.
      return runDetect(detect_source, fw::Config::load(defaults_dir, robot_file, overrides),
                       detect_output, detect_realtime);
    }
  } catch (const std::exception& e) {
    fw::logError("kinect3d", e.what());
    return 2;
  }
  return 0;
}
