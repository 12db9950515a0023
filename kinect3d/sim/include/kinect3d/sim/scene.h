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
// walks the waypoints like an obstacle) and a constant turn rate.
struct CarrierRobot {
  double x_m = 0.0, y_m = 0.0, theta_rad = 0.0;
  std::vector<Eigen::Vector2d> path_m;  // waypoints in the field frame; the first is (x_m, y_m)
  double speed_mps = 0.0;
  double turn_rate_radps = 0.0;

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

  int frameCount() const;
  // Where the sensor sits on the robot at scene time t.
  const fw::SensorPose& sensorPoseAt(double t_s) const {
    return knock && t_s >= knock->at_s ? knock->pose : sensor_pose;
  }
};

// Loads a built-in scene by name, or a scene file by path (anything ending in .yaml).
// Throws std::runtime_error naming the file, line and key on any problem.
Scene loadScene(const std::string& name_or_path);
std::vector<std::string> builtinSceneNames();

}  // namespace kinect3d::sim
