// Live OpenNI2 devices and .oni recordings, both through OpenNI2's own device layer.
#include <OpenNI.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <optional>

#include "colour_pairing.h"
#include "framework_api/log.h"
#include "kinect3d/camera_file.h"
#include "kinect3d/oni_recording.h"
#include "live_device.h"
#include "sources.h"

namespace kinect3d {

namespace {

using Clock = std::chrono::steady_clock;

// OpenNI2 is initialised once per process and never shut down while a stream may exist.
void initialiseOpenNI() {
  static std::once_flag once;
  static openni::Status status = openni::STATUS_OK;
  std::call_once(once, [] { status = openni::OpenNI::initialize(); });
  if (status != openni::STATUS_OK) {
    throw DepthSourceError(std::string("OpenNI2 failed to initialise: ") + openni::OpenNI::getExtendedError());
  }
}

// OpenNI2's last error on one line ("no reason given" when it has none, as for some truncated files).
std::string lastError() {
  std::string text = openni::OpenNI::getExtendedError();
  for (char& c : text) {
    if (c == '\n' || c == '\t' || c == '\r') c = ' ';
  }
  const auto first = text.find_first_not_of(' '), last = text.find_last_not_of(' ');
  return first == std::string::npos ? "OpenNI2 gave no reason" : text.substr(first, last - first + 1);
}

// The depth stream of one opened OpenNI2 device (live or file).
class OpenNI2Stream {
 public:
  // Opens uri (a device URI, a file, or empty for the first device) and starts depth at VGA 30 Hz
  // in millimetres where the device offers that mode. With start false the stream is created but
  // not started (so a recorder can be attached before the first frame); call start() then. With
  // colour, a live device's colour stream too (VGA RGB), depth registered to it where the device
  // can do that; a device without colour is said once and streams depth alone.
  void open(const std::string& uri, const std::string& label, bool start = true, bool colour = false) {
    close();
    if (device_.open(uri.empty() ? openni::ANY_DEVICE : uri.c_str()) != openni::STATUS_OK) {
      throw DepthSourceError(label + ": cannot open: " + lastError());
    }
    if (stream_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
      device_.close();
      throw DepthSourceError(label + ": has no depth stream: " + lastError());
    }
    if (!device_.isFile()) selectVgaMillimetres(label);
    if (colour && !device_.isFile()) openColour(label);
    if (start) this->start(label);
  }

  void start(const std::string& label) {
    if (stream_.start() != openni::STATUS_OK) {
      close();
      throw DepthSourceError(label + ": cannot start the depth stream: " + lastError());
    }
    const openni::VideoMode mode = stream_.getVideoMode();
    if (mode.getPixelFormat() != openni::PIXEL_FORMAT_DEPTH_1_MM) {
      close();
      throw DepthSourceError(label + ": depth is not in millimetres (pixel format " +
                             std::to_string(mode.getPixelFormat()) + ")");
    }
    intrinsics_ = Intrinsics::fromFieldOfView(mode.getResolutionX(), mode.getResolutionY(),
                                              stream_.getHorizontalFieldOfView(), stream_.getVerticalFieldOfView());
    fps_ = mode.getFps() > 0 ? mode.getFps() : 30;
    if (colour_stream_.isValid()) {
      if (colour_stream_.start() != openni::STATUS_OK) {
        close();
        throw DepthSourceError(label + ": cannot start the colour stream: " + lastError());
      }
      const openni::VideoMode colour_mode = colour_stream_.getVideoMode();
      // Registered depth is seen from the colour camera: one camera. Otherwise the colour camera
      // sits beside the depth camera as on a Kinect v1 (PrimeSense's layout, 2.5 cm).
      colour_camera_ = ColourCamera::kinectV1();
      colour_camera_.intrinsics = Intrinsics::fromFieldOfView(
          colour_mode.getResolutionX(), colour_mode.getResolutionY(), colour_stream_.getHorizontalFieldOfView(),
          colour_stream_.getVerticalFieldOfView());
      if (registered_) colour_camera_.offset_S_m.setZero();
    }
  }

  void close() {
    if (colour_stream_.isValid()) {
      colour_stream_.stop();
      colour_stream_.destroy();
    }
    colour_.clear();
    registered_ = false;
    if (stream_.isValid()) {
      stream_.stop();
      stream_.destroy();
    }
    if (device_.isValid()) device_.close();
  }

  // Waits up to timeout for a frame. Returns false on timeout; throws when the stream failed.
  bool read(DepthFrame& frame, int timeout_ms, const std::string& label) {
    openni::VideoStream* streams[] = {&stream_};
    int ready = -1;
    const openni::Status waited = openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms);
    if (waited == openni::STATUS_TIME_OUT) return false;
    if (waited != openni::STATUS_OK) throw DepthSourceError(label + ": " + lastError());
    openni::VideoFrameRef ref;
    if (stream_.readFrame(&ref) != openni::STATUS_OK || !ref.isValid()) {
      throw DepthSourceError(label + ": cannot read a frame: " + lastError());
    }
    if (ref.getWidth() != intrinsics_.width || ref.getHeight() != intrinsics_.height ||
        ref.getDataSize() < intrinsics_.width * intrinsics_.height * 2) {
      throw DepthSourceError(label + ": frame " + std::to_string(ref.getFrameIndex()) + " is " +
                             std::to_string(ref.getWidth()) + "x" + std::to_string(ref.getHeight()) + " with " +
                             std::to_string(ref.getDataSize()) + " bytes, expected " +
                             std::to_string(intrinsics_.width) + "x" + std::to_string(intrinsics_.height));
    }
    frame.resize(intrinsics_);
    const auto* rows = static_cast<const unsigned char*>(ref.getData());
    for (int v = 0; v < intrinsics_.height; ++v) {
      std::memcpy(&frame.depth_mm[static_cast<std::size_t>(v) * intrinsics_.width],
                  rows + static_cast<std::size_t>(v) * ref.getStrideInBytes(), intrinsics_.width * 2);
    }
    frame.index = static_cast<std::uint64_t>(ref.getFrameIndex());
    frame.source_time_s = ref.getTimestamp() * 1e-6;  // microseconds on the device clock
    if (colour_stream_.isValid()) attachColour(frame, label);
    return true;
  }

  openni::Device& device() { return device_; }
  openni::VideoStream& stream() { return stream_; }
  const Intrinsics& intrinsics() const { return intrinsics_; }
  int fps() const { return fps_; }
  bool isOpen() const { return stream_.isValid(); }

 private:
  void openColour(const std::string& label) {
    if (!device_.hasSensor(openni::SENSOR_COLOR) ||
        colour_stream_.create(device_, openni::SENSOR_COLOR) != openni::STATUS_OK) {
      fw::logWarn("openni2", label + ": has no colour stream; depth only");
      return;
    }
    const auto& modes = colour_stream_.getSensorInfo().getSupportedVideoModes();
    for (int i = 0; i < modes.getSize(); ++i) {
      if (modes[i].getResolutionX() == 640 && modes[i].getResolutionY() == 480 &&
          modes[i].getPixelFormat() == openni::PIXEL_FORMAT_RGB888) {
        colour_stream_.setVideoMode(modes[i]);
        break;
      }
    }
    if (colour_stream_.getVideoMode().getPixelFormat() != openni::PIXEL_FORMAT_RGB888) {
      fw::logWarn("openni2", label + ": its colour stream offers no RGB888 mode; depth only");
      colour_stream_.destroy();
      return;
    }
    registered_ = device_.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) &&
                  device_.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) == openni::STATUS_OK;
  }

  // The colour frames that arrived (read without waiting), kept; the one taken with the depth frame
  // (both streams run on the device clock at the same rate) is given to it.
  void attachColour(DepthFrame& frame, const std::string& label) {
    openni::VideoStream* streams[] = {&colour_stream_};
    int ready = -1;
    while (openni::OpenNI::waitForAnyStream(streams, 1, &ready, 0) == openni::STATUS_OK) {
      openni::VideoFrameRef ref;
      if (colour_stream_.readFrame(&ref) != openni::STATUS_OK || !ref.isValid()) break;
      const Intrinsics& in = colour_camera_.intrinsics;
      if (ref.getWidth() != in.width || ref.getHeight() != in.height || ref.getStrideInBytes() < in.width * 3) {
        fw::logWarn("openni2", label + ": a colour frame of another size; skipped");
        continue;
      }
      std::vector<std::uint8_t> rgb(static_cast<std::size_t>(in.width) * in.height * 3);
      const auto* rows = static_cast<const std::uint8_t*>(ref.getData());
      for (int v = 0; v < in.height; ++v) {
        std::memcpy(&rgb[static_cast<std::size_t>(v) * in.width * 3],
                    rows + static_cast<std::size_t>(v) * ref.getStrideInBytes(),
                    static_cast<std::size_t>(in.width) * 3);
      }
      colour_.add(colour_camera_.image(std::move(rgb), ref.getTimestamp() * 1e-6));
    }
    frame.colour = colour_.pairWith(frame.source_time_s, 1.5 / fps_);
  }

  void selectVgaMillimetres(const std::string& label) {
    const openni::SensorInfo& info = stream_.getSensorInfo();
    const auto& modes = info.getSupportedVideoModes();
    for (int i = 0; i < modes.getSize(); ++i) {
      const openni::VideoMode& mode = modes[i];
      if (mode.getResolutionX() == 640 && mode.getResolutionY() == 480 && mode.getFps() == 30 &&
          mode.getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_1_MM) {
        if (stream_.setVideoMode(mode) != openni::STATUS_OK) {
          throw DepthSourceError(label + ": cannot select 640x480 at 30 Hz: " + lastError());
        }
        return;
      }
    }
    fw::logWarn("openni2", label + ": no 640x480 30 Hz millimetre mode; using the device default");
  }

  openni::Device device_;
  openni::VideoStream stream_;
  Intrinsics intrinsics_;
  int fps_ = 30;
  openni::VideoStream colour_stream_;
  bool registered_ = false;  // depth registered to the colour camera by the device
  ColourCamera colour_camera_;
  ColourPairing colour_;
};

// A live OpenNI2 device; absence, loss and silence as every live device (live_device.h).
class OpenNI2Device : public LiveDevice {
 public:
  OpenNI2Device(std::string uri, const SourceOptions& options) : LiveDevice("openni2", options), uri_(std::move(uri)) {
    start();
  }
  ~OpenNI2Device() override { stream_.close(); }

  double frameRate_hz() const override { return stream_.fps(); }
  std::string describe() const override { return "openni2:" + uri_; }

 private:
  void openDevice() override { stream_.open(uri_, describe(), true, options().colour); }
  void closeDevice() override { stream_.close(); }
  bool deviceOpen() const override { return stream_.isOpen(); }
  bool readDevice(DepthFrame& frame, int wait_ms) override { return stream_.read(frame, wait_ms, describe()); }

  std::string uri_;
  OpenNI2Stream stream_;
};

class OniRecording : public DepthSource {
 public:
  OniRecording(std::string path, const SourceOptions& options) : DepthSource(options), path_(std::move(path)) {
    stream_.open(path_, describe());
    openni::PlaybackControl* playback = stream_.device().getPlaybackControl();
    if (playback == nullptr) throw DepthSourceError(describe() + ": not a recording");
    playback->setRepeatEnabled(false);
    // Manual speed: a frame is produced when it is read, so nothing is dropped however slowly the
    // pipeline runs. Real-time pacing, when asked for, is done by DepthSource::read.
    playback->setSpeed(-1.0f);
    frames_ = playback->getNumberOfFrames(stream_.stream());
    if (frames_ <= 0) throw DepthSourceError(describe() + ": the recording holds no depth frames");
  }
  ~OniRecording() override { stream_.close(); }

  std::uint64_t frameCount() const override { return static_cast<std::uint64_t>(frames_); }
  double frameRate_hz() const override { return stream_.fps(); }
  std::string describe() const override { return "oni:" + path_; }

 private:
  // OpenNI2's player retries a damaged record for ever without a word, and its readFrame() waits for
  // ever, so a frame is waited for in slices (the caller stays stoppable) and at most this long.
  static constexpr std::chrono::seconds kDamagedAfter{2};

  ReadResult readFrame(DepthFrame& frame) override {
    if (read_ >= frames_) return ReadResult::kEnd;
    const auto where = [this] { return "frame " + std::to_string(read_ + 1) + " of " + std::to_string(frames_); };
    bool arrived = false;
    try {
      arrived = stream_.read(frame, static_cast<int>(options().max_wait_s * 1000.0), describe());
    } catch (const DepthSourceError& e) {
      throw DepthSourceError(std::string(e.what()) + " (" + where() + "; the recording is damaged or truncated there)");
    }
    if (!arrived) {
      if (!waiting_since_) waiting_since_ = Clock::now();
      if (Clock::now() - *waiting_since_ > kDamagedAfter) {
        throw DepthSourceError(describe() + ": " + where() + " never came out of OpenNI2's player (" +
                               std::to_string(kDamagedAfter.count()) + " s): the recording is damaged there");
      }
      return ReadResult::kNoFrameYet;
    }
    waiting_since_.reset();
    ++read_;
    frame.sensor_id = describe();
    return ReadResult::kFrame;
  }

  std::string path_;
  OpenNI2Stream stream_;
  int frames_ = 0;
  int read_ = 0;
  std::optional<Clock::time_point> waiting_since_;  // since when the next frame is awaited
};

}  // namespace

std::unique_ptr<DepthSource> openOpenNI2Device(const std::string& device_uri, const SourceOptions& options) {
  initialiseOpenNI();
  return std::make_unique<OpenNI2Device>(device_uri, options);
}

void recordOni(const std::string& device_uri, const std::string& path, int frames, double timeout_s) {
  initialiseOpenNI();
  const std::string label = "openni2:" + device_uri;
  OpenNI2Stream stream;
  stream.open(device_uri, label, false);
  // The recorder runs before the stream starts, so it sees the first frame too.
  openni::Recorder recorder;
  if (recorder.create(path.c_str()) != openni::STATUS_OK || recorder.attach(stream.stream()) != openni::STATUS_OK ||
      recorder.start() != openni::STATUS_OK) {
    stream.close();
    throw DepthSourceError("cannot record to '" + path + "': " + lastError());
  }
  stream.start(label);
  // Every frame the stream delivers is recorded; reading them here counts them.
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  DepthFrame frame;
  int recorded = 0;
  while (recorded < frames && Clock::now() < deadline) {
    recorded += stream.read(frame, 100, label) ? 1 : 0;
  }
  recorder.stop();
  recorder.destroy();
  stream.close();
  if (recorded < frames) {
    throw DepthSourceError(label + ": only " + std::to_string(recorded) + " of " + std::to_string(frames) +
                           " frames arrived within " + std::to_string(timeout_s) + " s");
  }
}

std::unique_ptr<DepthSource> openOniRecording(const std::string& path, const SourceOptions& options) {
  if (!std::filesystem::is_regular_file(path)) {
    throw DepthSourceError("recording '" + path + "' does not exist");
  }
  initialiseOpenNI();
  return std::make_unique<OniRecording>(path, options);
}

}  // namespace kinect3d
