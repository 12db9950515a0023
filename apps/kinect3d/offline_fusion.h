// Detection and fusion run offline over recorded or simulated inputs, deterministically: what
// `kinect3d fuse` writes and what `kinect3d report fusion` measures, through the same files.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "framework_api/config.h"
#include "framework_api/types.h"
#include "fusion/ball_fusion.h"
#include "kinect3d/sim/field_sensors.h"
#include "kinect3d/sim/scene.h"

namespace kinect3d {

struct FusionRun {
  std::vector<fusion::FusionUpdate> updates;  // one per depth or omni frame, in source-time order
  std::optional<double> omni_latency_s;       // learnt, relative to the Kinect
  int latency_examples = 0;
};

// Detects balls in every frame of depth_uri (none: the omni camera alone; the scene map in the
// field frame with the pose at each frame's time), then feeds poses, Kinect frames and omni frames
// to one BallFusion in source-time order. Empty file names leave that input out (no poses: the
// robot stands at the field origin facing +y). config holds the kinect3d and fusion blocks.
FusionRun fuseFiles(const fw::Config& config, const std::string& depth_uri, const std::string& omni_file,
                    const std::string& pose_file);

// The simulated robot's omni camera and localisation for a scene, as omni.jsonl and pose.jsonl in dir.
void writeFieldSensorFiles(const sim::Scene& scene, const sim::OmniCameraModel& omni,
                           const sim::LocalisationModel& localisation, const std::string& dir);

}  // namespace kinect3d
