// The Kinect v1 through libfreenect (Debian's libfreenect 0.5.3): freenect:[index].
//
// Depth is asked for in the 11-bit raw mode, the one mode every libfreenect (and its fakenect
// replay library) has, and converted with the product's disparity model: the unit's own constants
// when libfreenect can read them from the device, the documented default otherwise. Functions that
// fakenect lacks (the registration) are looked up at run time, so the same binary runs over either.
#include <dlfcn.h>
#include <libfreenect.h>
#include <libfreenect_registration.h>
#include <sys/time.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <optional>

#include "colour_pairing.h"
#include "framework_api/log.h"
#include "framework_api/replay_clock.h"
#include "kinect3d/camera_file.h"
#include "kinect3d/kinect_disparity.h"
#include "live_device.h"
#include "sources.h"

namespace kinect3d {

namespace {

// The unit's disparity line and focal length from its registration constants, when the loaded
// libfreenect has freenect_copy_registration (fakenect does not).
struct UnitConstants {
  DisparityModel disparity;
  Intrinsics intrinsics;
};
std::optional<UnitConstants> readUnitConstants(freenect_device* device) {
  void* library = dlopen("libfreenect.so.0.5", RTLD_NOW | RTLD_NOLOAD);
  if (library == nullptr) return std::nullopt;
  using Copy = freenect_registration (*)(freenect_device*);
  using Destroy = int (*)(freenect_registration*);
  const auto copy = reinterpret_cast<Copy>(dlsym(library, "freenect_copy_registration"));
  const auto destroy = reinterpret_cast<Destroy>(dlsym(library, "freenect_destroy_registration"));
  dlclose(library);
  if (copy == nullptr || destroy == nullptr) return std::nullopt;
  freenect_registration registration = copy(device);
  const freenect_zero_plane_info zero_plane = registration.zero_plane_info;
  const double const_shift = registration.const_shift;
  destroy(&registration);
  if (!(zero_plane.reference_distance > 0.0f && zero_plane.reference_pixel_size > 0.0f &&
        zero_plane.dcmos_emitter_dist > 0.0f)) {
    return std::nullopt;
  }
  UnitConstants unit;
  unit.disparity = DisparityModel::fromDeviceConstants(zero_plane.reference_distance, zero_plane.reference_pixel_size,
                                                       zero_plane.dcmos_emitter_dist, const_shift);
  // The zero plane's pixels are those of the 1280x1024 sensor; the VGA image halves them.
  unit.intrinsics.fx = unit.intrinsics.fy = zero_plane.reference_distance / (2.0 * zero_plane.reference_pixel_size);
  return unit;
}

class FreenectDevice : public LiveDevice {
 public:
  FreenectDevice(const std::string& index, const SourceOptions& options) : LiveDevice("freenect", options) {
    try {
      std::size_t used = 0;
      index_ = index.empty() ? 0 : std::stoi(index, &used);
      if (!index.empty() && (used != index.size() || index_ < 0)) throw std::invalid_argument(index);
    } catch (const std::logic_error&) {
      throw DepthSourceError("freenect:" + index + ": expected freenect: or freenect:<device index>, e.g. freenect:0");
    }
    start();
  }
  ~FreenectDevice() override { closeDevice(); }

  std::string describe() const override { return "freenect:" + std::to_string(index_); }

 private:
  // The accelerometer is read over a blocking USB control transfer: every third frame (10 Hz) is plenty.
  static constexpr int kAccelerometerEveryFrames = 3;
  static constexpr double kMaxColourMismatch_s = 1.5 / 30.0;

  void openDevice() override {
    if (freenect_init(&context_, nullptr) < 0) {
      context_ = nullptr;
      throw DepthSourceError(describe() + ": libfreenect cannot start (libusb)");
    }
    freenect_set_log_level(context_, FREENECT_LOG_WARNING);
    freenect_select_subdevices(context_,
                               static_cast<freenect_device_flags>(FREENECT_DEVICE_MOTOR | FREENECT_DEVICE_CAMERA));
    const int devices = freenect_num_devices(context_);
    if (devices <= index_ || freenect_open_device(context_, &device_, index_) < 0) {
      device_ = nullptr;
      closeDevice();
      throw DepthSourceError(describe() + ": no Kinect v1 at index " + std::to_string(index_) + " (" +
                             std::to_string(std::max(devices, 0)) + " found)");
    }
    freenect_set_user(device_, this);
    const std::optional<UnitConstants> unit = readUnitConstants(device_);
    disparity_ = DisparityTable(unit ? unit->disparity : DisparityModel{});
    intrinsics_ = unit ? unit->intrinsics : Intrinsics{};
    if (!logged_constants_) {
      char focal[32];
      std::snprintf(focal, sizeof focal, "fx %.1f px", intrinsics_.fx);
      fw::logInfo("freenect", describe() + (unit ? ": the unit's own disparity constants, " + std::string(focal)
                                                 : ": libfreenect gives no unit constants; the default disparity "
                                                   "line and " +
                                                       std::string(focal)));
      logged_constants_ = true;
    }
    if (freenect_set_depth_mode(device_, freenect_find_depth_mode(FREENECT_RESOLUTION_MEDIUM, FREENECT_DEPTH_11BIT)) <
            0 ||
        (freenect_set_depth_callback(device_, &FreenectDevice::onDepth), freenect_start_depth(device_) < 0)) {
      closeDevice();
      throw DepthSourceError(describe() + ": cannot start 640x480 11-bit depth");
    }
    if (options().colour) {
      freenect_set_video_callback(device_, &FreenectDevice::onColour);
      if (freenect_set_video_mode(device_, freenect_find_video_mode(FREENECT_RESOLUTION_MEDIUM, FREENECT_VIDEO_RGB)) <
              0 ||
          freenect_start_video(device_) < 0) {
        closeDevice();
        throw DepthSourceError(describe() + ": cannot start 640x480 RGB colour");
      }
    }
    stamps_.reset();
    anchor_s_.reset();
    colour_.clear();
    frames_ = 0;
  }

  void closeDevice() override {
    if (device_ != nullptr) {
      freenect_stop_depth(device_);
      if (options().colour) freenect_stop_video(device_);
      freenect_close_device(device_);
      device_ = nullptr;
    }
    if (context_ != nullptr) {
      freenect_shutdown(context_);
      context_ = nullptr;
    }
  }

  bool deviceOpen() const override { return device_ != nullptr; }

  bool readDevice(DepthFrame& frame, int wait_ms) override {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(wait_ms);
    target_ = &frame;
    arrived_ = false;
    while (!arrived_ && std::chrono::steady_clock::now() < deadline) {
      timeval timeout{0, 10000};  // 10 ms slices; fakenect ignores it and sleeps by the recording
      if (freenect_process_events_timeout(context_, &timeout) < 0) {
        target_ = nullptr;
        throw DepthSourceError("libfreenect stopped delivering (device unplugged, or the end of a fakenect recording)");
      }
    }
    target_ = nullptr;
    if (!arrived_) return false;
    if (frames_++ % kAccelerometerEveryFrames == 0 && freenect_update_tilt_state(device_) >= 0) {
      const freenect_raw_tilt_state* state = freenect_get_tilt_state(device_);
      // All zero is no reading yet (fakenect before its first accelerometer file), never a sensor at rest.
      if (state->accelerometer_x != 0 || state->accelerometer_y != 0 || state->accelerometer_z != 0) {
        gravity_S_mps2_ =
            gravityFromAccelerometer(state->accelerometer_x, state->accelerometer_y, state->accelerometer_z);
      }
    }
    frame.gravity_S_mps2 = gravity_S_mps2_;
    // The colour image of the same moment: the device sends it just after or just before the depth,
    // so at most a frame period away; none nearer (a stalled colour stream) is none.
    frame.colour = colour_.pairWith(frame.source_time_s, kMaxColourMismatch_s);
    return true;
  }

  // The device's time of a stamp: its 60 MHz clock unwrapped, counted from the host's clock at the
  // first frame after opening.
  KinectStampClock::Time timeOf(std::uint32_t stamp) {
    const KinectStampClock::Time time = stamps_.next(stamp);
    if (!anchor_s_) anchor_s_ = fw::wallClockNow_s() - time.seconds;
    return time;
  }

  static void onDepth(freenect_device* device, void* raw, std::uint32_t stamp) {
    auto* self = static_cast<FreenectDevice*>(freenect_get_user(device));
    if (self->target_ == nullptr) return;
    DepthFrame& frame = *self->target_;
    const KinectStampClock::Time time = self->timeOf(stamp);
    frame.resize(self->intrinsics_);
    self->disparity_.convert(raw, frame);
    frame.source_time_s = *self->anchor_s_ + time.seconds;
    frame.index = static_cast<std::uint64_t>(std::max<std::int64_t>(time.index, 0));
    self->arrived_ = true;
  }

  static void onColour(freenect_device* device, void* rgb, std::uint32_t stamp) {
    auto* self = static_cast<FreenectDevice*>(freenect_get_user(device));
    const KinectStampClock::Time time = self->timeOf(stamp);
    const auto* bytes = static_cast<const std::uint8_t*>(rgb);
    const ColourCamera camera = ColourCamera::kinectV1();
    self->colour_.add(
        camera.image(std::vector<std::uint8_t>(bytes, bytes + 640 * 480 * 3), *self->anchor_s_ + time.seconds));
  }

  int index_ = 0;
  freenect_context* context_ = nullptr;
  freenect_device* device_ = nullptr;
  DisparityTable disparity_;
  Intrinsics intrinsics_;
  bool logged_constants_ = false;
  KinectStampClock stamps_;
  std::optional<double> anchor_s_;
  DepthFrame* target_ = nullptr;  // where onDepth writes, while readDevice waits
  bool arrived_ = false;
  std::uint64_t frames_ = 0;
  std::optional<Eigen::Vector3d> gravity_S_mps2_;
  ColourPairing colour_;
};

}  // namespace

std::unique_ptr<DepthSource> openFreenectDevice(const std::string& index, const SourceOptions& options) {
  return std::make_unique<FreenectDevice>(index, options);
}

}  // namespace kinect3d
