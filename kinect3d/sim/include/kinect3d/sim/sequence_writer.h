// Writes simulated sequences to disk: depth as a TUM sequence (depth.txt, 16-bit PNGs at 5000 units
// per metre, camera.yaml; rgb.txt and colour PNGs when the frames have colour) and the ground
// truth as truth.json.
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
  bool colour_started_ = false;
};

// truth.json: the scene name and one object per frame (see docs/simulator.md).
void writeTruthJson(const std::string& path, const Scene& scene, const std::vector<GroundTruth>& truth);

// A scene (as loaded, or changed in code) rendered to out_dir as a TUM sequence with truth.json.
void writeTumSequence(const Scene& scene, const std::string& out_dir);

// A scene (640x480) rendered to out_dir as fakenect-record writes a Kinect v1: raw disparity by
// the default disparity model, colour, the accelerometer, and 60 MHz stamps that start
// kStampFramesBeforeWrap frames before their wrap; with camera.yaml and truth.json.
constexpr int kStampFramesBeforeWrap = 10;
void writeFakenectRecording(const Scene& scene, const std::string& out_dir);

// `kinect3d simulate`: the scene (built-in name or file) written to out_dir as a TUM sequence
// (format "tum", frames rendered directly), as a fakenect recording (format "fakenect") or as an
// .oni recording (format "oni", frames served by the simulated OpenNI2 device and recorded by
// OpenNI2's Recorder in real time), with truth.json each way. frames 0: the scene's length; seed
// -1: the scene's own.
void writeSimulatedSequence(const std::string& scene_name, const std::string& out_dir, const std::string& format,
                            int frames, int seed);

}  // namespace kinect3d::sim
