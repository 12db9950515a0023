// `kinect3d calibrate drag` and `kinect3d calibrate ball-colour`: the match ball's own physics and
// colours, measured, printed as lines for the robot file.
#pragma once

#include <string>
#include <vector>

#include "framework_api/config.h"

namespace kinect3d {

// `calibrate drag`: the ball's drag, restitution and bounce friction fitted to the flights in
// `kinect3d detect` output files, with their spreads, printed as the robot file's ball block.
void printBallPhysicsFit(const std::vector<std::string>& files, const fw::Config& config);

// `calibrate ball-colour`: the match ball's colours from a recording of it (uri, with colour), how
// well they separate it from everything else, and, with write, written into robot_file.
void calibrateBallColourInto(const std::string& uri, const fw::Config& config, const std::string& robot_file,
                             bool write);

}  // namespace kinect3d
