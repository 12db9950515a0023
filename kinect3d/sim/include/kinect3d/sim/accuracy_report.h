// `kinect3d report`: the accuracy report (docs/accuracy.md) from simulated scenes and real frames.
#pragma once

#include <string>

#include "framework_api/config.h"

namespace kinect3d {

struct ReportOptions {
  int seeds = 3;              // noise seeds per kick/shot scene
  int clutter_frames = 1500;  // frames of the clutter scene (for the phantom rate)
  int people_seeds = 20;      // random scenes per kind in the people section
  int colour_seeds = 8;       // random scenes per kind of people and per ball in the colour section
  std::string real_data_dir;  // third-party real frames (holding real-depth/ and realdata/); empty: left out
};

// Writes the markdown report to out_path; prints a summary on stderr.
void writeAccuracyReport(const fw::Config& config, const ReportOptions& options, const std::string& out_path);

}  // namespace kinect3d
