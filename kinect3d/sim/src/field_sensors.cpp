#include "kinect3d/sim/field_sensors.h"

#include <cmath>
#include <random>

namespace kinect3d::sim {

namespace {
// Each image draws from its own stream, so image i is the same whatever was asked before it.
std::mt19937_64 streamFor(std::uint64_t seed, int index) {
  std::seed_seq sequence{seed, static_cast<std::uint64_t>(index), std::uint64_t{0x6f6d6e69}};
  return std::mt19937_64(sequence);
}

// The ray from the viewpoint through a centre at height z meets the plane of resting centres at
// this multiple of the horizontal distance.
double phantomFactor(double viewpoint_m, double radius_m, double z_m) {
  return (viewpoint_m - radius_m) / (viewpoint_m - z_m);
}
}  // namespace

OmniCameraSimulator::OmniCameraSimulator(const Scene& scene, const OmniCameraModel& model)
    : scene_(scene), model_(model) {
  if (scene_.ball)
    ball_ = std::make_unique<BallMotion>(*scene_.ball, scene_.physics, scene_.duration_s + 1.0, scene_.objects);
  // Orange things: a Poisson process over the scene, each somewhere 1.5-6 m around the robot.
  std::mt19937_64 random(model_.seed);
  std::exponential_distribution<double> gap(std::max(model_.false_rate_hz, 1e-9));
  std::uniform_real_distribution<double> distance(1.5, 6.0), bearing(-M_PI, M_PI);
  for (double t = gap(random); model_.false_rate_hz > 0.0 && t < scene_.duration_s; t += gap(random)) {
    const fw::RobotPose pose = scene_.robot.poseAt(t);
    const double d = distance(random), b = bearing(random);
    false_balls_.push_back({t, {pose.x_m + d * std::cos(b), pose.y_m + d * std::sin(b)}});
  }
}

int OmniCameraSimulator::frameCount() const {
  return static_cast<int>(std::floor((scene_.duration_s - model_.phase_s) * model_.rate_hz)) + 1;
}

double OmniCameraSimulator::captureTime_s(int index) const {
  return scene_.start_time_s + model_.phase_s + index / model_.rate_hz;
}

bool OmniCameraSimulator::occluded(const Eigen::Vector3d& ball_F, const fw::RobotPose& pose, double t_s) const {
  const Eigen::Vector2d from(pose.x_m, pose.y_m);
  const Eigen::Vector2d to = ball_F.head<2>();
  const Eigen::Vector2d along = to - from;
  const double length2 = std::max(along.squaredNorm(), 1e-12);
  for (const SceneObject& object : scene_.objects) {
    const Eigen::Vector3d offset = object.displacementAt(t_s);
    for (const Shape& shape : object.shapes) {
      // The shape's footprint on the floor as a disc round its middle (a capsule's spans its axis).
      const Eigen::Vector3d c = shape.center_m + 0.5 * shape.axis_m + offset;
      const double footprint = 0.5 * std::max(shape.size_m.x(), shape.size_m.y()) + 0.5 * shape.axis_m.head<2>().norm();
      // Where the ray passes the shape, and how high it is there.
      const double s = std::clamp((c.head<2>() - from).dot(along) / length2, 0.0, 1.0);
      if (s <= 0.0 || s >= 1.0) continue;
      if ((from + s * along - c.head<2>()).norm() > footprint) continue;
      const double ray_z = model_.viewpoint_height_m + s * (ball_F.z() - model_.viewpoint_height_m);
      if (ray_z >= shape.bottom_m() + offset.z() && ray_z <= shape.top_m() + offset.z()) return true;
    }
  }
  return false;
}

fw::OmniFrame OmniCameraSimulator::frame(int index) const {
  const double t = captureTime_s(index) - scene_.start_time_s;
  fw::OmniFrame frame;
  frame.stamp.source_time_s = captureTime_s(index) + model_.stamp_late_s;
  frame.stamp.receive_time_s = frame.stamp.source_time_s;
  std::mt19937_64 random = streamFor(model_.seed, index);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const fw::RobotPose pose = scene_.robot.poseAt(t);
  const double r = scene_.physics.radius_m;
  auto observe = [&](const Eigen::Vector3d& p_F) {
    const Eigen::Vector3d p_R = pose.T_F_R().inverse() * p_F;
    const double d = p_R.head<2>().norm() * phantomFactor(model_.viewpoint_height_m, r, p_R.z());
    fw::OmniBallObservation ball;
    ball.bearing_sigma_rad = model_.bearing_sigma_rad;
    ball.distance_sigma_m = model_.distance_sigma_m + model_.distance_sigma_fraction * d;
    ball.bearing_rad = std::atan2(-p_R.x(), p_R.y()) + ball.bearing_sigma_rad * normal(random);
    ball.distance_m = std::max(0.0, model_.distance_scale * d + ball.distance_sigma_m * normal(random));
    ball.source = "omni";
    ball.stamp = frame.stamp;
    if (ball.distance_m <= model_.max_distance_m) frame.balls.push_back(ball);
  };
  if (ball_) {
    const Eigen::Vector3d p_F = ball_->positionAt(t);
    const bool missed = uniform(random) < model_.miss_probability;
    if (!missed && p_F.z() <= model_.max_height_m && !occluded(p_F, pose, t)) observe(p_F);
  }
  for (const FalseBall& orange : false_balls_) {
    if (t >= orange.start_s && t < orange.start_s + model_.false_duration_s) {
      observe({orange.p_F.x(), orange.p_F.y(), r});
    }
  }
  // The other robots, by their centres on the floor, with the ball's noise and misses (drawn after the
  // ball's, so that its noise does not depend on how many robots stand around). Their hulls hide
  // nothing here: a robot behind another is seen as well.
  for (const SceneObject& object : scene_.objects) {
    if (object.type != "robot") continue;
    const Eigen::Vector3d centre_F = object.shapes.front().center_m + object.displacementAt(t);
    const Eigen::Vector3d p_R = pose.T_F_R().inverse() * Eigen::Vector3d(centre_F.x(), centre_F.y(), 0.0);
    const double d = p_R.head<2>().norm();
    fw::OmniRobotObservation robot;
    robot.bearing_sigma_rad = model_.bearing_sigma_rad;
    robot.distance_sigma_m = model_.distance_sigma_m + model_.distance_sigma_fraction * d;
    robot.bearing_rad = std::atan2(-p_R.x(), p_R.y()) + robot.bearing_sigma_rad * normal(random);
    robot.distance_m = std::max(0.0, model_.distance_scale * d + robot.distance_sigma_m * normal(random));
    const bool missed = uniform(random) < model_.miss_probability;
    if (!missed && robot.distance_m <= model_.max_distance_m) frame.robots.push_back(robot);
  }
  return frame;
}

LocalisationSimulator::LocalisationSimulator(const Scene& scene, const LocalisationModel& model)
    : scene_(scene), model_(model) {
  // First-order Gauss-Markov errors: stationary with the given sigmas, correlated over correlation_s.
  std::mt19937_64 random(model_.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const int count = static_cast<int>(std::floor(scene_.duration_s * model_.rate_hz)) + 1;
  const double a = std::exp(-1.0 / (model_.rate_hz * model_.correlation_s));
  const double b = std::sqrt(1.0 - a * a);
  const Eigen::Vector3d sigma(model_.sigma_xy_m, model_.sigma_xy_m, model_.sigma_theta_rad);
  // One draw a statement, theta first: as a constructor's arguments their order was the compiler's.
  const auto draw = [&] {
    const double theta = normal(random);
    const double y = normal(random);
    return Eigen::Vector3d(normal(random), y, theta);
  };
  Eigen::Vector3d e = draw();
  for (int i = 0; i < count; ++i) {
    errors_.push_back(e.cwiseProduct(sigma));
    e = a * e + b * draw();
  }
  if (!model_.odometry) return;
  // Its own random stream, so that the localisation's errors do not depend on whether it has odometry.
  std::mt19937_64 wheels(model_.seed ^ 0x0d0e7e5ULL);
  std::normal_distribution<double> wheel_normal(0.0, 1.0);
  const double scale_xy = 1.0 + model_.odometry_error * wheel_normal(wheels);
  const double scale_theta = 1.0 + model_.odometry_error * wheel_normal(wheels);
  fw::RobotPose::Odometry odometry;
  fw::RobotPose previous = scene_.robot.poseAt(0.0);
  odometry_.push_back(odometry);
  for (int i = 1; i < count; ++i) {
    const fw::RobotPose now = scene_.robot.poseAt(i / model_.rate_hz);
    // The true step in the robot frame of the step's start, as the wheels measure it.
    const Eigen::Vector2d step_R =
        Eigen::Rotation2Dd(-previous.theta_rad) * Eigen::Vector2d(now.x_m - previous.x_m, now.y_m - previous.y_m);
    const double turn_rad = std::remainder(now.theta_rad - previous.theta_rad, 2.0 * M_PI);
    const double noise_x = wheel_normal(wheels), noise_y = wheel_normal(wheels), noise_theta = wheel_normal(wheels);
    const Eigen::Vector2d measured_R =
        scale_xy * step_R + model_.odometry_error * step_R.norm() * Eigen::Vector2d(noise_x, noise_y);
    const double measured_turn_rad = scale_theta * turn_rad + model_.odometry_error * std::abs(turn_rad) * noise_theta;
    const Eigen::Vector2d p =
        Eigen::Vector2d(odometry.x_m, odometry.y_m) + Eigen::Rotation2Dd(odometry.theta_rad) * measured_R;
    odometry = {p.x(), p.y(), odometry.theta_rad + measured_turn_rad};
    odometry_.push_back(odometry);
    previous = now;
  }
}

fw::RobotPose LocalisationSimulator::pose(int index) const {
  const double t = index / model_.rate_hz;
  fw::RobotPose pose = scene_.robot.poseAt(t);
  const Eigen::Vector3d& e = errors_[static_cast<std::size_t>(index)];
  pose.x_m += e.x() + model_.bias_xy_m.x();
  pose.y_m += e.y() + model_.bias_xy_m.y();
  pose.theta_rad += e.z() + model_.bias_theta_rad;
  pose.stamp.source_time_s = pose.stamp.receive_time_s = scene_.start_time_s + t + model_.stamp_late_s;
  if (!odometry_.empty()) pose.odometry = odometry_[static_cast<std::size_t>(index)];
  return pose;
}

}  // namespace kinect3d::sim
