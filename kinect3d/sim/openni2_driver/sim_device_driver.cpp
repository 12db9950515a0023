// An OpenNI2 driver that serves the Kinect v1 simulator as a depth device, so the openni2: and
// .oni code paths (device enumeration, streams, Recorder, playback) run end to end without a
// Kinect. It is only ever opened by URI, "kinect3d-sim://<scene>[?frames=N&seed=S&drop=K]", never enumerated,
// so "openni2:" (the first device) can never pick it on a robot.
//
// The frames are those KinectSimulator renders for the scene, at the scene's frame rate; after
// `frames` frames (default: the scene's length) the stream goes quiet, as an unplugged camera. The
// device has a depth stream and a colour stream (RGB888, the Kinect v1's colour camera beside the
// depth camera, unregistered: it offers no image registration).
#include <Driver/OniDriverAPI.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>

#include "kinect3d/camera_file.h"
#include "kinect3d/sim/kinect_simulator.h"

// ONI_EXPORT_DRIVER uses OpenNI's internal allocation macros.
#define XN_NEW(type, arg) new type(arg)
#define XN_DELETE(pointer) delete pointer

namespace {

constexpr char kUriPrefix[] = "kinect3d-sim://";

struct StreamOptions {
  int frames = 0;               // stop after this many (0: the scene's length)
  int drop_every = 0;           // leave out every n-th frame, as a busy USB bus does (0: none)
  double appear_after_s = 0.0;  // cannot be opened until this long after the first attempt (slow USB at boot)
};

// "kinect3d-sim://hung_3m?frames=20&seed=3&drop=5&appear=3" -> the scene with that noise seed, 20
// frames, every 5th one dropped, openable 3 s after the first try (seed absent: the scene's own).
bool parseUri(const std::string& uri, kinect3d::sim::Scene& scene, StreamOptions& options) {
  if (uri.rfind(kUriPrefix, 0) != 0) return false;
  std::string name = uri.substr(sizeof kUriPrefix - 1);
  std::string query;
  if (const auto mark = name.find('?'); mark != std::string::npos) {
    query = name.substr(mark + 1);
    name.resize(mark);
  }
  if (name.empty()) return false;
  scene = kinect3d::sim::loadScene(name);
  options = StreamOptions{};
  std::istringstream parameters(query);
  for (std::string parameter; std::getline(parameters, parameter, '&');) {
    if (parameter.rfind("frames=", 0) == 0) options.frames = std::stoi(parameter.substr(7));
    if (parameter.rfind("drop=", 0) == 0) options.drop_every = std::stoi(parameter.substr(5));
    if (parameter.rfind("seed=", 0) == 0) scene.noise.seed = std::stoull(parameter.substr(5));
    if (parameter.rfind("appear=", 0) == 0) options.appear_after_s = std::stod(parameter.substr(7));
  }
  return true;
}

// The colour camera's intrinsics (ColourCamera::kinectV1()).
const kinect3d::Intrinsics& colourIntrinsics() {
  static const kinect3d::Intrinsics intrinsics = kinect3d::ColourCamera::kinectV1().intrinsics;
  return intrinsics;
}

OniVideoMode modeOf(OniSensorType type, const kinect3d::sim::Scene& scene) {
  const int fps = static_cast<int>(scene.fps + 0.5);
  if (type == ONI_SENSOR_COLOR)
    return {ONI_PIXEL_FORMAT_RGB888, colourIntrinsics().width, colourIntrinsics().height, fps};
  return {ONI_PIXEL_FORMAT_DEPTH_1_MM, scene.intrinsics.width, scene.intrinsics.height, fps};
}

// A device's frames on one clock, rendered once per frame index and handed to each of its
// streams, so that depth and colour come out in step as from one camera, however busy the machine
// and whenever each stream started.
class SharedFrames {
 public:
  using Clock = std::chrono::steady_clock;

  explicit SharedFrames(const kinect3d::sim::Scene& scene) : simulator_(scene) {}
  const kinect3d::sim::Scene& scene() const { return simulator_.scene(); }
  int frameCount() const { return simulator_.frameCount(); }
  // Called when the device's colour stream is created: from then on frames carry colour.
  void withColour() {
    const std::lock_guard<std::mutex> lock(mutex_);
    simulator_.setColour(true);
    colour_ = true;
  }
  // The device clock's start: the first stream's start.
  Clock::time_point start() {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (!start_) start_ = Clock::now();
    return *start_;
  }
  void get(int index, kinect3d::DepthFrame& frame) {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (index != index_ || (colour_ && !frame_.colour)) {
      simulator_.render(index, frame_, truth_);
      index_ = index;
    }
    frame = frame_;
  }

 private:
  std::mutex mutex_;
  kinect3d::sim::KinectSimulator simulator_;
  bool colour_ = false;
  std::optional<Clock::time_point> start_;
  int index_ = -1;
  kinect3d::DepthFrame frame_;
  kinect3d::sim::GroundTruth truth_;
};

class SimStream : public oni::driver::StreamBase {
 public:
  SimStream(OniSensorType type, std::shared_ptr<SharedFrames> frames, const StreamOptions& options)
      : type_(type),
        shared_(std::move(frames)),
        frames_(options.frames > 0 ? std::min(options.frames, shared_->frameCount()) : shared_->frameCount()),
        drop_every_(options.drop_every),
        mode_(modeOf(type, shared_->scene())) {
    if (type == ONI_SENSOR_COLOR) shared_->withColour();
  }
  ~SimStream() override { stop(); }

  OniStatus start() override {
    running_ = true;
    thread_ = std::thread([this] { produce(); });
    return ONI_STATUS_OK;
  }
  void stop() override {
    running_ = false;
    if (thread_.joinable()) thread_.join();
  }

  OniBool isPropertySupported(int id) override {
    return id == ONI_STREAM_PROPERTY_VIDEO_MODE || id == ONI_STREAM_PROPERTY_STRIDE ||
           id == ONI_STREAM_PROPERTY_CROPPING || id == ONI_STREAM_PROPERTY_HORIZONTAL_FOV ||
           id == ONI_STREAM_PROPERTY_VERTICAL_FOV || id == ONI_STREAM_PROPERTY_MAX_VALUE ||
           id == ONI_STREAM_PROPERTY_MIN_VALUE || id == ONI_STREAM_PROPERTY_MIRRORING;
  }

  OniStatus getProperty(int id, void* data, int* size) override {
    const kinect3d::Intrinsics& in = type_ == ONI_SENSOR_COLOR ? colourIntrinsics() : shared_->scene().intrinsics;
    switch (id) {
      case ONI_STREAM_PROPERTY_VIDEO_MODE:
        return copyOut(mode_, data, size);
      // OpenNI2's file player drops every frame of a recording that lacks stride or cropping.
      case ONI_STREAM_PROPERTY_STRIDE:
        return copyOut(in.width * bytesPerPixel(), data, size);
      case ONI_STREAM_PROPERTY_CROPPING:
        return copyOut(OniCropping{FALSE, 0, 0, in.width, in.height}, data, size);
      case ONI_STREAM_PROPERTY_HORIZONTAL_FOV:
        return copyOut(static_cast<float>(2.0 * std::atan(in.width / (2.0 * in.fx))), data, size);
      case ONI_STREAM_PROPERTY_VERTICAL_FOV:
        return copyOut(static_cast<float>(2.0 * std::atan(in.height / (2.0 * in.fy))), data, size);
      case ONI_STREAM_PROPERTY_MAX_VALUE:
        return copyOut(type_ == ONI_SENSOR_COLOR ? 255 : static_cast<int>(shared_->scene().noise.max_range_m * 1000),
                       data, size);
      case ONI_STREAM_PROPERTY_MIN_VALUE:
        return copyOut(0, data, size);
      case ONI_STREAM_PROPERTY_MIRRORING:
        return copyOut(static_cast<OniBool>(FALSE), data, size);
      default:
        return ONI_STATUS_NOT_SUPPORTED;
    }
  }

  OniStatus setProperty(int id, const void* data, int size) override {
    if (id == ONI_STREAM_PROPERTY_VIDEO_MODE && size == sizeof(OniVideoMode)) {
      // The simulator renders one mode; accept it and refuse any other.
      return std::memcmp(data, &mode_, sizeof mode_) == 0 ? ONI_STATUS_OK : ONI_STATUS_NOT_SUPPORTED;
    }
    if (id == ONI_STREAM_PROPERTY_MIRRORING && size == sizeof(OniBool)) {
      return *static_cast<const OniBool*>(data) ? ONI_STATUS_NOT_SUPPORTED : ONI_STATUS_OK;
    }
    return ONI_STATUS_NOT_SUPPORTED;
  }

 private:
  int bytesPerPixel() const { return type_ == ONI_SENSOR_COLOR ? 3 : 2; }

  template <typename T>
  static OniStatus copyOut(const T& value, void* data, int* size) {
    if (*size < static_cast<int>(sizeof(T))) return ONI_STATUS_BAD_PARAMETER;
    std::memcpy(data, &value, sizeof(T));
    *size = sizeof(T);
    return ONI_STATUS_OK;
  }

  // Renders frames at the scene's rate on the stream's own thread, as a camera delivers them.
  void produce() {
    const auto period = std::chrono::duration<double>(1.0 / shared_->scene().fps);
    // A stream started after another joins the device clock at the frame now due.
    const SharedFrames::Clock::time_point clock_start = shared_->start();
    const auto due = [&](int index) {
      return clock_start + std::chrono::duration_cast<SharedFrames::Clock::duration>(index * period);
    };
    int first = 0;
    while (due(first + 1) <= SharedFrames::Clock::now()) ++first;
    kinect3d::DepthFrame depth;
    for (int i = first; running_ && i < frames_; ++i) {
      const auto next = due(i + 1);
      if (drop_every_ > 0 && (i + 1) % drop_every_ == 0) {
        std::this_thread::sleep_until(next);  // the frame is lost on the way; its index is used up
        continue;
      }
      shared_->get(i, depth);
      OniFrame* frame = getServices().acquireFrame();
      if (frame == nullptr) break;
      const void* pixels = type_ == ONI_SENSOR_COLOR ? static_cast<const void*>(depth.colour->rgb.data())
                                                     : static_cast<const void*>(depth.depth_mm.data());
      const int bytes = mode_.resolutionX * mode_.resolutionY * bytesPerPixel();
      if (frame->dataSize < bytes) {
        getServices().releaseFrame(frame);
        break;
      }
      std::memcpy(frame->data, pixels, bytes);
      frame->dataSize = bytes;
      frame->sensorType = type_;
      frame->frameIndex = i + 1;  // OpenNI devices count from 1
      // A device clock in microseconds since the stream started, as real devices stamp frames
      // (OpenNI2's file player paces playback from zero, so epoch times would stall it).
      frame->timestamp = static_cast<uint64_t>((i + 1) * 1e6 / shared_->scene().fps);
      frame->width = mode_.resolutionX;
      frame->height = mode_.resolutionY;
      frame->videoMode = mode_;
      frame->croppingEnabled = FALSE;
      frame->cropOriginX = frame->cropOriginY = 0;
      frame->stride = mode_.resolutionX * bytesPerPixel();
      raiseNewFrame(frame);
      getServices().releaseFrame(frame);
      std::this_thread::sleep_until(next);
    }
  }

  const OniSensorType type_;
  std::shared_ptr<SharedFrames> shared_;
  const int frames_;
  const int drop_every_;
  const OniVideoMode mode_;
  std::atomic<bool> running_{false};
  std::thread thread_;
};

class SimDevice : public oni::driver::DeviceBase {
 public:
  SimDevice(kinect3d::sim::Scene scene, const StreamOptions& options)
      : scene_(std::move(scene)),
        options_(options),
        frames_(std::make_shared<SharedFrames>(scene_)),
        modes_{modeOf(ONI_SENSOR_DEPTH, scene_), modeOf(ONI_SENSOR_COLOR, scene_)} {
    sensors_[0] = {ONI_SENSOR_DEPTH, 1, &modes_[0]};
    sensors_[1] = {ONI_SENSOR_COLOR, 1, &modes_[1]};
  }

  OniStatus getSensorInfoList(OniSensorInfo** sensors, int* count) override {
    *sensors = sensors_;
    *count = 2;
    return ONI_STATUS_OK;
  }
  oni::driver::StreamBase* createStream(OniSensorType type) override {
    return type == ONI_SENSOR_DEPTH || type == ONI_SENSOR_COLOR ? new SimStream(type, frames_, options_) : nullptr;
  }
  void destroyStream(oni::driver::StreamBase* stream) override { delete stream; }

 private:
  kinect3d::sim::Scene scene_;
  StreamOptions options_;
  std::shared_ptr<SharedFrames> frames_;
  OniVideoMode modes_[2];
  OniSensorInfo sensors_[2];
};

class SimDriver : public oni::driver::DriverBase {
 public:
  explicit SimDriver(OniDriverServices* services) : DriverBase(services) {}

  // Called by OpenNI2 for a URI no enumerated device has: announce it if it is ours.
  OniStatus tryDevice(const char* uri) override {
    if (std::string(uri).rfind(kUriPrefix, 0) != 0) return ONI_STATUS_ERROR;
    OniDeviceInfo info{};
    std::snprintf(info.uri, sizeof info.uri, "%s", uri);
    std::snprintf(info.vendor, sizeof info.vendor, "Kinect3D");
    std::snprintf(info.name, sizeof info.name, "Kinect v1 simulator");
    deviceConnected(&info);
    return ONI_STATUS_OK;
  }

  oni::driver::DeviceBase* deviceOpen(const char* uri, const char* /*mode*/) override {
    try {
      kinect3d::sim::Scene scene;
      StreamOptions options;
      if (!parseUri(uri, scene, options)) return nullptr;
      // A device that appears late: absent until appear_after_s after the first attempt to open it.
      const auto first = first_attempt_.try_emplace(uri, std::chrono::steady_clock::now()).first->second;
      if (std::chrono::steady_clock::now() - first < std::chrono::duration<double>(options.appear_after_s)) {
        getServices().errorLoggerAppend("%s: not there yet", uri);
        return nullptr;
      }
      return new SimDevice(std::move(scene), options);
    } catch (const std::exception& e) {
      getServices().errorLoggerAppend("%s: %s", uri, e.what());
      return nullptr;
    }
  }
  void deviceClose(oni::driver::DeviceBase* device) override { delete device; }
  void shutdown() override {}

 private:
  std::map<std::string, std::chrono::steady_clock::time_point> first_attempt_;
};

}  // namespace

ONI_EXPORT_DRIVER(SimDriver)
