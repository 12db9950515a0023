// A simulated scene: the floor, static and moving obstacles and the ball in the field frame (origin
// at the centre spot, y towards the opponent goal, z up, floor z = 0), and the robot that carries
// the sensors, which may drive and turn. By default that robot stands at the origin facing +y, so
// the field and robot frames coincide.
// Scene files are YAML (docs/simulator.md); built-in scenes are such files compiled in.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "framework_api/sensor_pose.h"
#include "framework_api/types.h"
#include "kinect3d/depth_frame.h"
#include "kinect3d/sim/kinect_noise.h"

namespace kinect3d::sim {

// What a shape is made of, as the colour camera sees it. The colours themselves are drawn per scene
// from its seed (kinect3d/sim/src/colour_renderer.cpp) unless the scene file gives one.
enum class Surface {
  kPlain,  // a wall, a box, a pillar: a muted colour
  kShirt,  // clothes of any colour, orange included
  kTrousers,
  kSkin,
  kHair,
  kFlag,         // a referee's flag: yellow, red or orange
  kRobot,        // an MSL robot: black
  kGoal,         // white
  kLamp,         // a light: brighter than anything lit, mostly overexposed
  kLoudspeaker,  // black cloth
  kPoster,       // a poster with a ball printed on it, facing -y of its box
};

// A solid primitive. Boxes and cylinders stand upright and may be turned about z; a capsule (a
// limb) is a segment from center_m to center_m + axis_m, rounded, in any direction.
struct Shape {
  enum class Kind { kBox, kCylinder, kSphere, kCapsule };
  Kind kind = Kind::kBox;
  Eigen::Vector3d center_m = Eigen::Vector3d::Zero();  // box/sphere centre; cylinder base centre; capsule end
  Eigen::Vector3d size_m = Eigen::Vector3d::Ones();    // box extents; cylinder (2r, 2r, height); sphere and capsule 2r
  double yaw_rad = 0.0;
  double dropout = 0.0;  // extra chance a pixel on it returns no data (dark, absorbing material)
  Eigen::Vector3d axis_m = Eigen::Vector3d::Zero();  // capsule: from one end to the other
  Surface surface = Surface::kPlain;
  std::optional<Eigen::Vector3d> albedo = std::nullopt;  // linear RGB 0-1, overriding the surface's drawn colour

  static Shape capsule(const Eigen::Vector3d& from_m, const Eigen::Vector3d& to_m, double radius_m, double dropout);
  static Shape sphere(const Eigen::Vector3d& center_m, double radius_m, double dropout);
  // The lowest and highest points of the shape (at displacement 0).
  double bottom_m() const;
  double top_m() const;
};

// One obstacle (a wall, a goal, a robot, a person) made of shapes, optionally walking a path.
struct SceneObject {
  std::string type;
  std::vector<Shape> shapes;            // where they are at t = 0
  std::vector<Eigen::Vector2d> path_m;  // waypoints in x, y; walked back and forth from the first
  double speed_mps = 0.0;

  // How far the object has moved from where its shapes are defined, at time t.
  Eigen::Vector3d displacementAt(double t_s) const;
};

// Walks waypoints [x, y] back and forth from the first at a constant speed; the offset from the
// first waypoint at time t.
Eigen::Vector2d walkPath(const std::vector<Eigen::Vector2d>& path_m, double speed_mps, double t_s);

// The robot carrying the sensors: its pose in the field at t = 0, a path it drives (its centre
// walks the waypoints like an obstacle), a constant turn rate and a swing of its heading back and
// forth about it (a robot keeping its face to the ball).
struct CarrierRobot {
  double x_m = 0.0, y_m = 0.0, theta_rad = 0.0;
  std::vector<Eigen::Vector2d> path_m;  // waypoints in the field frame; the first is (x_m, y_m)
  double speed_mps = 0.0;
  double turn_rate_radps = 0.0;
  double swing_rad = 0.0;       // the heading swings by up to this either way, sinusoidally, ...
  double swing_period_s = 1.0;  // ... once over this

  // Its pose at scene time t (stamp.source_time_s left for the caller).
  fw::RobotPose poseAt(double t_s) const;
};

struct BallPhysics {
  double radius_m = 0.11;  // FIFA size 5
  double gravity_mps2 = 9.81;
  double drag_per_m = 0.024;        // rho Cd A / 2m; 0 = no air drag
  double restitution = 0.6;         // vertical speed kept at a bounce
  double bounce_friction = 0.2;     // fraction of horizontal speed lost at a bounce
  double rolling_decel_mps2 = 0.4;  // rolling resistance on carpet
  double spin_rps = 0.0;            // sidespin about the vertical, counter-clockwise seen from above
  // The Magnus acceleration is magnus_m (omega x v): rho A r (C_L / S) / 2m for a size 5 ball, whose
  // lift coefficient C_L is about half its spin ratio S = r omega / v (0.5 * 1.2 * 0.038 * 0.11 / 2 /
  // 0.43): 10 rev/s at 8 m/s bends a shot by 1.5 m/s^2.
  double magnus_m = 0.0029;
};

struct BallLaunch {
  Eigen::Vector3d position_m = Eigen::Vector3d(0.0, 2.0, 0.11);
  Eigen::Vector3d velocity_mps = Eigen::Vector3d::Zero();
  double launch_time_s = 0.0;  // at rest at position_m before this
  bool hanging = false;        // hung on a wire: never moves
  bool dark_panels = false;    // a classic ball's 12 black pentagons (28 % of it), returning no depth
};

// How the colour camera sees the scene: the match ball's colours and the hall's light (a team's ball
// in a team's hall, the same in the calibration session and the match), the camera's exposure.
// Everything else's colours and the light's direction over the frame are drawn from the seed.
struct ColourLook {
  Eigen::Vector3d ball_albedo = Eigen::Vector3d(0.90, 0.32, 0.04);  // linear RGB 0-1
  std::optional<Eigen::Vector3d> panel_albedo;                      // the 12 pentagons, when it has them
  double light = 1.0;  // the hall's brightness: 1 puts a white wall at about 85 % of the range
  Eigen::Vector3d tint = Eigen::Vector3d::Ones();  // the light's colour (white balance left over)
  double light_gradient = 0.3;                     // the brightness varies over the frame by this share either way
  double exposure_s = 0.015;                       // the colour camera's exposure: the ball's motion blur
  double noise = 0.01;                             // pixel noise, a share of the range (1 sigma)

  // The three match balls the product must learn: "orange", "yellow", "white_black" (a classic
  // white ball with black pentagons).
  static ColourLook withBall(const std::string& ball);
  static std::vector<std::string> ballNames();
};

// The sensor knocked on its mount during the scene: from at_s on it sits at pose.
struct SensorKnock {
  double at_s = 0.0;
  fw::SensorPose pose;
};

struct Scene {
  std::string name;
  double duration_s = 2.0;
  double fps = 30.0;
  double start_time_s = 1.7e9;  // source clock of frame 0
  fw::SensorPose sensor_pose;   // on the carrying robot
  std::optional<SensorKnock> knock;
  CarrierRobot robot;
  Intrinsics intrinsics;
  KinectNoise noise;
  bool floor = true;
  std::vector<SceneObject> objects;
  std::optional<BallLaunch> ball;
  BallPhysics physics;
  ColourLook look;

  int frameCount() const;
  // Where the sensor sits on the robot at scene time t.
  const fw::SensorPose& sensorPoseAt(double t_s) const {
    return knock && t_s >= knock->at_s ? knock->pose : sensor_pose;
  }
};

// Loads a built-in scene by name, or a scene file by path (anything ending in .yaml).
// Throws std::runtime_error naming the file, line and key on any problem.
Scene loadScene(const std::string& name_or_path);
// The scene in a world that several hosts simulate side by side (host.sim_world_start_wall_s): its
// time 0 at that wall-clock time, so every robot's sensors stamp it on the same clock; 0: as it is.
Scene inSharedWorld(Scene scene, double world_start_wall_s);
std::vector<std::string> builtinSceneNames();

}  // namespace kinect3d::sim
