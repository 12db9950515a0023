// `kinect3d detect`: the robot's kinect3d plugin run on a recording, and the JSON line it writes per
// depth frame (docs/cli.md), also what `kinect3d export` writes from a match log.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "framework_api/config.h"
#include "framework_api/world_state.h"

namespace kinect3d {

// {"frame", "t", "balls": [{"x", "y", "z", "state", "points", "static", "colour"}], "process_ms" (null when
// not known), "trajectory": null or {"p", "v", "state", "support", "rms_m", "touchdown", "crossing"}};
// positions to 0.1 mm, times to 1 us.
std::string detectLine(std::uint64_t frame_index, double t_s, const std::vector<fw::BallObservation>& balls,
                       std::optional<double> process_s, const std::optional<fw::BallTrajectory>& trajectory);

// One depth plugin's detect lines from what the world state published, in order (the journal of a
// running host, or a match log): a depth image starts a frame, the plugin's balls and trajectory
// complete it, and the trajectory stands until the plugin withdraws it. The depth images must be
// there: they give the frame numbers.
class DetectLines {
 public:
  DetectLines(std::string source, std::function<void(const std::string& line)> write)
      : source_(std::move(source)), write_(std::move(write)) {}
  void add(const fw::WorldItem& item);
  void add(const fw::DepthImage& image);  // a frame of the source begins (the last is written)
  // Writes the frame being assembled, if any (process_s: the detector's time for it, when known).
  void flush(std::optional<double> process_s = std::nullopt);
  std::uint64_t frames() const { return frames_; }
  std::uint64_t framesWithBall() const { return frames_with_ball_; }

 private:
  struct Frame {
    std::uint64_t index = 0;
    double t_s = 0.0;
    std::vector<fw::BallObservation> balls;
  };
  std::string source_;
  std::function<void(const std::string&)> write_;
  std::optional<Frame> frame_;  // begun by its depth image, not yet written
  std::optional<fw::BallTrajectory> trajectory_;
  std::uint64_t frames_ = 0, frames_with_ball_ = 0;
};

// `kinect3d detect`: the kinect3d plugin alone in a host (config's host.plugins set aside), on
// every frame of its kinect3d.source as fast as it takes them (fw::Host::replaySource): what the
// robot's plugin publishes, a line per frame into out (out_name names it in errors). Throws when the
// plugin gives up or out cannot be written.
void detect(const fw::Config& config, std::ostream& out, const std::string& out_name);

}  // namespace kinect3d
