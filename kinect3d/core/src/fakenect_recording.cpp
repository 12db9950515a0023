// fakenect-record folders: the format (kinect3d/fakenect_recording.h) and the fakenect: source.
#include "kinect3d/fakenect_recording.h"

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "framework_api/log.h"
#include "kinect3d/camera_file.h"
#include "kinect3d/depth_source.h"
#include "kinect3d/kinect_disparity.h"
#include "sources.h"

namespace kinect3d {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kDepthBytes = std::size_t{kFakenectWidth} * kFakenectHeight * 2;
constexpr std::size_t kColourBytes = std::size_t{kFakenectWidth} * kFakenectHeight * 3;
constexpr std::size_t kTiltStateBytes = 12;

std::string readWhole(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DepthSourceError("cannot open '" + path + "'");
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

const std::string& depthHeader() {
  static const std::string header = "P5 640 480 65535\n";
  return header;
}
const std::string& colourHeader() {
  static const std::string header = "P6 640 480 255\n";
  return header;
}

}  // namespace

std::vector<FakenectEntry> readFakenectIndex(const std::string& dir) {
  const fs::path index = fs::path(dir) / "INDEX.txt";
  std::ifstream in(index);
  if (!in) throw DepthSourceError("fakenect recording '" + dir + "' has no readable INDEX.txt");
  std::vector<FakenectEntry> entries;
  std::string text;
  for (int line = 1; std::getline(in, text); ++line) {
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (text.empty()) continue;
    const std::string where = index.string() + ":" + std::to_string(line) + ": ";
    FakenectEntry entry;
    entry.file = text;
    entry.line = line;
    char type = 0;
    unsigned int stamp = 0;
    int consumed = 0;
    if (std::sscanf(text.c_str(), "%c-%lf-%u.%n", &type, &entry.host_time_s, &stamp, &consumed) != 3 || consumed == 0 ||
        !std::isfinite(entry.host_time_s)) {
      throw DepthSourceError(where + "'" + text +
                             "' is not a fakenect file name (<type>-<host seconds>-<stamp>.<ext>)");
    }
    const std::string extension = text.substr(static_cast<std::size_t>(consumed));
    static const std::map<char, std::string> extensions = {{'d', "pgm"}, {'r', "ppm"}, {'a', "dump"}};
    const auto expected = extensions.find(type);
    if (expected == extensions.end() || expected->second != extension) {
      throw DepthSourceError(where + "'" + text + "': expected d-*.pgm, r-*.ppm or a-*.dump");
    }
    if (!fs::is_regular_file(fs::path(dir) / text)) throw DepthSourceError(where + "'" + text + "' does not exist");
    entry.type = type;
    entry.stamp = stamp;
    entries.push_back(entry);
  }
  if (entries.empty()) throw DepthSourceError(index.string() + ": lists no files");
  return entries;
}

std::vector<std::uint8_t> readFakenectColour(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DepthSourceError("cannot open '" + path + "'");
  std::string header(colourHeader().size(), '\0');
  if (!in.read(header.data(), static_cast<std::streamsize>(header.size())) || header != colourHeader()) {
    throw DepthSourceError(path + ": expected the header '" + colourHeader().substr(0, colourHeader().size() - 1) +
                           "'");
  }
  std::vector<std::uint8_t> rgb(kColourBytes);
  in.read(reinterpret_cast<char*>(rgb.data()), static_cast<std::streamsize>(rgb.size()));
  if (in.gcount() != static_cast<std::streamsize>(rgb.size()) || in.peek() != std::char_traits<char>::eof()) {
    throw DepthSourceError(path + ": not " + std::to_string(kColourBytes) + " bytes of pixels after its header");
  }
  return rgb;
}

std::array<std::int16_t, 3> readFakenectAccelerometer(const std::string& path) {
  const std::string bytes = readWhole(path);
  if (bytes.size() != kTiltStateBytes) {
    throw DepthSourceError(path + ": " + std::to_string(bytes.size()) + " bytes, expected libfreenect's " +
                           std::to_string(kTiltStateBytes) + "-byte tilt state");
  }
  std::array<std::int16_t, 3> counts{};
  std::memcpy(counts.data(), bytes.data(), sizeof counts);
  return counts;
}

FakenectWriter::FakenectWriter(std::string dir) : dir_(std::move(dir)) {
  std::error_code error;
  fs::create_directories(dir_, error);
  if (error) throw std::runtime_error("cannot create '" + dir_ + "': " + error.message());
  std::ofstream index(fs::path(dir_) / "INDEX.txt", std::ios::trunc);
  if (!index) throw std::runtime_error("cannot write '" + dir_ + "/INDEX.txt'");
}

void FakenectWriter::depth(double host_time_s, std::uint32_t stamp, const std::vector<std::uint16_t>& raw) {
  if (raw.size() * 2 != kDepthBytes) throw std::invalid_argument("a fakenect depth frame is 640x480");
  write('d', host_time_s, stamp, "pgm", depthHeader(), raw.data(), kDepthBytes);
}

void FakenectWriter::colour(double host_time_s, std::uint32_t stamp, const std::vector<std::uint8_t>& rgb) {
  if (rgb.size() != kColourBytes) throw std::invalid_argument("a fakenect colour frame is 640x480 RGB");
  write('r', host_time_s, stamp, "ppm", colourHeader(), rgb.data(), kColourBytes);
}

void FakenectWriter::accelerometer(double host_time_s, std::uint32_t stamp, const std::array<std::int16_t, 3>& counts) {
  unsigned char state[kTiltStateBytes] = {};  // tilt 0, pad, status 0 (stopped)
  std::memcpy(state, counts.data(), sizeof counts);
  write('a', host_time_s, stamp, "dump", "", state, sizeof state);
}

void FakenectWriter::write(char type, double host_time_s, std::uint32_t stamp, const char* extension,
                           const std::string& header, const void* data, std::size_t bytes) {
  char name[96];
  std::snprintf(name, sizeof name, "%c-%f-%" PRIu32 ".%s", type, host_time_s, stamp, extension);
  const std::string path = (fs::path(dir_) / name).string();
  std::ofstream out(path, std::ios::binary);
  out << header;
  out.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
  std::ofstream index(fs::path(dir_) / "INDEX.txt", std::ios::app);
  index << name << "\n";
  if (!out || !index) throw std::runtime_error("cannot write '" + path + "'");
}

namespace {

// A fakenect-record folder played without libfreenect. Each depth frame gets the colour image and
// the accelerometer reading nearest it in time (none when the nearest is more than a frame away);
// its time is the device's stamp unwrapped, counted from the recording host's clock at the first file.
class FakenectRecording : public DepthSource {
 public:
  FakenectRecording(const std::string& dir, const SourceOptions& options)
      : DepthSource(options), dir_(dir), entries_(readFakenectIndex(dir)) {
    CameraFile defaults;
    defaults.depth = Intrinsics{};
    defaults.colour = ColourCamera::kinectV1();
    camera_ = readCameraFile(dir, defaults, false);
    if (camera_.depth.width != kFakenectWidth || camera_.depth.height != kFakenectHeight ||
        camera_.colour.intrinsics.width != kFakenectWidth || camera_.colour.intrinsics.height != kFakenectHeight) {
      throw DepthSourceError(dir + "/camera.yaml: a fakenect recording's images are 640x480");
    }
    KinectStampClock clock;
    std::optional<std::int64_t> first_depth_index;  // frame indices start at 0 with the first depth frame
    for (std::size_t i = 0; i < entries_.size(); ++i) {
      const KinectStampClock::Time time = clock.next(entries_[i].stamp);
      const double t_s = entries_.front().host_time_s + time.seconds;
      switch (entries_[i].type) {
        case 'd':
          if (!first_depth_index) first_depth_index = time.index;
          depth_.push_back({i, t_s, static_cast<std::uint64_t>(time.index - *first_depth_index)});
          break;
        case 'r':
          if (!options.colour) break;
          colour_.push_back(i);
          colour_times_s_.push_back(t_s);
          break;
        default:
          accelerometer_.push_back(i);
          accelerometer_times_s_.push_back(t_s);
      }
    }
    if (depth_.empty()) throw DepthSourceError(dir + "/INDEX.txt: lists no depth frame (d-*.pgm)");
  }

  std::uint64_t frameCount() const override { return depth_.size(); }
  std::string describe() const override { return "fakenect:" + dir_; }

 private:
  struct Depth {
    std::size_t entry;
    double time_s;
    std::uint64_t index;
  };

  std::string pathOf(std::size_t entry) const { return (fs::path(dir_) / entries_[entry].file).string(); }

  ReadResult readFrame(DepthFrame& frame) override {
    while (next_ < depth_.size()) {
      const Depth& depth = depth_[next_++];
      try {
        frame = loadRawDisparityPgm(pathOf(depth.entry), camera_.depth, disparity_);
      } catch (const DepthSourceError& e) {
        reportSkipped(std::string(e.what()) + " (INDEX.txt line " + std::to_string(entries_[depth.entry].line) + ")");
        continue;
      }
      frame.index = depth.index;
      frame.source_time_s = depth.time_s;
      frame.sensor_id = describe();
      attachNearest(frame);
      return ReadResult::kFrame;
    }
    if (counters().frames == 0) throw DepthSourceError(describe() + ": none of its depth frames could be read");
    return ReadResult::kEnd;
  }

  // A companion file that cannot be read costs the frame its colour or gravity, said once per file.
  void attachNearest(DepthFrame& frame) {
    const double max_mismatch_s = 1.0 / frameRate_hz();
    if (!colour_.empty()) {
      const std::size_t k = nearestInTime(colour_times_s_, frame.source_time_s);
      if (std::abs(colour_times_s_[k] - frame.source_time_s) <= max_mismatch_s) {
        try {
          frame.colour = camera_.colour.image(readFakenectColour(pathOf(colour_[k])), colour_times_s_[k]);
        } catch (const DepthSourceError& e) {
          reportCompanion(e.what());
        }
      }
    }
    if (!accelerometer_.empty()) {
      const std::size_t k = nearestInTime(accelerometer_times_s_, frame.source_time_s);
      if (std::abs(accelerometer_times_s_[k] - frame.source_time_s) <= max_mismatch_s) {
        try {
          const auto counts = readFakenectAccelerometer(pathOf(accelerometer_[k]));
          frame.gravity_S_mps2 = gravityFromAccelerometer(counts[0], counts[1], counts[2]);
        } catch (const DepthSourceError& e) {
          reportCompanion(e.what());
        }
      }
    }
  }

  void reportCompanion(const std::string& what) {
    if (reported_.insert(what).second) fw::logWarn("depth", describe() + ": " + what + "; frames go on without it");
  }

  std::string dir_;
  std::vector<FakenectEntry> entries_;
  CameraFile camera_;
  DisparityTable disparity_;
  std::vector<Depth> depth_;
  std::vector<std::size_t> colour_, accelerometer_;  // entries, in index order
  std::vector<double> colour_times_s_, accelerometer_times_s_;
  std::size_t next_ = 0;
  std::set<std::string> reported_;
};

}  // namespace

std::unique_ptr<DepthSource> openFakenectRecording(const std::string& dir, const SourceOptions& options) {
  if (!fs::is_directory(dir)) throw DepthSourceError("fakenect recording folder '" + dir + "' does not exist");
  return std::make_unique<FakenectRecording>(dir, options);
}

}  // namespace kinect3d
