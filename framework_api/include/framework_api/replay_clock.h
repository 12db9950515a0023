// Plays recorded or simulated measurements at their own pace: the first source time is anchored
// to the wall clock, and a later one is due when as much wall time has passed. Without realtime
// everything is due at once.
#pragma once

#include <optional>

namespace fw {

class ReplayClock {
 public:
  explicit ReplayClock(bool realtime) : realtime_(realtime) {}

  // Waits at most max_wait_s for source_time_s to come due; true once it has.
  bool waitFor(double source_time_s, double max_wait_s = 0.1);

 private:
  bool realtime_;
  std::optional<double> offset_s_;  // wall time minus source time at the anchor
};

}  // namespace fw
