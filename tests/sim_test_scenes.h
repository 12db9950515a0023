// Small scenes built in code for the simulator and detector tests.
#pragma once

#include "kinect3d/sim/kinect_simulator.h"

namespace testing_scenes {

// Every effect off: exact geometry, for tests that check one effect at a time.
inline kinect3d::sim::KinectNoise noNoise() {
  kinect3d::sim::KinectNoise n;
  n.quantisation = false;
  n.axial_noise = false;
  n.lateral_noise_px = 0.0;
  n.shadows = false;
  n.edge_dropout = 0.0;
  n.flying_pixels = 0.0;
  n.exposure_s = 0.0;
  n.trail_dropout = 0.0;
  n.random_dropout = 0.0;
  return n;
}

// A level sensor 0.7 m up looking along +y at a wall whose face is at y = distance_m.
inline kinect3d::sim::Scene wallAt(double distance_m) {
  kinect3d::sim::Scene scene;
  scene.name = "wall";
  scene.duration_s = 1.0;
  scene.floor = false;
  scene.sensor_pose = fw::SensorPose{0.0, 0.0, 0.7, 0.0, 0.0, 0.0};
  kinect3d::sim::SceneObject wall;
  wall.type = "box";
  wall.shapes.push_back({kinect3d::sim::Shape::Kind::kBox, {0.0, distance_m + 0.1, 0.7}, {30.0, 0.2, 30.0}, 0.0, 0.0});
  scene.objects.push_back(wall);
  return scene;
}

}  // namespace testing_scenes
