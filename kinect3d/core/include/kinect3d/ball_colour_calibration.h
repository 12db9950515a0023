// `kinect3d calibrate ball-colour` (docs/colour.md): the match ball's main colours under the hall's
// light, from a recording in which the depth finds the one ball (a calibration session with the ball
// on the marks, or a person holding it in view), and how well they tell it from the rest.
#pragma once

#include "kinect3d/ball_detector.h"
#include "kinect3d/colour_check.h"
#include "kinect3d/depth_source.h"

namespace kinect3d {

// Reads the source to its end (a live sensor: for live_seconds) with the detector configured so
// (its colour check off), and learns from each colour frame where it found exactly one ball. Throws
// std::runtime_error when too few frames showed the ball whole in both cameras.
BallColourFit calibrateBallColour(DepthSource& source, DetectorConfig config, double live_seconds = 10.0);

}  // namespace kinect3d
