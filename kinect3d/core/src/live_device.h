// What every live depth device does when it is absent at start, unplugged, or goes quiet (an
// unplugged Kinect goes quiet rather than failing): it is reported and reopened every second,
// delivering no frames meanwhile, never spinning and never blocking the caller longer than
// max_wait_s, so the host stays stoppable. With wait_for_device, one that is absent at start is
// waited for and opened when it appears; without, that is an error. A loss is reported once until
// frames flow again, so a device that opens but delivers nothing (fakenect at the end of its
// recording) is not reported once a second.
#pragma once

#include <chrono>
#include <string>

#include "kinect3d/depth_source.h"

namespace kinect3d {

class LiveDevice : public DepthSource {
 protected:
  // log_tag: the component name in the log ("openni2", "freenect").
  LiveDevice(std::string log_tag, const SourceOptions& options);
  // The subclass's constructor ends with this: opens the device, or waits for it.
  void start();
  const std::string& logTag() const { return log_tag_; }

 private:
  using Clock = std::chrono::steady_clock;
  static constexpr std::chrono::seconds kSilenceLimit{1};
  static constexpr std::chrono::seconds kReopenInterval{1};
  static constexpr std::chrono::seconds kWaitingMessageInterval{5};

  // Opens and starts the device; throws DepthSourceError saying why it cannot.
  virtual void openDevice() = 0;
  virtual void closeDevice() = 0;
  virtual bool deviceOpen() const = 0;
  // Waits up to wait_ms for a frame: true with frame filled, false when none came. Throws
  // DepthSourceError when the device failed.
  virtual bool readDevice(DepthFrame& frame, int wait_ms) = 0;

  ReadResult readFrame(DepthFrame& frame) final;
  ReadResult reopen(int wait_ms);
  void lose(const std::string& why);

  std::string log_tag_;
  Clock::time_point last_frame_;
  Clock::time_point next_attempt_{};
  bool ever_streamed_ = false;
  bool streamed_since_open_ = false;  // a frame since the device was last opened
  bool reopened_ = false;             // opened again after a loss: reported with its first frame
  bool loss_reported_ = false;        // since the last frame
  Clock::time_point waiting_since_{}, next_waiting_message_{};
};

}  // namespace kinect3d
