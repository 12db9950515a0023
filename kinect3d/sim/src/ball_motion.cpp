#include "kinect3d/sim/ball_motion.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace kinect3d::sim {

namespace {
// Below this vertical speed after a bounce the ball stops hopping and rolls.
constexpr double kRollingThreshold_mps = 0.3;
// A robot's hull (aluminium and hard plastic) returns this share of the speed into it.
constexpr double kRobotRestitution = 0.4;
}  // namespace

void BallMotion::bounceOffRobots(State& s, double radius_m, double t_s, const std::vector<SceneObject>& obstacles) {
  for (const SceneObject& object : obstacles) {
    if (object.type != "robot") continue;
    const Eigen::Vector3d offset = object.displacementAt(t_s);
    const Eigen::Vector3d robot_v = (object.displacementAt(t_s + kStep_s) - offset) / kStep_s;
    for (const Shape& shape : object.shapes) {
      if (shape.kind != Shape::Kind::kBox) continue;
      // The hull's point nearest the ball's centre, in the box's own frame.
      const Eigen::Rotation2Dd turn(shape.yaw_rad);
      Eigen::Vector3d local = s.p - (shape.center_m + offset);
      local.head<2>() = turn.inverse() * local.head<2>();
      const Eigen::Vector3d half = 0.5 * shape.size_m;
      Eigen::Vector3d normal = local - local.cwiseMax(-half).cwiseMin(half);
      const double gap = normal.norm();
      if (gap >= radius_m || gap == 0.0) continue;
      normal /= gap;
      normal.head<2>() = turn * normal.head<2>();
      const double into = (s.v - robot_v).dot(normal);
      if (into >= 0.0) continue;  // already leaving it
      s.v -= (1.0 + kRobotRestitution) * into * normal;
      s.p += (radius_m - gap) * normal;
    }
  }
}

BallMotion::BallMotion(const BallLaunch& launch, const BallPhysics& physics, double duration_s,
                       const std::vector<SceneObject>& obstacles)
    : launch_time_s_(launch.launch_time_s) {
  State s{launch.position_m, launch.hanging ? Eigen::Vector3d::Zero() : launch.velocity_mps};
  const double r = physics.radius_m;
  const Eigen::Vector3d gravity(0.0, 0.0, -physics.gravity_mps2);
  const Eigen::Vector3d spin(0.0, 0.0, 2.0 * M_PI * physics.spin_rps);  // rad/s
  const int steps = static_cast<int>(std::ceil(std::max(0.0, duration_s - launch_time_s_) / kStep_s)) + 2;
  states_.reserve(steps);
  for (int i = 0; i < steps; ++i) {
    states_.push_back(s);
    if (launch.hanging) continue;
    bounceOffRobots(s, r, launch_time_s_ + i * kStep_s, obstacles);
    const bool rolling = s.p.z() <= r + 1e-9 && std::abs(s.v.z()) < 1e-9;
    if (rolling) {
      // Rolling resistance slows the ball until it stops.
      Eigen::Vector3d v = s.v;
      const double speed = v.head<2>().norm();
      const double slowed = std::max(0.0, speed - physics.rolling_decel_mps2 * kStep_s);
      if (speed > 0.0) v.head<2>() *= slowed / speed;
      s.p += 0.5 * (s.v + v) * kStep_s;
      s.v = v;
      continue;
    }
    // Semi-implicit Euler; the step is small against the flight (0.5 ms vs ~1 s).
    const Eigen::Vector3d a = gravity - physics.drag_per_m * s.v.norm() * s.v + physics.magnus_m * spin.cross(s.v);
    s.v += a * kStep_s;
    s.p += s.v * kStep_s;
    if (s.p.z() < r && s.v.z() < 0.0) {
      s.p.z() = r;
      s.v.z() = -physics.restitution * s.v.z();
      s.v.head<2>() *= 1.0 - physics.bounce_friction;
      if (s.v.z() < kRollingThreshold_mps) s.v.z() = 0.0;
    }
  }
}

BallMotion::State BallMotion::stateAt(double t_s) const {
  const double since_launch = t_s - launch_time_s_;
  if (since_launch <= 0.0) return {states_.front().p, Eigen::Vector3d::Zero()};
  const double steps = since_launch / kStep_s;
  const std::size_t i = std::min(static_cast<std::size_t>(steps), states_.size() - 2);
  const double w = std::clamp(steps - i, 0.0, 1.0);
  return {(1 - w) * states_[i].p + w * states_[i + 1].p, (1 - w) * states_[i].v + w * states_[i + 1].v};
}

Eigen::Vector3d BallMotion::positionAt(double t_s) const { return stateAt(t_s).p; }
Eigen::Vector3d BallMotion::velocityAt(double t_s) const { return stateAt(t_s).v; }

}  // namespace kinect3d::sim
