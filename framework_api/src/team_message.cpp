#include "framework_api/team_message.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>

#include <Eigen/Eigenvalues>

#define MSGPACK_NO_BOOST
#include <msgpack.hpp>

namespace fw {

void TeamMessage::shiftTimes(double delta_s) {
  sent_time_s += delta_s;
  if (pose) pose->stamp.source_time_s += delta_s;
  for (BallObservation& ball : kinect_balls) ball.stamp.source_time_s += delta_s;
  for (BallRay& ray : omni_rays) ray.time_s += delta_s;
  for (SeenRobot& robot : robots_seen) robot.time_s += delta_s;
  if (world_ball) {
    world_ball->stamp.source_time_s += delta_s;
    if (world_ball->goal_crossing) world_ball->goal_crossing->time_s += delta_s;
  }
  if (touchdown) touchdown->time_s += delta_s;
  for (ClockEcho& echo : echoes) echo.received_s += delta_s;  // their_sent_s is on the echoed robot's clock
}

namespace {

using Packer = msgpack::packer<msgpack::sbuffer>;

void packVector(Packer& pk, const double* values, int n) {
  pk.pack_array(static_cast<std::uint32_t>(n));
  for (int i = 0; i < n; ++i) pk.pack_double(values[i]);
}
void packVector(Packer& pk, const Eigen::Vector3d& v) { packVector(pk, v.data(), 3); }
// A covariance as its upper triangle: xx, xy, xz, yy, yz, zz.
void packCovariance(Packer& pk, const Eigen::Matrix3d& c) {
  const double upper[6] = {c(0, 0), c(0, 1), c(0, 2), c(1, 1), c(1, 2), c(2, 2)};
  packVector(pk, upper, 6);
}
void packKey(Packer& pk, const char* key) { pk.pack(std::string(key)); }
void packEntry(Packer& pk, const char* key, double value) {
  packKey(pk, key);
  pk.pack_double(value);
}

void packPose(Packer& pk, const TeamMessage& m) {
  pk.pack_map(6);
  packEntry(pk, "x", m.pose->x_m);
  packEntry(pk, "y", m.pose->y_m);
  packEntry(pk, "theta", m.pose->theta_rad);
  packEntry(pk, "t", m.pose->stamp.source_time_s);
  packEntry(pk, "sigma_xy", m.pose_sigma_xy_m);
  packEntry(pk, "sigma_theta", m.pose_sigma_theta_rad);
}

void packKinectBall(Packer& pk, const BallObservation& b) {
  pk.pack_map(7);
  packKey(pk, "p");
  packVector(pk, b.position_m);
  packKey(pk, "cov");
  packCovariance(pk, b.covariance_m2);
  packEntry(pk, "t", b.stamp.source_time_s);
  packKey(pk, "air");
  pk.pack(b.state == BallState::kAir);
  packKey(pk, "static");
  pk.pack(b.is_static);
  packKey(pk, "support");
  pk.pack(b.support_points);
  packKey(pk, "colour");
  pk.pack(std::string(toString(b.colour)));
}

void packRay(Packer& pk, const BallRay& r) {
  pk.pack_map(6);
  packKey(pk, "origin");
  packVector(pk, r.origin_F);
  packKey(pk, "dir");
  packVector(pk, r.direction_F);
  packEntry(pk, "sigma_bearing", r.bearing_sigma_rad);
  packEntry(pk, "sigma_elevation", r.elevation_sigma_rad);
  packEntry(pk, "view_top", r.view_top_m);
  packEntry(pk, "t", r.time_s);
}

void packSeenRobot(Packer& pk, const SeenRobot& r) {
  pk.pack_map(3);
  packKey(pk, "p");
  packVector(pk, r.position_F.data(), 2);
  packKey(pk, "cov");  // xx, xy, yy
  const double upper[3] = {r.covariance_m2(0, 0), r.covariance_m2(0, 1), r.covariance_m2(1, 1)};
  packVector(pk, upper, 3);
  packEntry(pk, "t", r.time_s);
}

void packWorldBall(Packer& pk, const FusedBall& b) {
  pk.pack_map(8 + (b.goal_crossing ? 1 : 0));
  packKey(pk, "p");
  packVector(pk, b.position_F);
  packKey(pk, "v");
  packVector(pk, b.velocity_F);
  packKey(pk, "cov");
  packCovariance(pk, b.covariance_F);
  packEntry(pk, "t", b.stamp.source_time_s);
  packKey(pk, "air");
  pk.pack(b.state == BallState::kAir);
  packEntry(pk, "air_probability", b.air_probability);
  packEntry(pk, "age", b.age_s);
  packKey(pk, "sources");
  pk.pack(b.sources);
  if (const auto& c = b.goal_crossing) {
    packKey(pk, "goal_crossing");
    pk.pack_map(6);
    packKey(pk, "goal");
    pk.pack(c->goal);
    packEntry(pk, "x", c->x_m);
    packEntry(pk, "z", c->z_m);
    packEntry(pk, "t", c->time_s);
    packEntry(pk, "sigma", c->sigma_m);
    packEntry(pk, "t_sigma", c->time_sigma_s);
  }
}

// The league's MixedTeamProtocol ball, for a teammate that reads only that: field frame, and a
// confidence that falls from 1 to 0 over the second after the ball's last support.
void packMixedTeamBall(Packer& pk, const FusedBall& b) {
  pk.pack_map(7);
  packEntry(pk, "x", b.position_F.x());
  packEntry(pk, "y", b.position_F.y());
  packEntry(pk, "z", b.position_F.z());
  packEntry(pk, "vx", b.velocity_F.x());
  packEntry(pk, "vy", b.velocity_F.y());
  packEntry(pk, "vz", b.velocity_F.z());
  packEntry(pk, "confidence", std::clamp(1.0 - b.age_s, 0.0, 1.0));
}

struct Fields;

// Reading: every accessor names the key path it reads, so an error says which field was wrong.
class Reader {
 public:
  Reader(const msgpack::object& object, std::string path) : object_(object), path_(std::move(path)) {}

  // The map's entries by key (a map is required).
  Fields entries() const;
  std::vector<Reader> items() const {
    if (object_.type != msgpack::type::ARRAY) fail("a list");
    std::vector<Reader> out;
    for (std::uint32_t i = 0; i < object_.via.array.size; ++i) {
      out.emplace_back(object_.via.array.ptr[i], path_ + "[" + std::to_string(i) + "]");
    }
    return out;
  }
  double number() const {
    double value = 0.0;
    switch (object_.type) {
      case msgpack::type::FLOAT32:
      case msgpack::type::FLOAT64:
        value = object_.via.f64;
        break;
      case msgpack::type::POSITIVE_INTEGER:
        value = static_cast<double>(object_.via.u64);
        break;
      case msgpack::type::NEGATIVE_INTEGER:
        value = static_cast<double>(object_.via.i64);
        break;
      default:
        fail("a number");
    }
    if (!std::isfinite(value)) fail("a finite number");
    return value;
  }
  int integer(int min, int max) const {
    const double value = number();
    if (value != std::floor(value) || value < min || value > max) {
      fail("an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]");
    }
    return static_cast<int>(value);
  }
  bool boolean() const {
    if (object_.type != msgpack::type::BOOLEAN) fail("true or false");
    return object_.via.boolean;
  }
  std::string text() const {
    if (object_.type != msgpack::type::STR) fail("text");
    return std::string(object_.via.str.ptr, object_.via.str.size);
  }
  std::vector<double> numbers(std::size_t n) const {
    const std::vector<Reader> list = items();
    if (list.size() != n) fail("a list of " + std::to_string(n) + " numbers");
    std::vector<double> out;
    for (const Reader& item : list) out.push_back(item.number());
    return out;
  }
  // A number in [min, max]: positions and speeds on a field, sigmas that are not negative.
  double number(double min, double max) const {
    const double value = number();
    if (value < min || value > max) fail("a number in [" + std::to_string(min) + ", " + std::to_string(max) + "]");
    return value;
  }
  // A position or a velocity: each coordinate within kMaxCoordinate, far beyond any field.
  Eigen::Vector3d vector3() const {
    const std::vector<double> v = numbers(3);
    for (const double x : v) {
      if (std::abs(x) > kMaxCoordinate) fail("a vector whose coordinates are within " + std::to_string(kMaxCoordinate));
    }
    return {v[0], v[1], v[2]};
  }
  // A covariance: symmetric positive semi-definite, no variance beyond kMaxVariance.
  Eigen::Matrix3d covariance() const {
    const std::vector<double> u = numbers(6);
    Eigen::Matrix3d c;
    c << u[0], u[1], u[2], u[1], u[3], u[4], u[2], u[4], u[5];
    return checkedCovariance(c);
  }
  // The same on the floor: xx, xy, yy.
  Eigen::Matrix2d covariance2() const {
    const std::vector<double> u = numbers(3);
    Eigen::Matrix2d c;
    c << u[0], u[1], u[1], u[2];
    return checkedCovariance(c);
  }
  static constexpr double kMaxCoordinate = 1e4;  // metres, metres per second
  static constexpr double kMaxVariance = 1e4;    // m^2
  template <typename Matrix>
  Matrix checkedCovariance(const Matrix& c) const {
    const auto eigenvalues = Eigen::SelfAdjointEigenSolver<Matrix>(c).eigenvalues();
    if (!(eigenvalues.minCoeff() >= -1e-12) || eigenvalues.maxCoeff() > kMaxVariance) {
      fail("a covariance (positive semi-definite, variances up to " + std::to_string(kMaxVariance) + ")");
    }
    return c;
  }
  [[noreturn]] void fail(const std::string& expected) const {
    throw TeamMessageError("team message field '" + path_ + "': expected " + expected);
  }

 private:
  msgpack::object object_;
  std::string path_;
};

// A map's entries by key, with the map's path for errors.
struct Fields {
  std::map<std::string, Reader> entries;
  std::string path;

  // The entry under key; a missing one is an error naming it.
  const Reader& operator[](const std::string& key) const;
  // Calls read on the entry under key when there is one.
  void ifPresent(const std::string& key, const std::function<void(const Reader&)>& read) const;
};

Fields Reader::entries() const {
  if (object_.type != msgpack::type::MAP) fail("a map");
  Fields out{{}, path_};
  for (std::uint32_t i = 0; i < object_.via.map.size; ++i) {
    const msgpack::object_kv& kv = object_.via.map.ptr[i];
    if (kv.key.type != msgpack::type::STR) fail("a map with text keys");
    const std::string key(kv.key.via.str.ptr, kv.key.via.str.size);
    out.entries.emplace(key, Reader(kv.val, path_.empty() ? key : path_ + "." + key));
  }
  return out;
}

const Reader& Fields::operator[](const std::string& key) const {
  const auto found = entries.find(key);
  if (found == entries.end()) {
    throw TeamMessageError("team message field '" + (path.empty() ? key : path + "." + key) + "' is missing");
  }
  return found->second;
}

void Fields::ifPresent(const std::string& key, const std::function<void(const Reader&)>& read) const {
  const auto found = entries.find(key);
  if (found != entries.end()) read(found->second);
}

BallObservation readKinectBall(const Reader& reader) {
  const auto m = reader.entries();
  BallObservation b;
  b.frame = Frame::kField;
  b.position_m = m["p"].vector3();
  b.covariance_m2 = m["cov"].covariance();
  b.stamp.source_time_s = m["t"].number();
  b.state = m["air"].boolean() ? BallState::kAir : BallState::kGround;
  b.is_static = m["static"].boolean();
  b.support_points = m["support"].integer(0, 1 << 30);
  const Reader& colour = m["colour"];
  try {
    b.colour = colourVerdictFrom(colour.text());
  } catch (const std::invalid_argument&) {
    colour.fail("a colour verdict");
  }
  return b;
}

}  // namespace

std::string packTeamMessage(const TeamMessage& m) {
  msgpack::sbuffer buffer;
  Packer pk(&buffer);
  const int entries = 6 + (m.pose ? 1 : 0) + (m.world_ball ? 2 : 0) + (m.touchdown ? 1 : 0);
  pk.pack_map(static_cast<std::uint32_t>(entries));
  packKey(pk, "name");
  pk.pack(m.robot_name);
  packEntry(pk, "sent", m.sent_time_s);
  if (m.pose) {
    packKey(pk, "pose");
    packPose(pk, m);
  }
  packKey(pk, "kinect_balls");
  pk.pack_array(static_cast<std::uint32_t>(m.kinect_balls.size()));
  for (const BallObservation& b : m.kinect_balls) packKinectBall(pk, b);
  packKey(pk, "omni_rays");
  pk.pack_array(static_cast<std::uint32_t>(m.omni_rays.size()));
  for (const BallRay& r : m.omni_rays) packRay(pk, r);
  packKey(pk, "robots_seen");
  pk.pack_array(static_cast<std::uint32_t>(m.robots_seen.size()));
  for (const SeenRobot& r : m.robots_seen) packSeenRobot(pk, r);
  if (m.world_ball) {
    packKey(pk, "world_ball");
    packWorldBall(pk, *m.world_ball);
    packKey(pk, "ball");
    packMixedTeamBall(pk, *m.world_ball);
  }
  if (m.touchdown) {
    packKey(pk, "touchdown");
    pk.pack_map(3);
    packKey(pk, "p");
    packVector(pk, m.touchdown->point_m.data(), 2);
    packEntry(pk, "t", m.touchdown->time_s);
    packEntry(pk, "sigma", m.touchdown->sigma_m);
  }
  packKey(pk, "echoes");
  pk.pack_array(static_cast<std::uint32_t>(m.echoes.size()));
  for (const ClockEcho& e : m.echoes) {
    pk.pack_map(3);
    packKey(pk, "robot");
    pk.pack(e.robot_id);
    packEntry(pk, "their_sent", e.their_sent_s);
    packEntry(pk, "received", e.received_s);
  }
  return std::string(buffer.data(), buffer.size());
}

TeamMessage unpackTeamMessage(const std::uint8_t* data, std::size_t size) {
  // Bounds far above any real message, so a forged length cannot make the reader allocate gigabytes.
  const msgpack::unpack_limit limits(/*array=*/4096, /*map=*/64, /*str=*/1024, /*bin=*/0, /*ext=*/0, /*depth=*/8);
  msgpack::object_handle handle;
  std::size_t used = 0;
  try {
    handle = msgpack::unpack(reinterpret_cast<const char*>(data), size, used, nullptr, nullptr, limits);
  } catch (const std::exception& e) {
    throw TeamMessageError(std::string("team message: not msgpack (") + e.what() + ")");
  }
  if (used != size) throw TeamMessageError("team message: " + std::to_string(size - used) + " bytes after its end");
  const auto root = Reader(handle.get(), "").entries();
  TeamMessage m;
  m.robot_name = root["name"].text();
  m.sent_time_s = root["sent"].number();
  root.ifPresent("pose", [&](const Reader& r) {
    const auto p = r.entries();
    RobotPose pose;
    pose.x_m = p["x"].number(-Reader::kMaxCoordinate, Reader::kMaxCoordinate);
    pose.y_m = p["y"].number(-Reader::kMaxCoordinate, Reader::kMaxCoordinate);
    pose.theta_rad = p["theta"].number(-1e3, 1e3);
    pose.stamp.source_time_s = p["t"].number();
    m.pose = pose;
    m.pose_sigma_xy_m = p["sigma_xy"].number(0.0, 1e3);
    m.pose_sigma_theta_rad = p["sigma_theta"].number(0.0, 1e3);
  });
  for (const Reader& r : root["kinect_balls"].items()) m.kinect_balls.push_back(readKinectBall(r));
  for (const Reader& r : root["omni_rays"].items()) {
    const auto e = r.entries();
    BallRay ray;
    ray.origin_F = e["origin"].vector3();
    ray.direction_F = e["dir"].vector3();
    if (std::abs(ray.direction_F.norm() - 1.0) > 1e-3) e["dir"].fail("a unit vector");
    ray.bearing_sigma_rad = e["sigma_bearing"].number(0.0, 1e3);
    ray.elevation_sigma_rad = e["sigma_elevation"].number(0.0, 1e3);
    ray.view_top_m = e["view_top"].number(-1e3, 1e3);
    ray.time_s = e["t"].number();
    m.omni_rays.push_back(ray);
  }
  // Added within wire version 1: older senders leave it out.
  root.ifPresent("robots_seen", [&](const Reader& list) {
    for (const Reader& r : list.items()) {
      const auto e = r.entries();
      const std::vector<double> p = e["p"].numbers(2);
      for (const double x : p) {
        if (std::abs(x) > Reader::kMaxCoordinate) e["p"].fail("a point within the field's bounds");
      }
      m.robots_seen.push_back({{p[0], p[1]}, e["cov"].covariance2(), e["t"].number()});
    }
  });
  root.ifPresent("world_ball", [&](const Reader& r) {
    const auto e = r.entries();
    FusedBall b;
    b.position_F = e["p"].vector3();
    b.velocity_F = e["v"].vector3();
    b.covariance_F = e["cov"].covariance();
    b.stamp.source_time_s = e["t"].number();
    b.state = e["air"].boolean() ? BallState::kAir : BallState::kGround;
    b.air_probability = e["air_probability"].number(0.0, 1.0);
    b.age_s = e["age"].number(0.0, 1e9);
    for (const Reader& s : e["sources"].items()) b.sources.push_back(s.text());
    e.ifPresent("goal_crossing", [&](const Reader& c) {
      const auto f = c.entries();
      const int goal = f["goal"].integer(-1, 1);
      if (goal == 0) f["goal"].fail("-1 or 1");
      b.goal_crossing = GoalCrossing{goal,
                                     f["x"].number(-Reader::kMaxCoordinate, Reader::kMaxCoordinate),
                                     f["z"].number(-Reader::kMaxCoordinate, Reader::kMaxCoordinate),
                                     f["t"].number(),
                                     f["sigma"].number(0.0, 1e3),
                                     f["t_sigma"].number(0.0, 1e3)};
    });
    m.world_ball = b;
  });
  root.ifPresent("touchdown", [&](const Reader& r) {
    const auto e = r.entries();
    const std::vector<double> p = e["p"].numbers(2);
    m.touchdown = Touchdown{{p[0], p[1]}, e["t"].number(), e["sigma"].number(0.0, 1e3)};
  });
  for (const Reader& r : root["echoes"].items()) {
    const auto e = r.entries();
    m.echoes.push_back({e["robot"].integer(0, 255), e["their_sent"].number(), e["received"].number()});
  }
  return m;
}

}  // namespace fw
