// The one pacing rule for everything that replays recorded or simulated time in real time (depth
// sources, the omni camera's and localisation's players): the first source time is anchored to the
// wall clock, and a later one is due when as much wall time has passed. A source time more than
// fw::kMaxStampJump_s off that pace, either way (the recording's clock jumped, or this host stalled),
// re-bases the pacing on it: it is due at once and the pace goes on from there, never a sleep through
// the jump nor a burst to catch up. Without realtime everything is due at once. The sources of one
// host keep to one anchor (SharedPace), so that what their sensors saw at one moment comes due at
// one moment whichever source started reading first.
#pragma once

#include <mutex>
#include <optional>

namespace fw {

// The anchor a host's replaying sources share (fw::WorldState::replayPace): the first of them to
// read an item sets it, and the others keep to it. Without it each source anchored its own first
// item: the demo's simulated Kinect, which starts a frame or two after the omni camera's player,
// then delivered every frame that much behind the omni image of the same moment, and the world ball
// recognised a kick late. Thread-safe.
class SharedPace {
 public:
  // The wall time minus source time everyone keeps to: the first caller's.
  double anchor(double wall_minus_source_s);

 private:
  std::mutex mutex_;
  std::optional<double> wall_minus_source_s_;
};

class ReplayClock {
 public:
  enum class Pace {
    kDue,      // its moment has come
    kNotYet,   // waited max_wait_s towards it; ask again
    kRebased,  // it was more than kMaxStampJump_s off the pace: due now, the pace starts again from it
  };

  explicit ReplayClock(bool realtime) : realtime_(realtime) {}
  // A clock that keeps to its host's shared anchor: its first item is due where that anchor puts
  // it, unless that is more than kMaxStampJump_s off (a source on another clock keeps its own).
  ReplayClock(bool realtime, SharedPace* host_pace) : realtime_(realtime), host_pace_(host_pace) {}
  // A clock pinned to the wall clock: a source time is due when the wall clock reaches it plus
  // wall_minus_source_s, however late the first one is read, and the pace never re-bases (several
  // hosts simulating one world each read it on the same wall-clock schedule; what comes too late is
  // due at once).
  ReplayClock(bool realtime, double wall_minus_source_s)
      : realtime_(realtime), offset_s_(wall_minus_source_s), pinned_(true) {}

  // Waits at most max_wait_s for source_time_s to come due. A time that is not finite is due at
  // once and leaves the pace as it was (the caller reports and skips such an item).
  Pace waitFor(double source_time_s, double max_wait_s = 0.1);
  // The wall time at which source_time_s comes due on the present pace; none before the first
  // time anchored it, or without realtime.
  std::optional<double> dueWall_s(double source_time_s) const;

 private:
  bool realtime_;
  SharedPace* host_pace_ = nullptr;
  std::optional<double> offset_s_;  // wall time minus source time at the anchor
  bool pinned_ = false;
};

}  // namespace fw
