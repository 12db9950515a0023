#include "kinect3d/depth_source.h"

#include <algorithm>
#include <filesystem>
#include <stdexcept>
#include <thread>

#include "framework_api/log.h"
#include "framework_api/types.h"
#include "sources.h"

namespace kinect3d {

ReadResult DepthSource::read(DepthFrame& frame) {
  if (!has_pending_) {
    const ReadResult result = readFrame(pending_);
    if (result != ReadResult::kFrame) return result;
    accept(pending_);
    has_pending_ = true;
  }
  // In real time a frame waits for its moment in slices of at most max_wait_s, so a caller (a
  // plugin's step) is never blocked longer and can be stopped meanwhile.
  if (options_.realtime && !dueNow(pending_)) return ReadResult::kNoFrameYet;
  std::swap(frame, pending_);  // buffers change hands: nothing is allocated once warm
  has_pending_ = false;
  frame.receive_time_s = fw::wallClockNow_s();
  return ReadResult::kFrame;
}

void DepthSource::accept(const DepthFrame& frame) {
  const std::size_t expected = static_cast<std::size_t>(frame.intrinsics.width) * frame.intrinsics.height;
  if (frame.depth_mm.size() != expected) {
    throw DepthSourceError(describe() + ": frame " + std::to_string(frame.index) + " has " +
                           std::to_string(frame.depth_mm.size()) + " pixels, expected " + std::to_string(expected));
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
}

bool DepthSource::dueNow(const DepthFrame& frame) {
  const double now_s = fw::wallClockNow_s();
  if (!paced_) {
    paced_ = true;
    first_source_time_s_ = frame.source_time_s;
    first_wall_time_s_ = now_s;
    return true;
  }
  const double wait_s = (frame.source_time_s - first_source_time_s_) - (now_s - first_wall_time_s_);
  if (wait_s > kMaxPacingWait_s || wait_s < -kMaxPacingWait_s) {
    // A jump in the recording's clock (or a stall here): pace from this frame on instead of
    // sleeping through the jump or racing to catch up.
    fw::logWarn("depth", describe() + ": frame " + std::to_string(frame.index) + " is " + std::to_string(wait_s) +
                             " s off the pace; pacing starts again from it");
    first_source_time_s_ = frame.source_time_s;
    first_wall_time_s_ = now_s;
    return true;
  }
  if (wait_s > options_.max_wait_s) {
    std::this_thread::sleep_for(std::chrono::duration<double>(options_.max_wait_s));
    return false;
  }
  if (wait_s > 0.0) std::this_thread::sleep_for(std::chrono::duration<double>(wait_s));
  return true;
}

namespace {
// The first few of a kind, then one in a hundred: a covered sensor must not flood the log.
bool worthLogging(std::uint64_t count) { return count <= 5 || count % 100 == 0; }
}  // namespace

void DepthSource::checkSanity(const DepthFrame& frame) {
  if (counters_.frames > 1 && frame.source_time_s <= last_source_time_s_) {
    ++counters_.stale_stamps;
    if (worthLogging(counters_.stale_stamps)) {
      fw::logWarn("depth", describe() + ": frame " + std::to_string(frame.index) + " is stamped " +
                               std::to_string(frame.source_time_s) + " s, not after the previous frame's " +
                               std::to_string(last_source_time_s_) + " s (" + std::to_string(counters_.stale_stamps) +
                               " so far); the trajectory will not use it");
    }
  } else {
    last_source_time_s_ = frame.source_time_s;
  }
  // Searched from the last row up, where the floor usually is: a normal frame stops at once.
  const bool blank =
      std::all_of(frame.depth_mm.rbegin(), frame.depth_mm.rend(), [](std::uint16_t d) { return d == 0; });
  if (blank) {
    ++counters_.blank;
    if (worthLogging(counters_.blank)) {
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
    throw DepthSourceError("'" + uri + "' is neither an .oni file nor a folder holding depth.txt; " +
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
