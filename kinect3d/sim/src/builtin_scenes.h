// The scene files in kinect3d/scenes/, compiled in (the build generates the definition).
#pragma once

#include <map>
#include <string>

namespace kinect3d::sim {

// Scene name (file name without .yaml) -> YAML text.
const std::map<std::string, std::string>& builtinScenes();

}  // namespace kinect3d::sim
