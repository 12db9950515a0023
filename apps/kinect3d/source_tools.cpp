#include "source_tools.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <stdexcept>

#include "framework_api/log.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/sim/sim_sources.h"

namespace kinect3d {

void printSourceInfo(const std::string& uri) {
  auto source = sim::sourcesWithSimulator().open(uri);
  DepthFrame frame;
  std::uint64_t frames = 0;
  double invalid_sum = 0.0, min_m = 0.0, max_m = 0.0, first_t = 0.0, last_t = 0.0;
  Intrinsics intrinsics;
  // A live device never ends: one second of frames is enough, two without any is a dead device.
  const bool live = source->frameCount() == 0;
  auto last_frame = std::chrono::steady_clock::now();
  for (;;) {
    const ReadResult result = source->read(frame);
    if (result == ReadResult::kEnd) break;
    if (result == ReadResult::kNoFrameYet) {
      if (live && std::chrono::steady_clock::now() - last_frame > std::chrono::seconds(2)) break;
      continue;  // a recording that stalls says so itself
    }
    last_frame = std::chrono::steady_clock::now();
    const DepthStats stats = computeStats(frame);
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
  if (frames == 0) throw DepthSourceError(uri + ": delivered no frame");
  std::printf("source:            %s\n", source->describe().c_str());
  std::printf("frames:            %llu (%llu skipped, %llu dropped)\n", static_cast<unsigned long long>(frames),
              static_cast<unsigned long long>(source->counters().skipped),
              static_cast<unsigned long long>(source->counters().dropped));
  std::printf("stale time stamps: %llu, frames without depth: %llu\n",
              static_cast<unsigned long long>(source->counters().stale_stamps),
              static_cast<unsigned long long>(source->counters().blank));
  std::printf("rate:              %.2f Hz\n",
              frames > 1 && last_t > first_t ? (frames - 1) / (last_t - first_t) : source->frameRate_hz());
  std::printf("size:              %dx%d\n", intrinsics.width, intrinsics.height);
  std::printf("intrinsics:        fx %.1f fy %.1f cx %.1f cy %.1f\n", intrinsics.fx, intrinsics.fy, intrinsics.cx,
              intrinsics.cy);
  std::printf("invalid pixels:    %.1f %%\n", 100.0 * invalid_sum / frames);
  std::printf("depth range:       %.3f - %.3f m\n", min_m, max_m);
}

namespace {

// Frame `index` (0 = first) of a source, or an error naming the source when it has fewer.
DepthFrame readFrame(DepthSource& source, const std::string& uri, int index) {
  DepthFrame frame;
  for (int seen = 0;;) {
    const ReadResult result = source.read(frame);
    if (result == ReadResult::kEnd) {
      throw DepthSourceError(uri + ": has no frame " + std::to_string(index));
    }
    if (result == ReadResult::kFrame && seen++ == index) return frame;
  }
}

}  // namespace

// One frame of each source (frame_numbers: one for all, or one per source), colour-mapped on one
// fixed 0-8 m scale (no data in black), side by side in one PNG, so simulated and real frames can
// be compared by eye; where a source has colour, its colour image under its depth.
void writeDepthPanels(const std::vector<std::string>& uris, const std::vector<int>& frame_numbers,
                      const std::string& out) {
  constexpr double kMaxDepth_mm = 8000.0;
  SourceOptions options;
  options.colour = true;
  std::vector<cv::Mat> depth_panels, colour_panels;
  bool any_colour = false;
  for (std::size_t i = 0; i < uris.size(); ++i) {
    const std::string& uri = uris[i];
    const int index = frame_numbers.empty() ? 0 : frame_numbers[frame_numbers.size() > 1 ? i : 0];
    DepthFrame frame = readFrame(*sim::sourcesWithSimulator().open(uri, options), uri, index);
    cv::Mat depth(frame.height(), frame.width(), CV_16UC1, frame.depth_mm.data());
    cv::Mat scaled, coloured;
    depth.convertTo(scaled, CV_8UC1, 255.0 / kMaxDepth_mm);
    cv::applyColorMap(scaled, coloured, cv::COLORMAP_TURBO);
    coloured.setTo(cv::Scalar(0, 0, 0), depth == 0);
    cv::putText(coloured, uri.substr(uri.find_last_of('/') + 1), {10, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.7,
                cv::Scalar(255, 255, 255), 2);
    cv::Mat colour(coloured.size(), CV_8UC3, cv::Scalar(0, 0, 0));
    if (frame.colour) {
      any_colour = true;
      cv::Mat bgr;
      cv::cvtColor(cv::Mat(frame.colour->height, frame.colour->width, CV_8UC3, frame.colour->rgb.data()), bgr,
                   cv::COLOR_RGB2BGR);
      cv::resize(bgr, colour, coloured.size());
    }
    depth_panels.push_back(coloured);
    colour_panels.push_back(colour);
  }
  cv::Mat joined;
  cv::hconcat(depth_panels, joined);
  if (any_colour) {
    cv::Mat colours;
    cv::hconcat(colour_panels, colours);
    cv::vconcat(joined, colours, joined);
  }
  if (!cv::imwrite(out, joined)) throw std::runtime_error("cannot write '" + out + "'");
}

// The scene map the detector builds from the source's frames up to frame `last`, as OctoMap's .bt.
void writeSceneMap(const std::string& uri, int last, const fw::Config& config, const std::string& out) {
  BallDetector detector(readDetectorConfig(config.block("kinect3d")), "kinect3d");
  auto source = sim::sourcesWithSimulator().open(uri);
  DepthFrame frame;
  Detections detections;
  for (int frames = 0; frames <= last;) {
    const ReadResult result = source->read(frame);
    if (result == ReadResult::kEnd) throw DepthSourceError(uri + ": has no frame " + std::to_string(last));
    if (result != ReadResult::kFrame) continue;
    detector.detect(frame, detections);
    ++frames;
  }
  if (detector.sceneMap() == nullptr) throw std::runtime_error(uri + ": the floor was never found, so there is no map");
  detector.sceneMap()->writeBinary(out);
  fw::logInfo("snapshot", "wrote the scene map after " + std::to_string(last + 1) + " frames of " + uri + " to " + out +
                              " (" + std::to_string(detector.sceneMap()->integrations()) + " ray integrations)");
}

}  // namespace kinect3d
