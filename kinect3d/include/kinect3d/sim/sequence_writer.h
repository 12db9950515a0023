// Writes simulated sequences to disk: depth as a TUM sequence (depth.txt, 16-bit PNGs at 5000 units
// per metre, camera.yaml) and the ground truth as truth.json.
#pragma once

#include <string>
#include <vector>

#include "kinect3d/depth_frame.h"
#include "kinect3d/sim/kinect_simulator.h"

namespace kinect3d::sim {

class TumSequenceWriter {
 public:
  // Creates dir (and dir/depth) if needed; throws std::runtime_error naming the path on failure.
  explicit TumSequenceWriter(const std::string& dir);
  void write(const DepthFrame& frame);

 private:
  std::string dir_;
  bool camera_written_ = false;
};

// truth.json: the scene name and one object per frame (see docs/simulator.md).
void writeTruthJson(const std::string& path, const Scene& scene, const std::vector<GroundTruth>& truth);

}  // namespace kinect3d::sim
