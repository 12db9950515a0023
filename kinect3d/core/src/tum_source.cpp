// TUM RGB-D style sequences: depth.txt lists "timestamp filename" per frame, depth images are
// 16-bit PNGs in units of 1/depth_scale metres (TUM: 5000 per metre).
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "framework_api/config.h"
#include "kinect3d/config_io.h"
#include "sources.h"

namespace kinect3d {

namespace {

namespace fs = std::filesystem;

struct TumEntry {
  double timestamp_s;
  std::string file;
  int line;
};

struct TumCamera {
  Intrinsics intrinsics{640, 480, 525.0, 525.0, 319.5, 239.5};  // TUM's defaults
  double depth_scale = 5000.0;                                  // image units per metre
};

TumCamera readCamera(const fs::path& dir) {
  TumCamera camera;
  const fs::path file = dir / "camera.yaml";
  if (!fs::exists(file)) return camera;
  try {
    const fw::ConfigView root = fw::Config::loadDocument(file.string()).root();
    root.requireOnlyKeys({"width", "height", "fx", "fy", "cx", "cy", "depth_scale"});
    camera.intrinsics = readIntrinsics(root);
    camera.depth_scale = root.getDouble("depth_scale", 1e-3, 1e7);
  } catch (const fw::ConfigError& e) {
    throw DepthSourceError(e.what());
  }
  return camera;
}

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
      : DepthSource(options), dir_(dir), camera_(readCamera(dir)), entries_(readIndex(dir / "depth.txt")) {}

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
    const Intrinsics& in = camera_.intrinsics;
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

  fs::path dir_;
  TumCamera camera_;
  std::vector<TumEntry> entries_;
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
