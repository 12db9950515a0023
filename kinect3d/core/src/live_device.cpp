#include "live_device.h"

#include <algorithm>
#include <thread>

#include "framework_api/log.h"

namespace kinect3d {

LiveDevice::LiveDevice(std::string log_tag, const SourceOptions& options)
    : DepthSource(options), log_tag_(std::move(log_tag)) {}

void LiveDevice::start() {
  try {
    openDevice();
  } catch (const DepthSourceError& e) {
    if (!options().wait_for_device) throw;
    fw::logWarn(log_tag_, std::string(e.what()) + "; waiting for the device, trying every second");
    waiting_since_ = Clock::now();
    next_attempt_ = Clock::now() + kReopenInterval;
    next_waiting_message_ = Clock::now() + kWaitingMessageInterval;
    return;
  }
  last_frame_ = Clock::now();
}

ReadResult LiveDevice::readFrame(DepthFrame& frame) {
  const int wait_ms = static_cast<int>(options().max_wait_s * 1000.0);
  if (!deviceOpen()) return reopen(wait_ms);
  try {
    if (!readDevice(frame, wait_ms)) {
      if (Clock::now() - last_frame_ > kSilenceLimit) lose("no frame for a second");
      return ReadResult::kNoFrameYet;
    }
  } catch (const DepthSourceError& e) {
    lose(e.what());
    return ReadResult::kNoFrameYet;
  }
  last_frame_ = Clock::now();
  if (!streamed_since_open_) {
    fw::logInfo(log_tag_, describe() + (reopened_ ? ": reopened, streaming " : ": streaming ") +
                              std::to_string(frame.width()) + "x" + std::to_string(frame.height()));
    if (reopened_) reportReconnected();
    streamed_since_open_ = ever_streamed_ = true;
    reopened_ = loss_reported_ = false;
  }
  frame.sensor_id = describe();
  return ReadResult::kFrame;
}

void LiveDevice::lose(const std::string& why) {
  // Reported once, not again and again while the device opens but never delivers.
  if (!loss_reported_) fw::logError(log_tag_, describe() + ": " + why + "; reopening every second");
  loss_reported_ = true;
  closeDevice();
  next_attempt_ = Clock::now() + kReopenInterval;
}

ReadResult LiveDevice::reopen(int wait_ms) {
  if (Clock::now() < next_attempt_) {
    std::this_thread::sleep_for(
        std::min(std::chrono::milliseconds(wait_ms),
                 std::chrono::duration_cast<std::chrono::milliseconds>(next_attempt_ - Clock::now())));
    return ReadResult::kNoFrameYet;
  }
  try {
    openDevice();
    reopened_ = ever_streamed_;
    streamed_since_open_ = false;
    last_frame_ = Clock::now();
  } catch (const DepthSourceError&) {
    next_attempt_ = Clock::now() + kReopenInterval;
    if (!ever_streamed_ && Clock::now() >= next_waiting_message_) {
      const auto waited = std::chrono::duration_cast<std::chrono::seconds>(Clock::now() - waiting_since_);
      fw::logWarn(log_tag_, describe() + ": still waiting for the device (" + std::to_string(waited.count()) + " s)");
      next_waiting_message_ = Clock::now() + kWaitingMessageInterval;
    }
  }
  return ReadResult::kNoFrameYet;
}

}  // namespace kinect3d
