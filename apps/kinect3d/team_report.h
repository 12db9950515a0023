// `kinect3d report team`: robots of one team in one simulated world, each a live host with its own
// sensors and the team plugin, talking over loopback through a network that loses and delays; each
// robot's world ball scored against the truth with its teammates and, replayed from its own log,
// without them.
#pragma once

#include <string>
#include <vector>

namespace kinect3d {

struct TeamReportOptions {
  std::string defaults_dir;         // the per-plugin defaults every robot starts from
  std::string worlds_dir;           // the folder holding the report's worlds (team/, team5/, team_hop/, team_hop3/)
  int runs = 3;                     // live runs per world and network
  std::string keep_dir;             // every run's match logs stay here (empty: a temporary folder)
  std::vector<std::string> worlds;  // only these worlds (empty: all)
};

// The report's worlds, comma-separated.
std::string teamReportWorlds();

void writeTeamReport(const TeamReportOptions& options, const std::string& out_path);

}  // namespace kinect3d
