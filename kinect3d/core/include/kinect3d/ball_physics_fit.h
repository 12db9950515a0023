// The ball's own physics from recorded flights (`kinect3d calibrate drag`): its air drag and its
// bounce, for the robot file's ball block (ball.drag_per_m and drag_sigma_per_m, the trajectory
// estimator's drag prior; ball.restitution and bounce_friction with their sigmas, the fusion's
// bounce).
//
// Each flight (detections in the air, no gap over 0.1 s, at least 8 of them over 0.2 s, faster
// than 2 m/s) is fitted alone: start, velocity, drag and sidespin curve by Gauss-Newton on the
// motion model fw::BallTrajectory propagates, with nothing assumed about the drag. The flights'
// drags (those known to 0.005 /m or better, when there are any) are combined weighted by their
// precision, and the spread between flights beyond what their own errors explain (another ball,
// the drag crisis at another speed) widens the prior, never below 0.002 /m.
// Consecutive flights joined by a bounce give the restitution, the vertical speed after the floor
// over the vertical speed before, and the bounce friction, the share of the horizontal speed lost,
// both taken where the fits meet the floor.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>

#include "framework_api/types.h"

namespace kinect3d {

struct FlightFit {
  double start_s = 0.0, end_s = 0.0;
  int detections = 0;
  fw::BallTrajectory trajectory;  // fitted, at start_s
  double drag_sigma_per_m = 0.0;  // the fitted drag is trajectory.drag_per_m
  double rms_m = 0.0;             // of the detections about the fit
};

struct BounceFit {
  double t_s = 0.0;
  double restitution = 0.0;        // vertical speed kept
  std::optional<double> friction;  // horizontal speed lost (a ball that fell almost straight down: none)
};

struct BallPhysicsCalibration {
  std::vector<FlightFit> flights;
  std::vector<BounceFit> bounces;
  int runs_skipped = 0;  // runs of airborne detections too short or too slow to fit
  // The prior to configure: the flights' weighted mean drag and how far the next flight's may lie.
  double drag_per_m = 0.0, drag_sigma_per_m = 0.0;
  std::optional<double> restitution, restitution_sigma;          // mean and spread over the bounces (sigma: 2 or more)
  std::optional<double> bounce_friction, bounce_friction_sigma;  // likewise
};

// Fits the flights of the one ball the frames follow (where a frame holds several balls, the one
// nearest the ball's last position). Throws std::invalid_argument when no flight can be fitted,
// saying what the data lacked.
BallPhysicsCalibration calibrateBallPhysics(const std::vector<fw::BallFrame>& frames, double radius_m);

}  // namespace kinect3d
