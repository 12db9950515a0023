// Constructors of the core's concrete sources, for DepthSourceTable::core() only. The rest of the code sees the
// DepthSource interface.
#pragma once

#include <memory>
#include <string>

#include "kinect3d/depth_source.h"

namespace kinect3d {

std::unique_ptr<DepthSource> openTumSequence(const std::string& dir, const SourceOptions& options);
std::unique_ptr<DepthSource> openOpenNI2Device(const std::string& device_uri, const SourceOptions& options);
std::unique_ptr<DepthSource> openOniRecording(const std::string& path, const SourceOptions& options);
std::unique_ptr<DepthSource> openFreenectDevice(const std::string& index, const SourceOptions& options);
std::unique_ptr<DepthSource> openFakenectRecording(const std::string& dir, const SourceOptions& options);
// A match log's recorded depth (log:<folder>): the frames of the log's (first) depth plugin with
// their original time stamps and frame indices, as fast as possible or, with realtime, at the pace
// they were recorded.
std::unique_ptr<DepthSource> openMatchLog(const std::string& folder, const SourceOptions& options);

}  // namespace kinect3d
