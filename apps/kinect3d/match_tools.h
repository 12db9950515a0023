// What the team does with a match log after the match (docs/match-log.md): re-run it with other
// settings, and take its inputs out as the files the other commands read.
#pragma once

#include <set>
#include <string>
#include <vector>

namespace kinect3d {

// `kinect3d replay`: the robot's own plugins (detection, trajectory, fusion, the logger) re-run by
// the host's deterministic mode (fw::Host::replay) on the recorded depth, omni images and poses, in
// the order the robot received them, into a new run folder under output. The configuration is the
// recorded one (written to <output>/recorded_config.yaml), or robot_file instead when given, with
// the overrides on top. The same log and settings always give the same output, and the robot's own
// settings give what the robot published.
void replayMatch(const std::string& log_folder, const std::string& defaults_dir, const std::string& robot_file,
                 const std::vector<std::string>& overrides, const std::string& output);

// `kinect3d export`: the files `kinect3d fuse` and `kinect3d detect` use; empty names are skipped.
struct ExportFiles {
  std::string omni;        // omni images, JSON lines
  std::string pose;        // robot poses, JSON lines
  std::string detections;  // the depth plugin's balls and trajectory per frame, as `kinect3d detect` writes
  std::string tum;         // the depth, as a TUM RGB-D folder
};
void exportMatch(const std::string& log_folder, const ExportFiles& files);

// `kinect3d view`'s log folders. The run folder a logger started in base after `before` (its
// entries then), once it holds a readable log; throws after 20 s without one.
std::string newRunFolder(const std::string& base, const std::set<std::string>& before);
// The match logs in a folder of them (the logger's logs/), in no particular order.
std::vector<std::string> matchLogsIn(const std::string& folder);
// A match log folder as given, or the newest in a folder of them (the logger's logs/), said aloud.
std::string newestRun(const std::string& folder);

}  // namespace kinect3d
