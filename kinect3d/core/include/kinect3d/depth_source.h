// Where depth frames come from. The pipeline cannot tell sources apart: a live OpenNI2 device or
// Kinect v1, an .oni recording, a TUM RGB-D sequence, a fakenect recording and the simulator all
// deliver DepthFrames through read().
//
// Sources are opened by URI through a DepthSourceTable (see docs/depth-sources.md). The core
// implements these schemes:
//   openni2:            first OpenNI2 device       openni2:<device-uri>   a given device
//   freenect:           first Kinect v1 (libfreenect)  freenect:<index>   a given one
//   oni:<file>          OpenNI2 recording          <path>.oni             the same
//   tum:<dir>           TUM RGB-D sequence         <dir with depth.txt>   the same
//   fakenect:<dir>      fakenect-record folder     <dir with INDEX.txt>   the same
//   log:<folder>        a match log's depth (framework_api/matchlog)
// An application adds others to its table, e.g. the simulator's sim:<scene> (kinect3d/sim).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "framework_api/replay_clock.h"
#include "framework_api/time_line.h"
#include "kinect3d/depth_frame.h"

namespace kinect3d {

// A source that cannot be opened or read any further: names the file, line or frame.
class DepthSourceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class ReadResult {
  kFrame,       // frame filled
  kNoFrameYet,  // nothing within the wait (a live device, a paced or slow recording), or a frame
                // skipped (its time stamp is not finite); try again
  kEnd          // the recording or scene is over
};

struct SourceOptions {
  // Recordings and the simulator: deliver frames at their recorded rate rather than as fast as
  // possible (live devices are always real time).
  bool realtime = false;
  // The longest read() may block waiting for a frame.
  double max_wait_s = 0.1;
  // Live devices: one that cannot be opened yet (slow USB enumeration at boot) is waited for and
  // opened when it appears, as the robot wants; otherwise opening it is an error, as a command wants.
  bool wait_for_device = false;
  // Deliver each depth frame's colour image where the source has one (a live device then opens its
  // colour stream too).
  bool colour = false;
  // The simulator: robots simulated side by side on one machine share one world, its time 0 at this
  // wall-clock time (seconds since the epoch; host.sim_world_start_wall_s); 0: the host starts
  // its scene when its first source reads it (host_pace).
  double sim_world_start_wall_s = 0.0;
  // In real time: the anchor the host's other sources keep to (fw::WorldState::replayPace), so that
  // this source's frames come due with their images of the same moment; none: its own first frame.
  fw::SharedPace* host_pace = nullptr;
};

struct SourceCounters {
  std::uint64_t frames = 0;        // delivered
  std::uint64_t dropped = 0;       // gaps in the source's frame indices
  std::uint64_t skipped = 0;       // unreadable frames reported and skipped
  std::uint64_t reconnects = 0;    // a live device lost and opened again
  std::uint64_t stale_stamps = 0;  // frames whose time stamp did not move on (repeated or backwards)
  std::uint64_t time_jumps = 0;    // frames whose time stamp jumped by more than fw::kMaxStampJump_s
  std::uint64_t blank = 0;         // frames without one valid pixel (a covered or blinded sensor)
};

class DepthSource {
 public:
  virtual ~DepthSource() = default;

  // Fills frame with the next depth image. Checks what every source must deliver (size against
  // intrinsics), stamps receive time, counts dropped frames, and reports (counted, logged with the
  // frame) time stamps that do not move on or jump (framework_api/time_line.h) and frames without
  // any valid depth; a frame whose time stamp is not finite is skipped. In real time, paces frames
  // by fw::ReplayClock. Throws DepthSourceError when the source cannot go on.
  ReadResult read(DepthFrame& frame);

  const SourceCounters& counters() const { return counters_; }
  // The number of frames, when known in advance (recordings, scenes); 0 for live devices.
  virtual std::uint64_t frameCount() const { return 0; }
  // The nominal frame rate.
  virtual double frameRate_hz() const { return 30.0; }
  virtual std::string describe() const = 0;

 protected:
  explicit DepthSource(const SourceOptions& options) : options_(options) {}
  const SourceOptions& options() const { return options_; }
  // Sources report an unreadable frame they skipped through this, then go on to the next.
  void reportSkipped(const std::string& what);
  // A live source that reopened its device: its frame counter starts again.
  void reportReconnected();
  // Real-time pacing pinned to the wall clock (fw::ReplayClock): a frame is due when the wall clock
  // reaches its source time plus wall_minus_source_s.
  void pinPacing(double wall_minus_source_s) { pacing_ = fw::ReplayClock(options_.realtime, wall_minus_source_s); }
  // The wall time at which a frame of this source time is due in real time (fw::ReplayClock); none
  // before the first frame was read, or without realtime.
  std::optional<double> dueWall_s(double source_time_s) const { return pacing_.dueWall_s(source_time_s); }

 private:
  virtual ReadResult readFrame(DepthFrame& frame) = 0;

  // Size check, dropped-frame and sanity counts for a frame the source delivered; false when the
  // frame is skipped (its time stamp is not finite).
  bool accept(const DepthFrame& frame);
  void checkSanity(const DepthFrame& frame);

  SourceOptions options_;
  SourceCounters counters_;
  bool has_last_index_ = false;
  std::uint64_t last_index_ = 0;
  std::uint64_t skipped_since_last_frame_ = 0;
  DepthFrame pending_;  // read from the source, waiting for its moment in real time
  bool has_pending_ = false;
  fw::ReplayClock pacing_{options_.realtime, options_.host_pace};
  fw::TimeLine time_line_;
};

// The URI schemes an application can open, each with the function that opens it. An application
// (the plugin, the CLI, a test) starts from the core's schemes and adds its own; nothing registers
// itself.
class DepthSourceTable {
 public:
  // Opens the part of the URI after "<scheme>:". Throws DepthSourceError when it cannot.
  using Opener = std::function<std::unique_ptr<DepthSource>(const std::string& rest, const SourceOptions& options)>;

  // openni2:, freenect:, oni:, tum:, fakenect: and log:.
  static DepthSourceTable core();

  // Throws std::invalid_argument when the scheme is already in the table.
  void add(const std::string& scheme, Opener opener);
  std::vector<std::string> schemes() const;

  // Opens the source a URI names; a bare path is an .oni file or a folder holding depth.txt or INDEX.txt.
  // Throws DepthSourceError for an unknown scheme or a source that cannot be opened, naming the
  // URI and the cause.
  std::unique_ptr<DepthSource> open(const std::string& uri, const SourceOptions& options = {}) const;

 private:
  std::string listSchemes() const;  // "openni2:, oni:, tum:"
  std::map<std::string, Opener> openers_;
};

}  // namespace kinect3d
