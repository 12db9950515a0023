#include "fusion/json_lines.h"

#include <cmath>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace fusion {

namespace {

using nlohmann::json;

// Calls parse(object, where) for every non-blank line; where is "file:line" for errors.
void forEachLine(const std::string& path, const std::function<void(const json&, const std::string&)>& parse) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open for reading");
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::string where = path + ":" + std::to_string(number);
    json object;
    try {
      object = json::parse(line);
    } catch (const json::parse_error& e) {
      throw std::runtime_error(where + ": not JSON (" + e.what() + ")");
    }
    if (!object.is_object()) throw std::runtime_error(where + ": expected a JSON object per line");
    parse(object, where);
  }
}

// A finite number under key, or an error naming it; optional keys return fallback when absent.
double number(const json& object, const char* key, const std::string& where, double min, double max) {
  const auto found = object.find(key);
  if (found == object.end()) throw std::runtime_error(where + ": missing \"" + key + "\"");
  if (!found->is_number()) throw std::runtime_error(where + ": \"" + key + "\" must be a number");
  const double value = found->get<double>();
  if (!std::isfinite(value) || value < min || value > max) {
    throw std::runtime_error(where + ": \"" + key + "\" = " + found->dump() + " is outside [" + std::to_string(min) +
                             ", " + std::to_string(max) + "]");
  }
  return value;
}

double optionalNumber(const json& object, const char* key, const std::string& where, double min, double max) {
  return object.contains(key) ? number(object, key, where, min, max) : 0.0;
}

void requireOnlyKeys(const json& object, const std::vector<std::string>& allowed, const std::string& where) {
  for (const auto& item : object.items()) {
    if (std::find(allowed.begin(), allowed.end(), item.key()) == allowed.end()) {
      throw std::runtime_error(where + ": unknown key \"" + item.key() + "\"");
    }
  }
}

// Calls parse(item, where) for every object in the line's "balls" list; where names the item.
// Each object of the line's list under key ("balls": required; others may be left out).
void forEachItem(const json& line, const std::string& key, const std::string& where,
                 const std::function<void(const json&, const std::string&)>& parse, bool required = false) {
  const auto items = line.find(key);
  if (items == line.end() && !required) return;
  if (items == line.end() || !items->is_array()) throw std::runtime_error(where + ": \"" + key + "\" must be a list");
  for (std::size_t i = 0; i < items->size(); ++i) {
    const std::string at = where + ": " + key + "[" + std::to_string(i) + "]";
    if (!(*items)[i].is_object()) throw std::runtime_error(at + ": expected an object");
    parse((*items)[i], at);
  }
}

void forEachBall(const json& line, const std::string& where,
                 const std::function<void(const json&, const std::string&)>& parse) {
  forEachItem(line, "balls", where, parse, true);
}

// A ball or a robot the omni camera saw: its bearing and distance, and their sigmas when given.
template <typename OmniObservation>
OmniObservation omniSighting(const json& item, const std::string& at) {
  requireOnlyKeys(item, {"bearing_rad", "distance_m", "sigma_bearing_rad", "sigma_distance_m"}, at);
  OmniObservation seen;
  seen.bearing_rad = number(item, "bearing_rad", at, -2.0 * M_PI, 2.0 * M_PI);
  seen.distance_m = number(item, "distance_m", at, 0.0, 100.0);
  seen.bearing_sigma_rad = optionalNumber(item, "sigma_bearing_rad", at, 0.0, M_PI);
  seen.distance_sigma_m = optionalNumber(item, "sigma_distance_m", at, 0.0, 100.0);
  return seen;
}

// Times are seconds on the source's clock; anything before 0 or past the year 2100 is a unit slip.
constexpr double kMaxTime_s = 4.1e9;

void writeLines(const std::string& path, const std::vector<json>& lines) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  for (const json& line : lines) out << line.dump() << '\n';
  if (!out.flush()) throw std::runtime_error(path + ": write failed");
}

json vector3(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

}  // namespace

std::vector<fw::OmniFrame> readOmniFile(const std::string& path, const std::string& source) {
  std::vector<fw::OmniFrame> frames;
  forEachLine(path, [&](const json& object, const std::string& where) {
    requireOnlyKeys(object, {"t", "balls", "robots"}, where);
    fw::OmniFrame frame;
    frame.stamp.source_time_s = frame.stamp.receive_time_s = number(object, "t", where, 0.0, kMaxTime_s);
    forEachBall(object, where, [&](const json& item, const std::string& at) {
      fw::OmniBallObservation ball = omniSighting<fw::OmniBallObservation>(item, at);
      ball.source = source;
      ball.stamp = frame.stamp;
      frame.balls.push_back(ball);
    });
    forEachItem(object, "robots", where, [&](const json& item, const std::string& at) {
      frame.robots.push_back(omniSighting<fw::OmniRobotObservation>(item, at));
    });
    frames.push_back(std::move(frame));
  });
  return frames;
}

std::vector<fw::BallFrame> readDetectionsFile(const std::string& path, const std::string& source) {
  std::vector<fw::BallFrame> frames;
  forEachLine(path, [&](const json& object, const std::string& where) {
    requireOnlyKeys(object, {"frame", "t", "balls", "process_ms", "trajectory"}, where);
    fw::BallFrame frame;
    frame.stamp.source_time_s = frame.stamp.receive_time_s = number(object, "t", where, 0.0, kMaxTime_s);
    forEachBall(object, where, [&](const json& item, const std::string& at) {
      requireOnlyKeys(item, {"x", "y", "z", "state", "points", "static", "colour"}, at);
      const Eigen::Vector3d p(number(item, "x", at, -100.0, 100.0), number(item, "y", at, -100.0, 100.0),
                              number(item, "z", at, -100.0, 100.0));
      const auto state = item.find("state");
      if (state == item.end() || !state->is_string() || (*state != "air" && *state != "ground")) {
        throw std::runtime_error(at + ": \"state\" must be \"air\" or \"ground\"");
      }
      fw::BallObservation ball = fw::BallObservation::inRobotFrame(
          p, Eigen::Matrix3d::Identity() * 1e-4, *state == "air" ? fw::BallState::kAir : fw::BallState::kGround, source,
          frame.stamp);
      if (const auto colour = item.find("colour"); colour != item.end()) {
        try {
          ball.colour = fw::colourVerdictFrom(colour->is_string() ? colour->get<std::string>() : colour->dump());
        } catch (const std::invalid_argument& e) {
          throw std::runtime_error(at + ": \"colour\": " + e.what());
        }
      }
      frame.balls.push_back(ball);
    });
    frames.push_back(std::move(frame));
  });
  return frames;
}

void writeOmniFile(const std::string& path, const std::vector<fw::OmniFrame>& frames) {
  std::vector<json> lines;
  for (const fw::OmniFrame& frame : frames) {
    const auto sighting = [](const auto& seen) {
      json item{{"bearing_rad", seen.bearing_rad}, {"distance_m", seen.distance_m}};
      if (seen.bearing_sigma_rad > 0.0) item["sigma_bearing_rad"] = seen.bearing_sigma_rad;
      if (seen.distance_sigma_m > 0.0) item["sigma_distance_m"] = seen.distance_sigma_m;
      return item;
    };
    json balls = json::array(), robots = json::array();
    for (const fw::OmniBallObservation& ball : frame.balls) balls.push_back(sighting(ball));
    for (const fw::OmniRobotObservation& robot : frame.robots) robots.push_back(sighting(robot));
    json line{{"t", frame.stamp.source_time_s}, {"balls", balls}};
    if (!robots.empty()) line["robots"] = robots;
    lines.push_back(line);
  }
  writeLines(path, lines);
}

std::vector<fw::RobotPose> readPoseFile(const std::string& path) {
  std::vector<fw::RobotPose> poses;
  forEachLine(path, [&](const json& object, const std::string& where) {
    requireOnlyKeys(object, {"t", "x_m", "y_m", "theta_rad", "odometry"}, where);
    fw::RobotPose pose;
    pose.stamp.source_time_s = pose.stamp.receive_time_s = number(object, "t", where, 0.0, kMaxTime_s);
    pose.x_m = number(object, "x_m", where, -100.0, 100.0);
    pose.y_m = number(object, "y_m", where, -100.0, 100.0);
    pose.theta_rad = number(object, "theta_rad", where, -4.0 * M_PI, 4.0 * M_PI);
    if (object.contains("odometry")) {
      const json& odometry = object.at("odometry");
      const std::string odometry_where = where + ", odometry";
      if (!odometry.is_object())
        throw std::runtime_error(odometry_where + ": expected an object {x_m, y_m, theta_rad}");
      requireOnlyKeys(odometry, {"x_m", "y_m", "theta_rad"}, odometry_where);
      // The odometry's frame is its own: it drifts without bound over a long match, and turns add up.
      pose.odometry = fw::RobotPose::Odometry{number(odometry, "x_m", odometry_where, -1e4, 1e4),
                                              number(odometry, "y_m", odometry_where, -1e4, 1e4),
                                              number(odometry, "theta_rad", odometry_where, -1e6, 1e6)};
    }
    poses.push_back(pose);
  });
  return poses;
}

void writePoseFile(const std::string& path, const std::vector<fw::RobotPose>& poses) {
  std::vector<json> lines;
  for (const fw::RobotPose& pose : poses) {
    json line{{"t", pose.stamp.source_time_s}, {"x_m", pose.x_m}, {"y_m", pose.y_m}, {"theta_rad", pose.theta_rad}};
    if (const auto& odometry = pose.odometry) {
      line["odometry"] = {{"x_m", odometry->x_m}, {"y_m", odometry->y_m}, {"theta_rad", odometry->theta_rad}};
    }
    lines.push_back(line);
  }
  writeLines(path, lines);
}

void writeFusedFile(const std::string& path, const std::vector<FusionUpdate>& updates) {
  std::vector<json> lines;
  for (const FusionUpdate& update : updates) {
    json line{{"t", update.time_s}, {"ball", nullptr}};
    if (const auto& ball = update.ball) {
      line["ball"] = {{"field", vector3(ball->position_F)},   {"robot", vector3(ball->position_R)},
                      {"v_field", vector3(ball->velocity_F)}, {"state", fw::toString(ball->state)},
                      {"sigma_m", ball->sigmaHorizontal_m()}, {"sources", ball->sources}};
    }
    lines.push_back(std::move(line));
  }
  writeLines(path, lines);
}

}  // namespace fusion
