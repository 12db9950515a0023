// `kinect3d fuse` and `kinect3d report fusion`: the robot's own plugins (localisation, kinect3d, omni,
// fusion) run by the host's deterministic mode on recorded files, and the world balls they publish.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "framework_api/config.h"
#include "fusion/ball_fusion.h"
#include "kinect3d/sim/field_sensors.h"
#include "kinect3d/sim/scene.h"

namespace kinect3d {

// The recorded inputs; an empty one is left out, with its plugin.
struct RecordedFiles {
  std::string depth;  // a depth source URI, for the kinect3d plugin (none: the omni camera alone)
  std::string omni;   // omni balls, JSON lines (none: the Kinect alone)
  std::string pose;   // robot poses, JSON lines (none: the robot stands at the field origin facing +y)
};

struct FusionRun {
  // The world ball after each depth or omni frame, in the order the fusion plugin published them
  // (no rejections: the plugin publishes none).
  std::vector<fusion::FusionUpdate> updates;
  std::optional<double> omni_latency_s;  // what the fusion last said it learnt, relative to the Kinect
  std::optional<double> pose_latency_s;  // likewise the pose's
};

// Hands every input of the files to its plugin (fw::Host::replay) in source-time order, as a robot
// receives them when each arrives the moment it is stamped: at equal times a pose, then a depth
// frame, then an omni image, and each file's own order kept. The plugins are configured by config
// (the robot's blocks), with only their sources, the pace and host.plugins set here.
FusionRun fuseRecorded(const fw::Config& config, const RecordedFiles& files);

// The simulated robot's omni camera and localisation for a scene, as omni.jsonl and pose.jsonl in dir.
void writeFieldSensorFiles(const sim::Scene& scene, const sim::OmniCameraModel& omni,
                           const sim::LocalisationModel& localisation, const std::string& dir);

}  // namespace kinect3d
