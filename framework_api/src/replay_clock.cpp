#include "framework_api/replay_clock.h"

#include <algorithm>
#include <chrono>
#include <thread>

#include "framework_api/types.h"

namespace fw {

bool ReplayClock::waitFor(double source_time_s, double max_wait_s) {
  if (!realtime_) return true;
  const double now_s = wallClockNow_s();
  if (!offset_s_) offset_s_ = now_s - source_time_s;
  const double wait_s = source_time_s + *offset_s_ - now_s;
  if (wait_s <= 0.0) return true;
  std::this_thread::sleep_for(std::chrono::duration<double>(std::min(wait_s, max_wait_s)));
  return wait_s <= max_wait_s;
}

}  // namespace fw
