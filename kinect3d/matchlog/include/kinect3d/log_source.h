// A match log's recorded depth as a depth source: log:<folder> plays the frames of the log's
// (first) depth plugin with their original source time stamps and frame indices, as fast as
// possible or, with realtime, at the pace they were recorded.
#pragma once

#include "kinect3d/depth_source.h"

namespace kinect3d {

// Adds log:<folder> to an application's table.
void addLogSource(DepthSourceTable& table);

}  // namespace kinect3d
