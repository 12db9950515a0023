// Renders a Scene as a Kinect v1 would see it: ray-cast geometry, then the sensor's physics
// (projector shadows, edge dropouts and flying pixels, motion trails, disparity noise and 1/8 px
// quantisation, range limits, dropouts) as set in Scene::noise.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "kinect3d/depth_frame.h"
#include "kinect3d/sim/ball_motion.h"
#include "kinect3d/sim/scene.h"

namespace kinect3d::sim {

// What was really there when a frame was taken.
struct GroundTruth {
  std::uint64_t frame_index = 0;
  double time_s = 0.0;       // scene time (0 at the first frame); the frame carries the source time
  fw::RobotPose robot_pose;  // of the robot carrying the sensor, stamped with the frame's source time
  bool has_ball = false;
  Eigen::Vector3d ball_center_F = Eigen::Vector3d::Zero();
  Eigen::Vector3d ball_velocity_F = Eigen::Vector3d::Zero();
  Eigen::Vector3d ball_center_R = Eigen::Vector3d::Zero();    // in the carrying robot's frame
  Eigen::Vector3d ball_velocity_R = Eigen::Vector3d::Zero();  // the field velocity in its axes
  bool airborne = false;                                      // centre more than 1 cm above resting height
  int visible_pixels = 0;    // pixels that show the ball (fully covered, with valid depth)
  double clearance_m = 0.0;  // from the ball's surface to the nearest obstacle (floor excluded)
};

class ColourRenderer;

class KinectSimulator {
 public:
  explicit KinectSimulator(Scene scene);
  ~KinectSimulator();

  const Scene& scene() const { return scene_; }
  int frameCount() const { return scene_.frameCount(); }

  // Renders frame i; the same scene and seed always give the same frame i, in any order. Every
  // frame carries gravity in the sensor frame, and with colour on, the image of the Kinect v1's
  // colour camera (ColourCamera::kinectV1()), registered to the depth through its offset.
  void render(int frame_index, DepthFrame& frame, GroundTruth& truth);
  // Colour as the scene's look has it (kinect3d/sim/src/colour_renderer.h); off by default.
  void setColour(bool on);

 private:
  struct Renderer;
  GroundTruth truthAt(int frame_index, double t) const;
  Scene scene_;
  std::unique_ptr<BallMotion> ball_motion_;
  std::unique_ptr<Renderer> renderer_;
  std::unique_ptr<ColourRenderer> colour_renderer_;
};

}  // namespace kinect3d::sim
