// The Kinect v1's depth error as a function of range (docs/simulator.md lists the sources):
// quantised disparity and Gaussian axial noise, both growing with the square of the range.
// The simulator draws from it, the detector scales its tolerances with it, and the observations'
// covariances come from it.
#pragma once

#include <cmath>

namespace kinect3d {

struct DepthNoiseModel {
  static constexpr double kKinectV1Baseline_m = 0.075;  // its projector to its IR camera

  double focal_px = 575.8;  // fx of the depth camera
  double baseline_m = kKinectV1Baseline_m;

  // Spacing of representable depths: disparity comes in 1/8 pixel steps, so dz = z^2 / (8 f b).
  double quantisationStep_m(double z_m) const { return z_m * z_m / (8.0 * focal_px * baseline_m); }
  // Nguyen, Izadi & Lovell (2012), surfaces seen at 10-60 degrees.
  static double axialSigma_m(double z_m) { return 0.0012 + 0.0019 * (z_m - 0.4) * (z_m - 0.4); }
  // Lateral noise about 0.8 px, as a distance at range z.
  double lateralSigma_m(double z_m) const { return 0.8 * z_m / focal_px; }
};

}  // namespace kinect3d
