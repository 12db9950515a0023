// TUM RGB-D style sequences: depth.txt lists "timestamp filename" per frame, depth images are
// 16-bit PNGs in units of 1/depth_scale metres (TUM: 5000 per metre). With rgb.txt beside it, in
// the same layout, each depth frame gets the colour image nearest in time, as TUM's associate.py
// pairs them: none when the nearest is more than 0.02 s away.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "framework_api/log.h"
#include "kinect3d/camera_file.h"
#include "sources.h"

namespace kinect3d {

namespace {

namespace fs = std::filesystem;

struct TumEntry {
  double timestamp_s;
  std::string file;
  int line;
};

// TUM's defaults: its Kinects' depth is registered to the colour camera (no offset).
CameraFile tumDefaults() {
  CameraFile camera;
  camera.depth = Intrinsics{640, 480, 525.0, 525.0, 319.5, 239.5};
  camera.depth_scale = 5000.0;  // image units per metre
  return camera;
}

// rgb.txt's colour images may be 8-bit colour or grey images of any format OpenCV reads.
constexpr double kMaxColourMismatch_s = 0.02;

std::vector<TumEntry> readIndex(const fs::path& list) {
  std::ifstream in(list);
  if (!in) throw DepthSourceError("cannot read '" + list.string() + "'");
  std::vector<TumEntry> entries;
  std::string text;
  for (int line = 1; std::getline(in, text); ++line) {
    const auto hash = text.find('#');
    if (hash != std::string::npos) text.resize(hash);
    std::istringstream fields(text);
    TumEntry entry{0.0, "", line};
    std::string extra;
    if (!(fields >> entry.timestamp_s)) {
      if (text.find_first_not_of(" \t\r") == std::string::npos) continue;  // blank line
      throw DepthSourceError(list.string() + ":" + std::to_string(line) + ": expected 'timestamp filename', got '" +
                             text + "'");
    }
    if (!(fields >> entry.file) || (fields >> extra)) {
      throw DepthSourceError(list.string() + ":" + std::to_string(line) + ": expected 'timestamp filename', got '" +
                             text + "'");
    }
    entries.push_back(entry);
  }
  if (entries.empty()) throw DepthSourceError(list.string() + ": lists no frames");
  return entries;
}

class TumSequence : public DepthSource {
 public:
  TumSequence(const fs::path& dir, const SourceOptions& options)
      : DepthSource(options),
        dir_(dir),
        camera_(readCameraFile(dir.string(), tumDefaults(), true)),
        entries_(readIndex(dir / "depth.txt")) {
    if (options.colour && fs::exists(dir / "rgb.txt")) {
      colour_entries_ = readIndex(dir / "rgb.txt");
      std::stable_sort(colour_entries_.begin(), colour_entries_.end(),
                       [](const TumEntry& a, const TumEntry& b) { return a.timestamp_s < b.timestamp_s; });
      for (const TumEntry& entry : colour_entries_) colour_times_s_.push_back(entry.timestamp_s);
    }
  }

  std::uint64_t frameCount() const override { return entries_.size(); }
  double frameRate_hz() const override {
    if (entries_.size() < 2) return 30.0;
    return (entries_.size() - 1) / (entries_.back().timestamp_s - entries_.front().timestamp_s);
  }
  std::string describe() const override { return "tum:" + dir_.string(); }

 private:
  ReadResult readFrame(DepthFrame& frame) override {
    while (next_ < entries_.size()) {
      const TumEntry& entry = entries_[next_];
      const std::uint64_t index = next_++;
      const fs::path image_path = dir_ / entry.file;
      const std::string problem = decode(image_path, frame);
      if (!problem.empty()) {
        reportSkipped(image_path.string() + " (depth.txt line " + std::to_string(entry.line) + "): " + problem);
        continue;
      }
      frame.index = index;
      frame.source_time_s = entry.timestamp_s;
      frame.sensor_id = describe();
      attachColour(frame);
      return ReadResult::kFrame;
    }
    if (counters().frames == 0) {
      throw DepthSourceError(describe() + ": none of the " + std::to_string(entries_.size()) +
                             " listed frames could be read");
    }
    return ReadResult::kEnd;
  }

  // Fills frame from a PNG; returns what is wrong with the file, or "" when it was read.
  std::string decode(const fs::path& path, DepthFrame& frame) const {
    if (!fs::exists(path)) return "file does not exist";
    const cv::Mat image = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
    if (image.empty()) return "not a readable image";
    if (image.type() != CV_16UC1) return "not a 16-bit single-channel image";
    const Intrinsics& in = camera_.depth;
    if (image.cols != in.width || image.rows != in.height) {
      return "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) + ", expected " +
             std::to_string(in.width) + "x" + std::to_string(in.height);
    }
    frame.resize(in);
    const double mm_per_unit = 1000.0 / camera_.depth_scale;
    for (int v = 0; v < in.height; ++v) {
      const std::uint16_t* row = image.ptr<std::uint16_t>(v);
      for (int u = 0; u < in.width; ++u) {
        const double mm = std::round(row[u] * mm_per_unit);
        frame.depth_mm[static_cast<std::size_t>(v) * in.width + u] =
            mm <= 65535.0 ? static_cast<std::uint16_t>(mm) : 0;  // beyond uint16 mm: no data
      }
    }
    return "";
  }

  // The colour image nearest the frame in time, if one is near enough and readable (one that is
  // not is reported and the frame goes on without colour).
  void attachColour(DepthFrame& frame) {
    if (colour_times_s_.empty()) return;
    const TumEntry& entry = colour_entries_[nearestInTime(colour_times_s_, frame.source_time_s)];
    if (std::abs(entry.timestamp_s - frame.source_time_s) > kMaxColourMismatch_s) return;
    const fs::path path = dir_ / entry.file;
    const cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
    const Intrinsics& in = camera_.colour.intrinsics;
    if (image.empty() || image.depth() != CV_8U || image.cols != in.width || image.rows != in.height) {
      fw::logWarn("depth", describe() + ": colour image " + path.string() + " (rgb.txt line " +
                               std::to_string(entry.line) + ") is not a readable " + std::to_string(in.width) + "x" +
                               std::to_string(in.height) + " 8-bit image; frame " + std::to_string(frame.index) +
                               " goes on without colour");
      return;
    }
    std::vector<std::uint8_t> rgb(static_cast<std::size_t>(in.width) * in.height * 3);
    cv::Mat rgb_view(in.height, in.width, CV_8UC3, rgb.data());
    cv::cvtColor(image, rgb_view, cv::COLOR_BGR2RGB);
    frame.colour = camera_.colour.image(std::move(rgb), entry.timestamp_s);
  }

  fs::path dir_;
  CameraFile camera_;
  std::vector<TumEntry> entries_;
  std::vector<TumEntry> colour_entries_;  // rgb.txt, in time order
  std::vector<double> colour_times_s_;
  std::size_t next_ = 0;
};

}  // namespace

std::unique_ptr<DepthSource> openTumSequence(const std::string& dir, const SourceOptions& options) {
  if (!fs::is_directory(dir)) throw DepthSourceError("TUM sequence folder '" + dir + "' does not exist");
  if (!fs::exists(fs::path(dir) / "depth.txt")) {
    throw DepthSourceError("TUM sequence folder '" + dir + "' has no depth.txt");
  }
  return std::make_unique<TumSequence>(dir, options);
}

}  // namespace kinect3d
