// The simulator as a source of depth frames, in the two forms the rest of the product reads:
// a DepthSource (sim:<scene>) and an OpenNI2 device (see sim/openni2_driver/).
#pragma once

#include <string>

#include "kinect3d/depth_source.h"

namespace kinect3d::sim {

// Adds sim:<scene> (a built-in scene name or a scene file ending in .yaml) to an application's table.
void addSimulatorSource(DepthSourceTable& table);

// The core's schemes plus sim:, what the CLI, the demo plugin and the tests open.
DepthSourceTable sourcesWithSimulator();

// The URI that opens the simulator as an OpenNI2 device: "openni2:" + simulatedDeviceUri("kick_away",
// 20) is a source, the URI alone a device. frames 0: the whole scene; seed -1: the scene's own noise
// seed.
std::string simulatedDeviceUri(const std::string& scene, int frames = 0, long seed = -1);

}  // namespace kinect3d::sim
