#include "kinect3d/depth_source.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>

#include "framework_api/log.h"
#include "framework_api/types.h"
#include "sources.h"

namespace kinect3d {

ReadResult DepthSource::read(DepthFrame& frame) {
  if (!has_pending_) {
    const ReadResult result = readFrame(pending_);
    if (result != ReadResult::kFrame) return result;
    if (!accept(pending_)) return ReadResult::kNoFrameYet;  // skipped: the next call reads on
    has_pending_ = true;
  }
  // In real time a frame waits for its moment in slices of at most max_wait_s, so a caller (a
  // plugin's step) is never blocked longer and can be stopped meanwhile.
  if (options_.realtime) {
    switch (pacing_.waitFor(pending_.source_time_s, options_.max_wait_s)) {
      case fw::ReplayClock::Pace::kNotYet:
        return ReadResult::kNoFrameYet;
      case fw::ReplayClock::Pace::kRebased:
        fw::logWarn("depth", describe() + ": frame " + std::to_string(pending_.index) +
                                 " is more than a second off the pace; pacing starts again from it");
        break;
      case fw::ReplayClock::Pace::kDue:
        break;
    }
  }
  std::swap(frame, pending_);  // buffers change hands: nothing is allocated once warm
  has_pending_ = false;
  frame.receive_time_s = fw::wallClockNow_s();
  return ReadResult::kFrame;
}

bool DepthSource::accept(const DepthFrame& frame) {
  const std::size_t expected = static_cast<std::size_t>(frame.intrinsics.width) * frame.intrinsics.height;
  if (frame.depth_mm.size() != expected) {
    throw DepthSourceError(describe() + ": frame " + std::to_string(frame.index) + " has " +
                           std::to_string(frame.depth_mm.size()) + " pixels, expected " + std::to_string(expected));
  }
  if (!std::isfinite(frame.source_time_s)) {
    reportSkipped(describe() + ": frame " + std::to_string(frame.index) + "'s time stamp " +
                  time_line_.describe(fw::TimeLine::Step::kNotFinite, frame.source_time_s));
    return false;
  }
  if (has_last_index_ && frame.index > last_index_ + 1) {
    // A gap the source skipped itself (an unreadable file) is counted as skipped, not dropped.
    const std::uint64_t gap = frame.index - last_index_ - 1;
    counters_.dropped += gap > skipped_since_last_frame_ ? gap - skipped_since_last_frame_ : 0;
  }
  skipped_since_last_frame_ = 0;
  has_last_index_ = true;
  last_index_ = frame.index;
  ++counters_.frames;
  checkSanity(frame);
  return true;
}

void DepthSource::checkSanity(const DepthFrame& frame) {
  const fw::TimeLine::Step step = time_line_.next(frame.source_time_s);
  if (step == fw::TimeLine::Step::kLate || step == fw::TimeLine::Step::kJump) {
    std::uint64_t& count = step == fw::TimeLine::Step::kLate ? counters_.stale_stamps : counters_.time_jumps;
    ++count;
    if (fw::worthLogging(count)) {
      fw::logWarn("depth", describe() + ": frame " + std::to_string(frame.index) + "'s time stamp " +
                               time_line_.describe(step, frame.source_time_s) + " (" + std::to_string(count) +
                               " such frames so far); " +
                               (step == fw::TimeLine::Step::kLate ? "the trajectory will not use it"
                                                                  : "what follows starts again from it"));
    }
  }
  // Searched from the last row up, where the floor usually is: a normal frame stops at once.
  const bool blank =
      std::all_of(frame.depth_mm.rbegin(), frame.depth_mm.rend(), [](std::uint16_t d) { return d == 0; });
  if (blank) {
    ++counters_.blank;
    if (fw::worthLogging(counters_.blank)) {
      fw::logWarn("depth", describe() + ": frame " + std::to_string(frame.index) +
                               " has no valid depth at all: is the sensor covered or blinded? (" +
                               std::to_string(counters_.blank) + " such frames so far)");
    }
  }
}

void DepthSource::reportReconnected() {
  ++counters_.reconnects;
  has_last_index_ = false;  // a reopened device counts its frames from the start
}

void DepthSource::reportSkipped(const std::string& what) {
  ++counters_.skipped;
  ++skipped_since_last_frame_;
  fw::logWarn("depth", "skipped unreadable frame: " + what);
}

DepthSourceTable DepthSourceTable::core() {
  DepthSourceTable table;
  table.add("openni2", openOpenNI2Device);
  table.add("oni", openOniRecording);
  table.add("tum", openTumSequence);
  table.add("freenect", openFreenectDevice);
  table.add("fakenect", openFakenectRecording);
  table.add("log", openMatchLog);
  return table;
}

void DepthSourceTable::add(const std::string& scheme, Opener opener) {
  if (!openers_.emplace(scheme, std::move(opener)).second) {
    throw std::invalid_argument("depth source scheme '" + scheme + ":' is already in the table");
  }
}

std::vector<std::string> DepthSourceTable::schemes() const {
  std::vector<std::string> names;
  for (const auto& entry : openers_) names.push_back(entry.first);
  return names;
}

std::string DepthSourceTable::listSchemes() const {
  std::string list;
  for (const auto& entry : openers_) list += (list.empty() ? "" : ", ") + entry.first + ":";
  return list;
}

std::unique_ptr<DepthSource> DepthSourceTable::open(const std::string& uri, const SourceOptions& options) const {
  namespace fs = std::filesystem;
  const auto colon = uri.find(':');
  const std::string scheme = colon == std::string::npos ? "" : uri.substr(0, colon);
  if (scheme.empty() || scheme.find('/') != std::string::npos) {
    // A bare path: recognised by what it is.
    if (fs::path(uri).extension() == ".oni") return open("oni:" + uri, options);
    if (fs::is_directory(uri) && fs::exists(fs::path(uri) / "depth.txt")) return open("tum:" + uri, options);
    if (fs::is_directory(uri) && fs::exists(fs::path(uri) / "INDEX.txt")) return open("fakenect:" + uri, options);
    throw DepthSourceError("'" + uri + "' is neither an .oni file nor a folder holding depth.txt or INDEX.txt; " +
                           "use a URI with one of the schemes " + listSchemes());
  }
  const auto opener = openers_.find(scheme);
  if (opener == openers_.end()) {
    throw DepthSourceError("unknown depth source scheme '" + scheme + ":' in '" + uri + "'; expected one of " +
                           listSchemes());
  }
  return opener->second(uri.substr(colon + 1), options);
}

}  // namespace kinect3d
