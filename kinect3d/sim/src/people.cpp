#include "kinect3d/sim/people.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

#include "framework_api/config.h"

namespace kinect3d::sim {

namespace {

struct GestureName {
  Gesture gesture;
  const char* name;
};
constexpr GestureName kGestures[] = {{Gesture::kDown, "down"},         {Gesture::kWalkingSwing, "walking"},
                                     {Gesture::kReaching, "reaching"}, {Gesture::kRaised, "raised"},
                                     {Gesture::kHeldOut, "held_out"},  {Gesture::kHandAtHead, "hand_at_head"},
                                     {Gesture::kRefereeFlag, "flag"}};

// A unit vector across d, towards `towards` (or up, if d points along it).
Eigen::Vector3d across(const Eigen::Vector3d& d, const Eigen::Vector3d& towards) {
  Eigen::Vector3d n = towards - towards.dot(d) * d;
  if (n.norm() < 1e-3) n = Eigen::Vector3d::UnitZ() - d.z() * d;
  return n.normalized();
}

}  // namespace

ArmPose ArmPose::of(Gesture gesture, double side) {
  switch (gesture) {
    case Gesture::kDown:
      return {0.1, 0.0, 0.2, false};
    case Gesture::kWalkingSwing:
      return {0.35, side > 0 ? M_PI / 2 : -M_PI / 2, 0.3, false};
    case Gesture::kReaching:
      return {1.4, 1.35, 0.1, false};
    case Gesture::kRaised:
      return {2.95, 0.3, 0.1, false};
    case Gesture::kHeldOut:
      return {1.55, 0.0, 0.0, false};
    case Gesture::kHandAtHead:
      return {2.2, 0.7, 2.1, false};
    case Gesture::kRefereeFlag:
      return {2.6, 0.35, 0.0, true};
  }
  return {};
}

std::vector<Shape> Person::shapes() const {
  const double H = height_m, w = build * height_m / 1.75;  // w scales widths and girths
  const Eigen::Matrix3d R_F_B = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  auto at = [&](const Eigen::Vector3d& p_B) -> Eigen::Vector3d { return feet_m + R_F_B * p_B; };
  const Eigen::Vector3d forward = Eigen::Vector3d::UnitY();
  std::vector<Shape> shapes;
  auto limb = [&](const Eigen::Vector3d& a_B, const Eigen::Vector3d& b_B, double r, double dropout, Surface surface) {
    shapes.push_back(Shape::capsule(at(a_B), at(b_B), r, dropout));
    shapes.back().surface = surface;
  };
  auto add = [&](Shape shape, Surface surface) {
    shape.surface = surface;
    shapes.push_back(shape);
  };

  // Legs: thighs swing either way when walking, the back knee bends.
  const double leg = 0.245 * H;
  for (const double side : {-1.0, 1.0}) {
    const double swing = side < 0 ? stride_rad : -stride_rad;
    const double knee_bend = swing < 0 ? 0.4 * stride_rad / 0.35 : 0.0;
    const Eigen::Vector3d hip(side * 0.09 * w, 0.0, 0.53 * H);
    const Eigen::Vector3d knee = hip + leg * Eigen::Vector3d(0, std::sin(swing), -std::cos(swing));
    const Eigen::Vector3d ankle =
        knee + leg * Eigen::Vector3d(0, std::sin(swing - knee_bend), -std::cos(swing - knee_bend));
    limb(hip, knee, 0.075 * w, clothes_dropout, Surface::kTrousers);
    limb(knee, ankle, 0.055 * w, clothes_dropout, Surface::kTrousers);
    limb(ankle, ankle + Eigen::Vector3d(0, 0.17 * w, 0), 0.045 * w, clothes_dropout, Surface::kTrousers);  // foot
  }
  // Torso and pelvis, neck, head, and the hair over the head's top and back.
  add(Shape{Shape::Kind::kBox, at({0, 0, 0.66 * H}), {0.36 * w, 0.21 * w, 0.32 * H}, yaw_rad, clothes_dropout},
      Surface::kShirt);
  limb({0, 0, 0.81 * H}, {0, 0.01, 0.875 * H}, 0.055 * w, 0.0, Surface::kSkin);
  const double head_r = 0.105 * std::sqrt(build);
  const Eigen::Vector3d head(0, 0.01, 0.93 * H);
  add(Shape::sphere(at(head + Eigen::Vector3d(0, -0.025, 0.03)), head_r + 0.012, hair_dropout), Surface::kHair);
  add(Shape::sphere(at(head), head_r, 0.0), Surface::kSkin);

  // Arms: the upper arm from the shoulder, the forearm bent from it towards the front, the hand.
  for (const double side : {-1.0, 1.0}) {
    const ArmPose& arm = side < 0 ? left_arm : right_arm;
    const Eigen::Vector3d shoulder(side * 0.2 * w, 0.0, 0.8 * H);
    const Eigen::Vector3d upper(side * std::sin(arm.raise_rad) * std::cos(arm.swing_rad),
                                std::sin(arm.raise_rad) * std::sin(arm.swing_rad), -std::cos(arm.raise_rad));
    const Eigen::Vector3d elbow = shoulder + 0.19 * H * upper;
    const Eigen::Vector3d lower =
        (std::cos(arm.elbow_rad) * upper + std::sin(arm.elbow_rad) * across(upper, forward)).normalized();
    const Eigen::Vector3d wrist = elbow + 0.16 * H * lower;
    limb(shoulder, elbow, 0.05 * w, clothes_dropout, Surface::kShirt);
    limb(elbow, wrist, 0.04 * w, 0.0, Surface::kSkin);
    const Eigen::Vector3d hand = wrist + 0.05 * lower;
    add(Shape::sphere(at(hand), 0.045 * w, 0.0), Surface::kSkin);
    if (arm.flag) {
      const Eigen::Vector3d top = hand + 0.5 * lower;
      limb(hand, top, 0.012, 0.0, Surface::kFlag);
      add(Shape{Shape::Kind::kBox, at(top + Eigen::Vector3d(side * 0.22, 0, -0.15)), {0.45, 0.02, 0.30}, yaw_rad, 0.0},
          Surface::kFlag);
    }
  }
  return shapes;
}

Person randomPerson(std::mt19937& random, const Eigen::Vector3d& feet_m, double yaw_rad) {
  auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(random); };
  auto gesture = [&]() { return kGestures[std::uniform_int_distribution<int>(0, 6)(random)].gesture; };
  Person person;
  person.feet_m = feet_m;
  person.yaw_rad = yaw_rad;
  person.height_m = uniform(1.55, 1.95);
  person.build = uniform(0.85, 1.2);
  const Gesture left = gesture(), right = gesture();
  person.left_arm = ArmPose::of(left, -1.0);
  person.right_arm = ArmPose::of(right, 1.0);
  person.stride_rad = (left == Gesture::kWalkingSwing || right == Gesture::kWalkingSwing) ? uniform(0.2, 0.4) : 0.0;
  person.clothes_dropout = uniform(0.0, 0.6);
  person.hair_dropout = uniform(0.3, 1.0);
  return person;
}

Gesture gestureNamed(const std::string& name) {
  for (const GestureName& g : kGestures) {
    if (name == g.name) return g.gesture;
  }
  throw std::invalid_argument("unknown gesture '" + name + "'");
}

std::vector<std::string> gestureNames() {
  std::vector<std::string> names;
  for (const GestureName& g : kGestures) names.emplace_back(g.name);
  return names;
}

const char* crowdBallName(CrowdBall ball) {
  switch (ball) {
    case CrowdBall::kNone:
      return "people_no_ball";
    case CrowdBall::kThrownFromHands:
      return "people_thrown_from_hands";
    case CrowdBall::kOverAHead:
      return "people_over_a_head";
    case CrowdBall::kFromTheBorder:
      return "people_from_the_border";
  }
  return "?";
}

std::optional<Scene> crowdSceneNamed(const std::string& name) {
  for (const CrowdBall ball :
       {CrowdBall::kNone, CrowdBall::kThrownFromHands, CrowdBall::kOverAHead, CrowdBall::kFromTheBorder}) {
    const std::string prefix = std::string(crowdBallName(ball)) + "_";
    if (name.rfind(prefix, 0) != 0) continue;
    const std::string seed = name.substr(prefix.size());
    if (seed.empty() || seed.size() > 6 || seed.find_first_not_of("0123456789") != std::string::npos) continue;
    return crowdScene(std::stoi(seed), ball);
  }
  return std::nullopt;
}

Scene crowdScene(int seed, CrowdBall ball) {
  std::mt19937 random(static_cast<unsigned>(seed) * 7919u + static_cast<unsigned>(ball));
  auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(random); };
  Scene scene;
  scene.name = std::string(crowdBallName(ball)) + "_" + std::to_string(seed);
  scene.duration_s = 1.5;
  scene.sensor_pose = fw::SensorPose{0.0, 0.0, uniform(0.55, 0.85), 0.0, fw::degreesToRadians(uniform(-8.0, 8.0)), 0.0};
  scene.noise.seed = static_cast<std::uint64_t>(seed);
  scene.noise.max_range_m = uniform(5.5, 9.5);
  if (uniform(0.0, 1.0) < 0.6) {  // a wall behind, or an empty hall beyond the range
    SceneObject wall;
    wall.type = "box";
    wall.shapes.push_back(
        Shape{Shape::Kind::kBox, {0.0, uniform(6.5, 9.0), 1.5}, {20.0, 0.2, 3.0}, 0.0, uniform(0.0, 0.3)});
    scene.objects.push_back(wall);
  }
  // People: the view spans +-29 degrees; azimuths to +-36 put some across its edges.
  const int people = std::uniform_int_distribution<int>(5, 8)(random);
  std::vector<Person> crowd;
  for (int i = 0; i < people; ++i) {
    const double range = i < 2 ? uniform(0.8, 2.0) : uniform(2.0, 6.0);
    const double azimuth = fw::degreesToRadians(uniform(-36.0, 36.0));
    const Eigen::Vector3d feet(range * std::sin(azimuth), range * std::cos(azimuth), 0.0);
    crowd.push_back(randomPerson(random, feet, uniform(-M_PI, M_PI)));
  }
  const double g = scene.physics.gravity_mps2;
  BallLaunch launch;
  launch.launch_time_s = 0.3;
  switch (ball) {
    case CrowdBall::kNone:
      break;
    case CrowdBall::kThrownFromHands: {
      // A person 2.5-4 m ahead faces the robot, arms held out, the ball just in front of the hands.
      Person& thrower = crowd.back();
      const double range = uniform(2.5, 4.0);
      thrower.feet_m = {uniform(-0.8, 0.8), range, 0.0};
      thrower.yaw_rad = M_PI + uniform(-0.3, 0.3);
      thrower.left_arm = ArmPose::of(Gesture::kReaching, -1.0);
      thrower.right_arm = ArmPose::of(Gesture::kReaching, 1.0);
      const Eigen::Vector3d toward_robot = -thrower.feet_m.normalized();
      launch.position_m = thrower.feet_m + Eigen::Vector3d(0, 0, 0.75 * thrower.height_m) + 0.75 * toward_robot;
      // Thrown to the side of the robot, rising a little: it stays in view as it leaves the hands.
      // One draw a statement: C++ leaves the order of calls within one expression to the compiler,
      // and a seed must make the same crowd whichever built it (this is the order GCC chose).
      const double up_mps = uniform(0.5, 2.0);
      const double towards_mps = uniform(1.0, 2.5);
      const double sideways = uniform(0.0, 1.0) < 0.5 ? -1.0 : 1.0;
      const double sideways_mps = uniform(1.5, 3.0);
      launch.velocity_mps = Eigen::Vector3d(sideways * sideways_mps, -towards_mps, up_mps);
      break;
    }
    case CrowdBall::kOverAHead: {
      // Lobbed from 2.5 m to one side of a person 3-5 m ahead, its apex 0.3 m over the head.
      Person& under = crowd.back();
      under.feet_m = {uniform(-0.8, 0.8), uniform(3.0, 5.0), 0.0};
      const double side = uniform(0.0, 1.0) < 0.5 ? -1.0 : 1.0;
      const double apex_z = under.height_m + 0.3 + scene.physics.radius_m;
      const double vz = std::sqrt(2.0 * g * (apex_z - scene.physics.radius_m));
      const double to_apex_s = vz / g;
      launch.position_m = under.feet_m + Eigen::Vector3d(side * 2.5, 0.0, scene.physics.radius_m);
      launch.velocity_mps = Eigen::Vector3d(-side * 2.5 / to_apex_s, 0.0, vz);
      break;
    }
    case CrowdBall::kFromTheBorder: {
      // From beyond the side of the view, 3-5 m out and 0.5-1.5 m up, across and up.
      const double side = uniform(0.0, 1.0) < 0.5 ? -1.0 : 1.0;
      const double range = uniform(3.0, 5.0), azimuth = fw::degreesToRadians(40.0);
      launch.position_m = {side * range * std::sin(azimuth), range * std::cos(azimuth), uniform(0.5, 1.5)};
      launch.velocity_mps = {-side * uniform(4.0, 7.0), uniform(-1.0, 1.0), uniform(1.5, 3.5)};
      launch.launch_time_s = 0.0;
      break;
    }
  }
  if (ball != CrowdBall::kNone) scene.ball = launch;
  // Walking slowly across, but for the thrower or the person under the lob (the last), who stand still.
  const bool last_stands = ball == CrowdBall::kThrownFromHands || ball == CrowdBall::kOverAHead;
  for (std::size_t i = 0; i < crowd.size(); ++i) {
    const Person& person = crowd[i];
    SceneObject object;
    object.type = "person";
    object.shapes = person.shapes();
    if (!(last_stands && i + 1 == crowd.size())) {
      const Eigen::Vector2d start = person.feet_m.head<2>();
      // One draw a statement: as a constructor's arguments their order was the compiler's.
      const double dy_m = uniform(-0.5, 0.5);
      const double dx_m = uniform(-1.0, 1.0);
      object.path_m = {start, start + Eigen::Vector2d(dx_m, dy_m)};
      object.speed_mps = uniform(0.0, 1.2);
    }
    scene.objects.push_back(object);
  }
  // Drawn last, so that everything above stays as it was before units differed.
  scene.noise.axial_noise_scale = uniform(0.8, 1.5);  // a unit quieter or noisier than the average
  return scene;
}

}  // namespace kinect3d::sim
