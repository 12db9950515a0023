// What the colour camera beside the depth camera sees: every surface ray-cast from the colour
// camera's own origin (so the image is registered to the depth through the camera's offset, as a
// real Kinect's is), in colours drawn per scene from its seed, lit by the hall's light, which varies
// over the frame, with the ball smeared over the colour camera's exposure, gamma-encoded and noisy.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "kinect3d/camera_file.h"
#include "kinect3d/sim/ball_motion.h"
#include "kinect3d/sim/scene.h"

namespace kinect3d::sim {

class ColourRenderer {
 public:
  // Draws every object's colours, the light's direction and its slope over the frame from the
  // scene's seed; the ball's colours and the light's level are the scene's look.
  explicit ColourRenderer(const Scene& scene);

  // The RGB image (width * height * 3) at scene time t with the depth camera at T_F_S; ball may be
  // null. The same scene, time and frame index always give the same image.
  std::vector<std::uint8_t> render(double t, const Eigen::Isometry3d& T_F_S, const BallMotion* ball,
                                   const ColourCamera& camera, int frame_index);

 private:
  Eigen::Vector3d albedoOf(std::size_t object, const Shape& shape) const;

  const Scene& scene_;
  std::vector<std::vector<Eigen::Vector3d>> surface_albedo_;  // [object][Surface]: linear RGB, or emitted for a lamp
  Eigen::Vector3d light_from_F_;                              // towards the hall's lights
  Eigen::Vector2d light_slope_;                               // the brightness's change over the frame's width, height
  // Per pixel, kept between frames so that rendering allocates nothing once warm: the optical depth
  // of the nearest surface, and the light it sends before the hall's level and slope.
  std::vector<float> nearest_;
  std::vector<Eigen::Vector3f> radiance_;
};

}  // namespace kinect3d::sim
