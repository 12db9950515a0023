// Where the product's files lie relative to its executables. The build tree and an installed tree
// (`cmake --install build --prefix DIR`) share one layout, so every executable finds its plugins
// and default configuration from its own location, wherever the tree was copied:
//   <prefix>/bin/                  vision_host, kinect3d, kinect3d_bench
//   <prefix>/lib/kinect3d/plugins/ the plugins vision_host loads
//   <prefix>/share/kinect3d/config/ defaults/ and robots/
#pragma once

#include <string>

namespace fw {

// <prefix>/lib/kinect3d/plugins for the running executable.
std::string defaultPluginDir();
// <prefix>/share/kinect3d/config for the running executable.
std::string defaultConfigDir();

}  // namespace fw
