// The depth sources the command line opens: the core's, the simulator's sim:<scene> and a match
// log's log:<folder>.
#pragma once

#include "kinect3d/log_source.h"
#include "kinect3d/sim/sim_sources.h"

namespace kinect3d {

inline DepthSourceTable cliSources() {
  DepthSourceTable table = sim::sourcesWithSimulator();
  addLogSource(table);
  return table;
}

}  // namespace kinect3d
