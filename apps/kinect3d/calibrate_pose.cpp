#include "calibrate_pose.h"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "framework_api/log.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/sim/sim_sources.h"

namespace kinect3d {

namespace {

namespace fs = std::filesystem;

constexpr double kScatterWarning_m = 0.03;  // detections of a still ball spread less than this
constexpr double kLiveCapture_s = 1.0;      // live: frames averaged per mark after Enter

struct MarkSpec {
  std::string label;  // "mark 2 (marks.yaml:5)"
  Eigen::Vector3d ball_R_m;
  std::optional<std::pair<double, double>> window_s;  // from the recording's first frame
  std::optional<Eigen::Vector2d> pixel;               // picked by hand instead of detected
};

std::vector<MarkSpec> readMarks(const std::string& path, double radius_m) {
  const fw::ConfigView root = fw::Config::loadDocument(path).root();
  root.requireOnlyKeys({"marks"});
  std::vector<MarkSpec> marks;
  int number = 0;
  for (const fw::ConfigView& mark : root.childList("marks")) {
    mark.requireOnlyKeys({"x", "y", "z", "from_s", "to_s", "pixel"});
    MarkSpec spec;
    spec.label = "mark " + std::to_string(++number) + " (" + mark.originOf("x") + ")";
    spec.ball_R_m = {mark.getDouble("x", -20.0, 20.0), mark.getDouble("y", -20.0, 20.0),
                     mark.has("z") ? mark.getDouble("z", 0.0, 3.0) : radius_m};
    if (mark.has("from_s") != mark.has("to_s")) {
      throw fw::ConfigError(mark.originOf(mark.has("from_s") ? "from_s" : "to_s") + ": " + spec.label +
                            ": give both from_s and to_s (the seconds of the recording that show the ball there)");
    }
    if (mark.has("from_s")) {
      spec.window_s = std::make_pair(mark.getDouble("from_s", 0.0, 1e6), mark.getDouble("to_s", 0.0, 1e6));
      if (spec.window_s->second <= spec.window_s->first) {
        throw fw::ConfigError(mark.originOf("to_s") + ": " + spec.label + ": to_s must be after from_s");
      }
    }
    if (mark.has("pixel")) {
      const std::vector<double> uv = mark.getDoubleList("pixel", 2);
      spec.pixel = Eigen::Vector2d(uv[0], uv[1]);
    }
    marks.push_back(spec);
  }
  if (marks.empty()) throw fw::ConfigError(path + ": lists no marks");
  return marks;
}

// The samples of one mark, averaged: the per-axis median and the RMS distance to it.
CalibrationMark average(const MarkSpec& spec, const std::vector<Eigen::Vector3d>& samples) {
  if (samples.empty()) {
    throw CalibrationError(spec.label + ": no ball found" +
                           (spec.window_s ? " between " + std::to_string(spec.window_s->first) + " and " +
                                                std::to_string(spec.window_s->second) + " s"
                                          : std::string()) +
                           "; check the time range, or pick the ball by hand with pixel: [u, v]");
  }
  Eigen::Vector3d median;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> values;
    for (const Eigen::Vector3d& p : samples) values.push_back(p[axis]);
    std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
    median[axis] = values[values.size() / 2];
  }
  double sum_sq = 0.0;
  for (const Eigen::Vector3d& p : samples) sum_sq += (p - median).squaredNorm();
  CalibrationMark mark{spec.label, spec.ball_R_m, median, std::sqrt(sum_sq / samples.size())};
  if (mark.scatter_m > kScatterWarning_m) {
    fw::logWarn("calibrate", spec.label + ": its " + std::to_string(samples.size()) + " detections scatter by " +
                                 std::to_string(std::lround(mark.scatter_m * 100)) +
                                 " cm: was the ball still, and the only ball-like thing in view?");
  }
  return mark;
}

// Sees frames in order and keeps, per mark, where the ball was in the sensor frame.
class MarkCollector {
 public:
  MarkCollector(const fw::ConfigView& kinect3d_block, double radius_m)
      : detector_(detectorWithoutPose(kinect3d_block), "calibrate"), radius_m_(radius_m) {}

  // The detector looks at every frame (the floor fit needs them); a mark's sample is taken when one is given.
  void see(const DepthFrame& frame, const MarkSpec* mark, std::vector<Eigen::Vector3d>* samples) {
    detector_.detect(frame, detections_);
    if (detections_.aligned) floor_T_R_S_ = detector_.T_R_S();
    if (mark == nullptr) return;
    if (mark->pixel) {
      if (const auto centre = ballCentreAtPixel(frame, *mark->pixel, radius_m_)) samples->push_back(*centre);
      return;
    }
    if (!detections_.aligned || detections_.balls.empty()) return;
    const auto best =
        std::max_element(detections_.balls.begin(), detections_.balls.end(),
                         [](const auto& a, const auto& b) { return a.support_points < b.support_points; });
    samples->push_back(detector_.T_R_S()->inverse() * best->position_m);
  }
  const std::optional<Eigen::Isometry3d>& floor() const { return floor_T_R_S_; }

 private:
  // The calibration finds the pose: the detector must take its frame from the floor, never from
  // the pose being replaced.
  static DetectorConfig detectorWithoutPose(const fw::ConfigView& block) {
    DetectorConfig config = readDetectorConfig(block);
    config.ground.pose.reset();
    return config;
  }

  BallDetector detector_;
  double radius_m_;
  Detections detections_;
  std::optional<Eigen::Isometry3d> floor_T_R_S_;
};

bool enterPressed() {
  pollfd input{STDIN_FILENO, POLLIN, 0};
  if (poll(&input, 1, 0) <= 0) return false;
  std::string line;
  std::getline(std::cin, line);
  return true;
}

std::string fixed(double value, int decimals) {
  std::ostringstream text;
  text.setf(std::ios::fixed);
  text.precision(decimals);
  text << value;
  return text.str();
}

}  // namespace

void printPoseCalibration(const PoseCalibration& calibration, std::ostream& out) {
  const CalibrationResult& result = calibration.result;
  const std::vector<CalibrationMark>& marks = calibration.marks;
  out << "kinect3d:\n  sensor:\n    pose_in_robot: " << fw::poseInRobotYaml(result.pose) << "\n";
  if (result.sigma) {
    const auto& s = *result.sigma;
    out << "# 1 sigma: x " << fixed(100 * s[0], 1) << " cm, y " << fixed(100 * s[1], 1) << " cm, z "
        << fixed(100 * s[2], 1) << " cm, yaw " << fixed(s[3] * 180 / M_PI, 2) << " deg, pitch "
        << fixed(s[4] * 180 / M_PI, 2) << " deg, roll " << fixed(s[5] * 180 / M_PI, 2) << " deg\n";
  } else {
    out << "# no uncertainty: too few marks to leave one out (add one)\n";
  }
  out << "# "
      << (result.used_floor ? "height, pitch and roll from the floor; the marks fix x, y and yaw"
                            : "all six from the marks (no floor)")
      << "\n";
  for (std::size_t i = 0; i < marks.size(); ++i) {
    out << "# " << marks[i].label << " at (" << fixed(marks[i].ball_R_m.x(), 2) << ", "
        << fixed(marks[i].ball_R_m.y(), 2) << ", " << fixed(marks[i].ball_R_m.z(), 2) << "): residual "
        << fixed(100 * result.residuals_m[i], 1) << " cm, scatter " << fixed(100 * marks[i].scatter_m, 1) << " cm"
        << (result.used[i] ? "" : "  DROPPED: far off the others' fit; is it mislabelled?") << "\n";
  }
}

PoseCalibration calibratePose(const PoseCalibrationOptions& options, const fw::Config& config) {
  const fw::ConfigView block = config.block("kinect3d");
  const double radius_m = readDetectorConfig(block).ball.radius_m;
  const std::vector<MarkSpec> specs = readMarks(options.marks_file, radius_m);
  const auto source = sim::sourcesWithSimulator().open(options.source);
  const bool live = source->frameCount() == 0;
  for (const MarkSpec& spec : specs) {
    if (!live && !spec.window_s) {
      throw fw::ConfigError(spec.label + ": a recording needs from_s and to_s for each mark");
    }
  }
  MarkCollector collector(block, radius_m);
  std::vector<std::vector<Eigen::Vector3d>> samples(specs.size());
  DepthFrame frame;
  if (live) {
    // One mark after another: the user places the ball, presses Enter, and a second is averaged.
    for (std::size_t i = 0; i < specs.size(); ++i) {
      std::cerr << "Put the ball on " << specs[i].label << " at (" << specs[i].ball_R_m.x() << ", "
                << specs[i].ball_R_m.y() << ") and press Enter" << std::endl;
      std::optional<double> capture_until_s;
      while (!capture_until_s || frame.source_time_s < *capture_until_s) {
        const ReadResult result = source->read(frame);
        if (result == ReadResult::kEnd) throw DepthSourceError(options.source + ": ended during the calibration");
        if (result != ReadResult::kFrame) continue;
        if (!capture_until_s && enterPressed()) capture_until_s = frame.source_time_s + kLiveCapture_s;
        collector.see(frame, capture_until_s ? &specs[i] : nullptr, &samples[i]);
      }
    }
  } else {
    std::optional<double> first_s;
    for (ReadResult result; (result = source->read(frame)) != ReadResult::kEnd;) {
      if (result != ReadResult::kFrame) continue;
      if (!first_s) first_s = frame.source_time_s;
      const double t = frame.source_time_s - *first_s;
      std::size_t i = 0;
      while (i < specs.size() && !(t >= specs[i].window_s->first && t <= specs[i].window_s->second)) ++i;
      collector.see(frame, i < specs.size() ? &specs[i] : nullptr, i < specs.size() ? &samples[i] : nullptr);
    }
  }
  std::vector<CalibrationMark> marks;
  for (std::size_t i = 0; i < specs.size(); ++i) marks.push_back(average(specs[i], samples[i]));
  if (options.use_floor && !collector.floor()) {
    fw::logWarn("calibrate", "the floor was not found: all six degrees of freedom come from the marks");
  }
  PoseCalibration calibration{marks, calibrateSensorPose(marks, options.use_floor ? collector.floor() : std::nullopt)};
  if (options.write) {
    const std::string backup = writePoseInRobotFile(options.robot_file, calibration.result.pose);
    fw::logInfo("calibrate",
                "wrote kinect3d.sensor.pose_in_robot into " + options.robot_file + " (the old file is " + backup + ")");
  }
  return calibration;
}

std::string writePoseInRobotFile(const std::string& robot_file, const fw::SensorPose& pose) {
  return writeRobotFileValue(robot_file, {"kinect3d", "sensor", "pose_in_robot"}, fw::poseInRobotYaml(pose));
}

std::string writeRobotFileValue(const std::string& robot_file, const std::vector<std::string>& path,
                                const std::string& value) {
  std::ifstream in(robot_file);
  if (!in) throw std::runtime_error("cannot read '" + robot_file + "'");
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  const auto indentOf = [](const std::string& line) { return line.find_first_not_of(' '); };
  const auto isContent = [&](const std::string& line) {
    const std::size_t first = indentOf(line);
    return first != std::string::npos && line[first] != '#';
  };
  // The end of the block that starts at line `start` (the first later content line not indented deeper).
  const auto blockEnd = [&](std::size_t start) {
    const std::size_t indent = indentOf(lines[start]);
    std::size_t end = start + 1;
    for (std::size_t i = start + 1; i < lines.size(); ++i) {
      if (!isContent(lines[i])) continue;
      if (indentOf(lines[i]) <= indent) break;
      end = i + 1;
    }
    return end;
  };
  // The child `key:` of the block at `start` (or of the top level when start is npos).
  const auto findKey = [&](const std::string& key, std::size_t start) -> std::optional<std::size_t> {
    const std::size_t from = start == std::string::npos ? 0 : start + 1;
    const std::size_t to = start == std::string::npos ? lines.size() : blockEnd(start);
    std::optional<std::size_t> child_indent;
    for (std::size_t i = from; i < to; ++i) {
      if (!isContent(lines[i])) continue;
      if (!child_indent) child_indent = indentOf(lines[i]);
      if (indentOf(lines[i]) != *child_indent) continue;
      if (lines[i].compare(*child_indent, key.size() + 1, key + ":") == 0) return i;
    }
    return std::nullopt;
  };
  // Down the path's blocks as far as the file has them; the rest is written under the last found.
  std::size_t parent = std::string::npos;
  std::size_t depth = 0;
  for (; depth + 1 < path.size(); ++depth) {
    const auto found = findKey(path[depth], parent);
    if (!found) break;
    if (lines[*found].find('{') != std::string::npos) {
      throw std::runtime_error(robot_file + ":" + std::to_string(*found + 1) + ": the " + path[depth] +
                               " block is written on one line ({...}); write it as a block to use --write, or "
                               "paste the printed lines into it");
    }
    parent = *found;
  }
  const auto old = depth + 1 == path.size() ? findKey(path.back(), parent) : std::nullopt;
  if (old) {
    // Keep the line's own indentation and its comment; a block-style value below it goes.
    const std::string& line = lines[*old];
    const std::size_t hash = line.find(" #");
    const std::string comment = hash == std::string::npos ? "" : line.substr(line.find_last_not_of(' ', hash) + 1);
    const std::size_t end = blockEnd(*old);
    const std::string key = path.back() + ":";
    lines[*old] = line.substr(0, line.find(key)) + key + " " + value + comment;
    lines.erase(lines.begin() + static_cast<long>(*old) + 1, lines.begin() + static_cast<long>(end));
  } else {
    std::vector<std::string> added;
    std::size_t indent = parent == std::string::npos ? 0 : indentOf(lines[parent]) + 2;
    for (std::size_t k = depth; k < path.size(); ++k, indent += 2) {
      added.push_back(std::string(indent, ' ') + path[k] + ":" + (k + 1 == path.size() ? " " + value : ""));
    }
    const auto at = parent == std::string::npos ? lines.end() : lines.begin() + static_cast<long>(parent) + 1;
    lines.insert(at, added.begin(), added.end());
  }

  const std::time_t now = std::time(nullptr);
  std::tm local{};
  localtime_r(&now, &local);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%d_%H-%M-%S", &local);
  const std::string backup = robot_file + "." + stamp + ".bak";
  fs::copy_file(robot_file, backup, fs::copy_options::overwrite_existing);
  std::ofstream out(robot_file);
  for (const std::string& line : lines) out << line << "\n";
  if (!out.flush()) throw std::runtime_error("cannot write '" + robot_file + "' (the old file is " + backup + ")");
  return backup;
}

}  // namespace kinect3d
