// Recording an OpenNI2 device's depth stream to an .oni file with OpenNI2's own Recorder.
#pragma once

#include <string>

namespace kinect3d {

// Records `frames` depth frames of the device at device_uri to path. Throws DepthSourceError
// naming the device or the file when the device cannot be opened, the file cannot be written, or
// the frames do not arrive within timeout_s.
void recordOni(const std::string& device_uri, const std::string& path, int frames, double timeout_s);

}  // namespace kinect3d
