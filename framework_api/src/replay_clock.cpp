#include "framework_api/replay_clock.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "framework_api/time_line.h"
#include "framework_api/types.h"

namespace fw {

double SharedPace::anchor(double wall_minus_source_s) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!wall_minus_source_s_) wall_minus_source_s_ = wall_minus_source_s;
  return *wall_minus_source_s_;
}

ReplayClock::Pace ReplayClock::waitFor(double source_time_s, double max_wait_s) {
  if (!realtime_ || !std::isfinite(source_time_s)) return Pace::kDue;
  const double now_s = wallClockNow_s();
  if (!offset_s_) {
    offset_s_ = now_s - source_time_s;
    if (host_pace_ != nullptr) {
      const double shared_s = host_pace_->anchor(*offset_s_);
      if (std::abs(shared_s - *offset_s_) <= kMaxStampJump_s) offset_s_ = shared_s;
    }
  }
  const double wait_s = source_time_s + *offset_s_ - now_s;
  if (!pinned_ && std::abs(wait_s) > kMaxStampJump_s) {
    offset_s_ = now_s - source_time_s;
    return Pace::kRebased;
  }
  if (wait_s <= 0.0) return Pace::kDue;
  std::this_thread::sleep_for(std::chrono::duration<double>(std::min(wait_s, max_wait_s)));
  return wait_s <= max_wait_s ? Pace::kDue : Pace::kNotYet;
}

std::optional<double> ReplayClock::dueWall_s(double source_time_s) const {
  if (!realtime_ || !offset_s_) return std::nullopt;
  return source_time_s + *offset_s_;
}

}  // namespace fw
