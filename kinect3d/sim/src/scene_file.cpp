// Scene files: YAML read through framework_api's document reader, so every error names the file,
// line and key. The format is documented in docs/simulator.md.
#include <cmath>
#include <filesystem>
#include <map>

#include "builtin_scenes.h"
#include "kinect3d/config_io.h"
#include "kinect3d/sim/people.h"
#include "kinect3d/sim/scene.h"

namespace kinect3d::sim {

namespace {

// Optional keys: absent keeps the default in `value`, present is checked like any other value.
void readOptional(const fw::ConfigView& view, const std::string& key, double& value, double min, double max) {
  if (view.has(key)) value = view.getDouble(key, min, max);
}
void readOptional(const fw::ConfigView& view, const std::string& key, bool& value) {
  if (view.has(key)) value = view.getBool(key);
}

Eigen::Vector3d vector3(const fw::ConfigView& view, const std::string& key) {
  const std::vector<double> v = view.getDoubleList(key, 3);
  return {v[0], v[1], v[2]};
}

// Standard obstacles, sized from the MSL rules and the reference notes.
std::vector<Shape> shapesOf(const fw::ConfigView& object, const std::string& type) {
  const Eigen::Vector3d base = vector3(object, "center");
  const double yaw = object.has("yaw_deg") ? degreesToRadians(object.getDouble("yaw_deg", -360, 360)) : 0.0;
  const double dropout = object.has("dropout") ? object.getDouble("dropout", 0.0, 1.0) : 0.0;
  auto box = [&](Eigen::Vector3d offset, Eigen::Vector3d size) {
    const Eigen::Vector3d center = base + Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * offset;
    return Shape{Shape::Kind::kBox, center, size, yaw, dropout};
  };
  if (type == "box") return {Shape{Shape::Kind::kBox, base, vector3(object, "size"), yaw, dropout}};
  if (type == "cylinder" || type == "sphere") {
    const double r = object.getDouble("radius", 0.01, 10.0);
    if (type == "sphere") return {Shape{Shape::Kind::kSphere, base, Eigen::Vector3d::Constant(2 * r), 0.0, dropout}};
    return {Shape{Shape::Kind::kCylinder, base, {2 * r, 2 * r, object.getDouble("height", 0.01, 20.0)}, 0.0, dropout}};
  }
  auto made_of = [](Shape shape, Surface surface) {
    shape.surface = surface;
    return shape;
  };
  if (type == "robot") {
    // An MSL robot: at most 0.52 m across and 0.80 m tall; centre given on the floor.
    const Eigen::Vector3d size = object.has("size") ? vector3(object, "size") : Eigen::Vector3d(0.5, 0.5, 0.78);
    return {made_of(box({0, 0, size.z() / 2}, size), Surface::kRobot)};
  }
  if (type == "human") {
    // Legs, torso and head of an adult; centre given on the floor between the feet.
    return {made_of(box({-0.1, 0, 0.45}, {0.14, 0.16, 0.9}), Surface::kTrousers),
            made_of(box({0.1, 0, 0.45}, {0.14, 0.16, 0.9}), Surface::kTrousers),
            made_of(box({0, 0, 1.2}, {0.42, 0.24, 0.62}), Surface::kShirt),
            made_of(Shape::sphere(base + Eigen::Vector3d(0, 0, 1.64), 0.11, dropout), Surface::kSkin)};
  }
  if (type == "person") {
    // An articulated person (kinect3d/sim/people.h); centre given on the floor between the feet.
    Person person;
    person.feet_m = base;
    person.yaw_rad = yaw;
    if (object.has("height")) person.height_m = object.getDouble("height", 1.0, 2.3);
    if (object.has("build")) person.build = object.getDouble("build", 0.6, 1.5);
    if (object.has("stride_deg")) person.stride_rad = degreesToRadians(object.getDouble("stride_deg", 0.0, 40.0));
    person.clothes_dropout = dropout;
    if (object.has("hair_dropout")) person.hair_dropout = object.getDouble("hair_dropout", 0.0, 1.0);
    for (const auto& [key, side] : {std::pair{"left_arm", -1.0}, std::pair{"right_arm", 1.0}}) {
      if (!object.has(key)) continue;
      const std::vector<std::string> names = gestureNames();
      const ArmPose arm = ArmPose::of(gestureNamed(object.getChoice(key, {names.begin(), names.end()})), side);
      (side < 0 ? person.left_arm : person.right_arm) = arm;
    }
    return person.shapes();
  }
  if (type == "goal") {
    // 2.0 m wide, 1.0 m high inside, 0.125 m posts; the net is invisible to the projector.
    const double post = 0.125;
    return {made_of(box({-1.0 - post / 2, 0, 0.5 + post / 2}, {post, post, 1.0 + post}), Surface::kGoal),
            made_of(box({1.0 + post / 2, 0, 0.5 + post / 2}, {post, post, 1.0 + post}), Surface::kGoal),
            made_of(box({0, 0, 1.0 + post / 2}, {2.0 + 2 * post, post, post}), Surface::kGoal)};
  }
  throw std::runtime_error(object.originOf("type") + ": " + object.path() + ".type = '" + type +
                           "' is unknown; expected box, cylinder, sphere, robot, human, person or goal");
}

// Waypoints [[x, y], ...] under key.
std::vector<Eigen::Vector2d> readPath(const fw::ConfigView& view, const std::string& key) {
  std::vector<Eigen::Vector2d> path;
  const std::size_t points = view.listSize(key);
  for (std::size_t i = 0; i < points; ++i) {
    const std::vector<double> xy = view.getDoubleList(key + "." + std::to_string(i), 2);
    path.emplace_back(xy[0], xy[1]);
  }
  return path;
}

CarrierRobot readCarrier(const fw::ConfigView& robot) {
  robot.requireOnlyKeys({"pose", "path", "speed_mps", "turn_rate_deg_s", "swing_deg", "swing_period_s"});
  CarrierRobot carrier;
  if (robot.has("pose")) {
    const fw::ConfigView pose = robot.child("pose");
    pose.requireOnlyKeys({"x", "y", "theta_deg"});
    carrier.x_m = pose.getDouble("x", -20.0, 20.0);
    carrier.y_m = pose.getDouble("y", -20.0, 20.0);
    carrier.theta_rad = degreesToRadians(pose.getDouble("theta_deg", -360.0, 360.0));
  }
  if (robot.has("path")) {
    carrier.path_m = readPath(robot, "path");
    carrier.speed_mps = robot.getDouble("speed_mps", 0.0, 10.0);
    if (!robot.has("pose") && !carrier.path_m.empty()) {
      carrier.x_m = carrier.path_m.front().x();
      carrier.y_m = carrier.path_m.front().y();
    }
    const Eigen::Vector2d start(carrier.x_m, carrier.y_m);
    if (!carrier.path_m.empty() && (carrier.path_m.front() - start).norm() > 1e-6) {
      throw fw::ConfigError(robot.originOf("path") + ": " + robot.path() +
                            ".path must start where robot.pose stands (a path walks from its first waypoint)");
    }
  }
  if (robot.has("turn_rate_deg_s")) {
    carrier.turn_rate_radps = degreesToRadians(robot.getDouble("turn_rate_deg_s", -720.0, 720.0));
  }
  if (robot.has("swing_deg")) carrier.swing_rad = degreesToRadians(robot.getDouble("swing_deg", 0.0, 180.0));
  if (robot.has("swing_period_s")) carrier.swing_period_s = robot.getDouble("swing_period_s", 0.1, 60.0);
  return carrier;
}

SceneObject readObject(const fw::ConfigView& object) {
  object.requireOnlyKeys({"type", "center", "size", "radius", "height", "yaw_deg", "dropout", "path", "speed_mps",
                          "build", "stride_deg", "hair_dropout", "left_arm", "right_arm", "surface", "colour"});
  SceneObject result;
  result.type = object.getChoice("type", {"box", "cylinder", "sphere", "robot", "human", "person", "goal"});
  result.shapes = shapesOf(object, result.type);
  // What a plain box, cylinder or sphere is, for the colour camera; and a colour fixed by the file
  // (otherwise drawn from the scene's seed).
  if (object.has("surface")) {
    if (result.type != "box" && result.type != "cylinder" && result.type != "sphere") {
      throw fw::ConfigError(object.originOf("surface") + ": " + object.path() +
                            ".surface is for a box, cylinder or sphere; a " + result.type + " has its own");
    }
    const std::string surface = object.getChoice("surface", {"plain", "lamp", "loudspeaker", "poster"});
    for (Shape& shape : result.shapes) {
      shape.surface = surface == "lamp"          ? Surface::kLamp
                      : surface == "loudspeaker" ? Surface::kLoudspeaker
                      : surface == "poster"      ? Surface::kPoster
                                                 : Surface::kPlain;
    }
  }
  if (object.has("colour")) {
    const std::vector<double> rgb = object.getDoubleList("colour", 3);
    for (const double c : rgb) {
      if (c < 0.0 || c > 1.0) {
        throw fw::ConfigError(object.originOf("colour") + ": " + object.path() +
                              ".colour is linear RGB, each between 0 and 1");
      }
    }
    // A person's colour is the shirt's; skin and hair keep theirs.
    const bool person = result.type == "person" || result.type == "human";
    for (Shape& shape : result.shapes) {
      if (!person || shape.surface == Surface::kShirt) shape.albedo = Eigen::Vector3d(rgb[0], rgb[1], rgb[2]);
    }
  }
  if (object.has("path")) {
    // Waypoints [[x, y], ...]; the object walks them back and forth, starting at the first.
    result.path_m = readPath(object, "path");
    result.speed_mps = object.getDouble("speed_mps", 0.0, 15.0);
  }
  return result;
}

KinectNoise readNoise(const fw::ConfigView& view) {
  view.requireOnlyKeys({"baseline_m", "quantisation", "axial_noise", "axial_noise_scale", "lateral_noise_px", "shadows",
                        "edge_dropout", "flying_pixels", "exposure_s", "trail_dropout", "random_dropout",
                        "interference", "min_range_m", "max_range_m", "seed"});
  KinectNoise n;
  readOptional(view, "baseline_m", n.baseline_m, 0.01, 0.5);
  readOptional(view, "quantisation", n.quantisation);
  readOptional(view, "axial_noise", n.axial_noise);
  readOptional(view, "axial_noise_scale", n.axial_noise_scale, 0.25, 4.0);
  readOptional(view, "lateral_noise_px", n.lateral_noise_px, 0.0, 5.0);
  readOptional(view, "shadows", n.shadows);
  readOptional(view, "edge_dropout", n.edge_dropout, 0.0, 1.0);
  readOptional(view, "flying_pixels", n.flying_pixels, 0.0, 1.0);
  readOptional(view, "exposure_s", n.exposure_s, 0.0, 0.033);
  readOptional(view, "trail_dropout", n.trail_dropout, 0.0, 1.0);
  readOptional(view, "random_dropout", n.random_dropout, 0.0, 1.0);
  readOptional(view, "interference", n.interference, 0.0, 1.0);
  readOptional(view, "min_range_m", n.min_range_m, 0.1, 20.0);
  readOptional(view, "max_range_m", n.max_range_m, n.min_range_m, 20.0);
  if (view.has("seed")) n.seed = static_cast<std::uint64_t>(view.getInt("seed", 0, 2147483647));
  return n;
}

ColourLook readLook(const fw::ConfigView& view) {
  view.requireOnlyKeys({"ball", "light", "light_gradient", "exposure_s", "noise"});
  const std::vector<std::string> balls = ColourLook::ballNames();
  ColourLook look = ColourLook::withBall(view.has("ball") ? view.getChoice("ball", {balls.begin(), balls.end()})
                                                          : std::string("orange"));
  readOptional(view, "light", look.light, 0.05, 5.0);
  readOptional(view, "light_gradient", look.light_gradient, 0.0, 0.9);
  readOptional(view, "exposure_s", look.exposure_s, 0.0, 0.1);
  readOptional(view, "noise", look.noise, 0.0, 0.2);
  return look;
}

Scene readScene(const fw::ConfigView& root) {
  root.requireOnlyKeys({"name", "description", "duration_s", "fps", "start_time_s", "robot", "sensor", "noise", "floor",
                        "objects", "ball", "physics", "colour"});
  Scene scene;
  scene.name = root.getString("name");
  scene.duration_s = root.getDouble("duration_s", 0.0, 3600.0);
  readOptional(root, "fps", scene.fps, 1.0, 120.0);
  readOptional(root, "start_time_s", scene.start_time_s, 0.0, 1e10);
  if (root.has("robot")) scene.robot = readCarrier(root.child("robot"));
  const fw::ConfigView sensor = root.child("sensor");
  sensor.requireOnlyKeys({"pose_in_robot", "intrinsics", "knocked"});
  scene.sensor_pose = readSensorPose(sensor.child("pose_in_robot"));
  if (sensor.has("knocked")) {
    const fw::ConfigView knocked = sensor.child("knocked");
    knocked.requireOnlyKeys({"at_s", "pose_in_robot"});
    scene.knock = SensorKnock{knocked.getDouble("at_s", 0.0, 3600.0), readSensorPose(knocked.child("pose_in_robot"))};
  }
  if (sensor.has("intrinsics")) {
    sensor.child("intrinsics").requireOnlyKeys({"width", "height", "fx", "fy", "cx", "cy"});
    scene.intrinsics = readIntrinsics(sensor.child("intrinsics"));
  }
  if (root.has("noise")) scene.noise = readNoise(root.child("noise"));
  if (root.has("colour")) scene.look = readLook(root.child("colour"));
  readOptional(root, "floor", scene.floor);
  if (root.has("objects")) {
    for (const fw::ConfigView& object : root.childList("objects")) {
      scene.objects.push_back(readObject(object));
    }
  }
  if (root.has("ball")) {
    const fw::ConfigView ball = root.child("ball");
    ball.requireOnlyKeys({"position", "velocity", "launch_time_s", "hanging", "dark_panels"});
    BallLaunch launch;
    launch.position_m = vector3(ball, "position");
    if (ball.has("velocity")) launch.velocity_mps = vector3(ball, "velocity");
    readOptional(ball, "launch_time_s", launch.launch_time_s, 0.0, 3600.0);
    readOptional(ball, "hanging", launch.hanging);
    readOptional(ball, "dark_panels", launch.dark_panels);
    scene.ball = launch;
  }
  if (root.has("physics")) {
    const fw::ConfigView physics = root.child("physics");
    physics.requireOnlyKeys({"radius_m", "gravity_mps2", "drag_per_m", "restitution", "bounce_friction",
                             "rolling_decel_mps2", "spin_rps", "magnus_m"});
    BallPhysics& p = scene.physics;
    readOptional(physics, "radius_m", p.radius_m, 0.01, 1.0);
    readOptional(physics, "gravity_mps2", p.gravity_mps2, 0.0, 20.0);
    readOptional(physics, "drag_per_m", p.drag_per_m, 0.0, 1.0);
    readOptional(physics, "restitution", p.restitution, 0.0, 1.0);
    readOptional(physics, "bounce_friction", p.bounce_friction, 0.0, 1.0);
    readOptional(physics, "rolling_decel_mps2", p.rolling_decel_mps2, 0.0, 10.0);
    readOptional(physics, "spin_rps", p.spin_rps, -30.0, 30.0);
    readOptional(physics, "magnus_m", p.magnus_m, 0.0, 0.02);
  }
  return scene;
}

}  // namespace

ColourLook ColourLook::withBall(const std::string& ball) {
  ColourLook look;
  if (ball == "yellow") {
    look.ball_albedo = {0.85, 0.70, 0.03};
  } else if (ball == "white_black") {
    look.ball_albedo = {0.80, 0.80, 0.78};
    look.panel_albedo = Eigen::Vector3d(0.03, 0.03, 0.03);
  } else if (ball != "orange") {
    throw std::invalid_argument("no ball '" + ball + "' (orange, yellow or white_black)");
  }
  return look;
}

std::vector<std::string> ColourLook::ballNames() { return {"orange", "yellow", "white_black"}; }

int Scene::frameCount() const { return static_cast<int>(std::lround(duration_s * fps)); }

Shape Shape::capsule(const Eigen::Vector3d& from_m, const Eigen::Vector3d& to_m, double radius_m, double dropout) {
  Shape shape{Kind::kCapsule, from_m, Eigen::Vector3d::Constant(2 * radius_m), 0.0, dropout};
  shape.axis_m = to_m - from_m;
  return shape;
}

Shape Shape::sphere(const Eigen::Vector3d& center_m, double radius_m, double dropout) {
  return Shape{Kind::kSphere, center_m, Eigen::Vector3d::Constant(2 * radius_m), 0.0, dropout};
}

double Shape::bottom_m() const {
  switch (kind) {
    case Kind::kCylinder:
      return center_m.z();
    case Kind::kCapsule:
      return std::min(center_m.z(), center_m.z() + axis_m.z()) - size_m.x() / 2;
    default:
      return center_m.z() - size_m.z() / 2;
  }
}

double Shape::top_m() const {
  switch (kind) {
    case Kind::kCylinder:
      return center_m.z() + size_m.z();
    case Kind::kCapsule:
      return std::max(center_m.z(), center_m.z() + axis_m.z()) + size_m.x() / 2;
    default:
      return center_m.z() + size_m.z() / 2;
  }
}

Eigen::Vector2d walkPath(const std::vector<Eigen::Vector2d>& path_m, double speed_mps, double t_s) {
  if (path_m.size() < 2 || speed_mps <= 0.0) return Eigen::Vector2d::Zero();
  double length = 0.0;
  for (std::size_t i = 1; i < path_m.size(); ++i) length += (path_m[i] - path_m[i - 1]).norm();
  if (length <= 0.0) return Eigen::Vector2d::Zero();
  // Walk the path to its end and back again, forever.
  double s = std::fmod(speed_mps * t_s, 2.0 * length);
  if (s > length) s = 2.0 * length - s;
  for (std::size_t i = 1; i < path_m.size(); ++i) {
    const double leg = (path_m[i] - path_m[i - 1]).norm();
    if (s <= leg || i + 1 == path_m.size()) {
      const Eigen::Vector2d p = path_m[i - 1] + (leg > 0 ? std::min(s / leg, 1.0) : 0.0) * (path_m[i] - path_m[i - 1]);
      return p - path_m.front();
    }
    s -= leg;
  }
  return Eigen::Vector2d::Zero();
}

Eigen::Vector3d SceneObject::displacementAt(double t_s) const {
  const Eigen::Vector2d offset = walkPath(path_m, speed_mps, t_s);
  return {offset.x(), offset.y(), 0.0};
}

fw::RobotPose CarrierRobot::poseAt(double t_s) const {
  const Eigen::Vector2d offset = walkPath(path_m, speed_mps, t_s);
  fw::RobotPose pose;
  pose.x_m = x_m + offset.x();
  pose.y_m = y_m + offset.y();
  const double swing_rad = this->swing_rad * std::sin(2.0 * M_PI * t_s / swing_period_s);
  pose.theta_rad = std::remainder(theta_rad + turn_rate_radps * t_s + swing_rad, 2.0 * M_PI);
  return pose;
}

Scene loadScene(const std::string& name_or_path) {
  try {
    const bool is_file = std::filesystem::path(name_or_path).extension() == ".yaml";
    if (is_file) return readScene(fw::Config::loadDocument(name_or_path).root());
    if (const std::optional<Scene> crowd = crowdSceneNamed(name_or_path)) return *crowd;
    const std::map<std::string, std::string>& builtins = builtinScenes();
    const auto found = builtins.find(name_or_path);
    if (found == builtins.end()) {
      std::string names;
      for (const auto& entry : builtins) names += " " + entry.first;
      throw std::runtime_error("no built-in scene '" + name_or_path + "' (built in:" + names +
                               "; random people: people_no_ball_<seed>, people_thrown_from_hands_<seed>, "
                               "people_over_a_head_<seed>, people_from_the_border_<seed>; or give a scene file "
                               "ending in .yaml)");
    }
    return readScene(fw::Config::parseDocument(found->second, "built-in scene " + found->first).root());
  } catch (const fw::ConfigError& e) {
    throw std::runtime_error(e.what());
  }
}

Scene inSharedWorld(Scene scene, double world_start_wall_s) {
  if (world_start_wall_s > 0.0) scene.start_time_s = world_start_wall_s;
  return scene;
}

std::vector<std::string> builtinSceneNames() {
  std::vector<std::string> names;
  for (const auto& entry : builtinScenes()) names.push_back(entry.first);
  return names;
}

}  // namespace kinect3d::sim
