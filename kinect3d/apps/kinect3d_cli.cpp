// kinect3d: the depth pipeline's command line. See docs/cli.md.
#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <iostream>

#include "framework_api/log.h"
#include "kinect3d/depth_source.h"
#include "kinect3d/sim/kinect_simulator.h"
#include "kinect3d/sim/sequence_writer.h"

namespace {

int runSimulate(const std::string& scene_name, const std::string& out_dir, int frames, int seed) {
  kinect3d::sim::Scene scene = kinect3d::sim::loadScene(scene_name);
  if (seed >= 0) scene.noise.seed = static_cast<std::uint64_t>(seed);
  if (frames > 0) scene.duration_s = frames / scene.fps;
  kinect3d::sim::KinectSimulator simulator(scene);
  kinect3d::sim::TumSequenceWriter writer(out_dir);
  std::vector<kinect3d::sim::GroundTruth> truth(simulator.frameCount());
  kinect3d::DepthFrame frame;
  for (int i = 0; i < simulator.frameCount(); ++i) {
    simulator.render(i, frame, truth[i]);
    writer.write(frame);
  }
  kinect3d::sim::writeTruthJson(out_dir + "/truth.json", scene, truth);
  fw::logInfo("simulate", "wrote " + std::to_string(truth.size()) + " frames of '" + scene.name +
                              "' to " + out_dir);
  return 0;
}

int runInfo(const std::string& uri) {
  auto source = kinect3d::openDepthSource(uri);
  kinect3d::DepthFrame frame;
  std::uint64_t frames = 0;
  double invalid_sum = 0.0, min_m = 0.0, max_m = 0.0, first_t = 0.0, last_t = 0.0;
  kinect3d::Intrinsics intrinsics;
  for (;;) {
    const kinect3d::ReadResult result = source->read(frame);
    if (result == kinect3d::ReadResult::kEnd) break;
    if (result == kinect3d::ReadResult::kNoFrameYet) {
      if (source->frameCount() == 0 && frames >= 30) break;  // a live device: one second is enough
      continue;
    }
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
    if (source->frameCount() == 0 && frames >= 30) break;
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

// Frame `index` of each source, colour-mapped on one fixed 0-8 m scale (no data in black), side
// by side in one PNG, so simulated and real frames can be compared by eye.
int runSnapshot(const std::vector<std::string>& uris, int index, const std::string& out) {
  constexpr double kMaxDepth_mm = 8000.0;
  std::vector<cv::Mat> panels;
  for (const std::string& uri : uris) {
    auto source = kinect3d::openDepthSource(uri);
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Kinect3D: 3D ball perception from depth frames."};
  app.require_subcommand(1);

  std::string scene, out_dir, format = "tum";
  int frames = 0, seed = -1;
  CLI::App* simulate = app.add_subcommand("simulate", "Render a simulated scene to a sequence on disk");
  simulate->add_option("scene", scene, "Built-in scene name or scene file (.yaml)")->required();
  simulate->add_option("--out", out_dir, "Output folder")->required();
  simulate->add_option("--format", format, "Sequence format")->check(CLI::IsMember({"tum"}))->capture_default_str();
  simulate->add_option("--frames", frames, "Number of frames (default: the scene's duration)")->check(CLI::PositiveNumber);
  simulate->add_option("--seed", seed, "Noise seed (default: the scene's)")->check(CLI::NonNegativeNumber);

  std::string uri;
  CLI::App* info = app.add_subcommand("info", "Print what a depth source delivers");
  info->add_option("source", uri, "Depth source URI: openni2:, oni:<file>, tum:<dir>, sim:<scene>")->required();

  std::vector<std::string> snapshot_uris;
  std::string snapshot_out;
  int snapshot_frame = 0;
  CLI::App* snapshot = app.add_subcommand("snapshot", "Colour-map one frame of each source, side by side, to a PNG");
  snapshot->add_option("sources", snapshot_uris, "Depth source URIs")->required();
  snapshot->add_option("--frame", snapshot_frame, "Frame number (0 = first)")->check(CLI::NonNegativeNumber);
  snapshot->add_option("--out", snapshot_out, "PNG file to write")->required();

  CLI11_PARSE(app, argc, argv);
  try {
    if (*simulate) return runSimulate(scene, out_dir, frames, seed);
    if (*info) return runInfo(uri);
    if (*snapshot) return runSnapshot(snapshot_uris, snapshot_frame, snapshot_out);
  } catch (const std::exception& e) {
    fw::logError("kinect3d", e.what());
    return 2;
  }
  return 0;
}
