// What `kinect3d info` and `kinect3d snapshot` do with a depth source: look at what it delivers.
#pragma once

#include <string>
#include <vector>

#include "framework_api/config.h"

namespace kinect3d {

// `info`: what the source delivers (frames, rate, size, intrinsics, invalid pixels, depth range), on
// stdout; a live device for about a second. Throws DepthSourceError when it delivers nothing.
void printSourceInfo(const std::string& uri);

// `snapshot --out`: one frame of each source (frame_numbers: one for all, or one per source),
// colour-mapped on one fixed 0-8 m scale (no data in black), side by side in one PNG, so simulated
// and real frames can be compared by eye; where a source has colour, its colour image under its depth.
void writeDepthPanels(const std::vector<std::string>& uris, const std::vector<int>& frame_numbers,
                      const std::string& out);

// `snapshot --bt`: the scene map the detector builds from the source's frames up to frame `last`, as
// OctoMap's .bt.
void writeSceneMap(const std::string& uri, int last, const fw::Config& config, const std::string& out);

}  // namespace kinect3d
