// A source's time stamps on this host's clock. A sensor stamps on its own clock (a device's counter,
// a recording's times); the host stamps what it receives on its wall clock. The smallest
// receive-minus-source gap of a source's recent items is the one that waited least on its way to the
// host: the best estimate of the offset between the two clocks (it includes the source's shortest
// transfer, a millisecond or two).
#pragma once

#include <algorithm>
#include <cmath>
#include <deque>

#include "framework_api/types.h"

namespace fw {

class HostClockOf {
 public:
  static constexpr std::size_t kKept = 300;  // ten seconds at 30 Hz: a clock that drifts is followed

  void add(const Stamp& stamp) {
    const double gap_s = stamp.receive_time_s - stamp.source_time_s;
    if (!std::isfinite(gap_s)) return;
    gaps_s_.push_back(gap_s);
    if (gaps_s_.size() > kKept) gaps_s_.pop_front();
  }
  bool known() const { return !gaps_s_.empty(); }
  // Call only when known(). Host time = source time + offset.
  double hostMinusSource_s() const { return *std::min_element(gaps_s_.begin(), gaps_s_.end()); }
  double toHost(double source_time_s) const { return source_time_s + hostMinusSource_s(); }
  double toSource(double host_time_s) const { return host_time_s - hostMinusSource_s(); }

 private:
  std::deque<double> gaps_s_;
};

}  // namespace fw
