// The Kinect v1 error model the simulator applies (docs/simulator.md gives the sources). Every
// effect can be switched off; a seed makes a run repeatable.
#pragma once

#include <cstdint>

namespace kinect3d::sim {

struct KinectNoise {
  // Projector-to-camera baseline along the optical x axis (the projector sits on the camera's +x
  // side, as the shadows in real frames show). Sets the disparity scale and the shadows.
  double baseline_m = 0.075;
  bool quantisation = true;        // disparity in 1/8 pixel steps: the 'parallel planes'
  bool axial_noise = true;         // Gaussian disparity noise matching Nguyen et al.'s sigma_z(z)
  double axial_noise_scale = 1.0;  // times that sigma: a unit noisier (or quieter) than their average
  double lateral_noise_px = 0.8;   // where each pixel's ray really looks; 0 = exact
  bool shadows = true;             // background the projector cannot see returns no data
  double edge_dropout = 0.35;      // share of depth-edge pixels that return no data
  double flying_pixels = 0.25;     // share of depth-edge pixels given a depth between the two sides
  double exposure_s = 0.012;       // motion blur of the ball (trails); 0 = instantaneous
  double trail_dropout = 0.3;      // share of partly covered (trail) pixels that return no data
  double random_dropout = 0.003;   // share of all pixels that return no data (isolated)
  // Another Kinect's projector overlapping ours over part of the view (0 = none, 1 = facing it):
  // there a tenth of it is holed in patches and small clusters of false depth appear.
  double interference = 0.0;
  double min_range_m = 0.5;
  double max_range_m = 9.5;
  std::uint64_t seed = 1;
};

}  // namespace kinect3d::sim
