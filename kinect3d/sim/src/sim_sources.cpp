#include "kinect3d/sim/sim_sources.h"

#include "framework_api/types.h"
#include "kinect3d/sim/kinect_simulator.h"

namespace kinect3d::sim {

namespace {

// sim:<scene>: frame by frame, as the simulator renders them.
class Simulation : public DepthSource {
 public:
  Simulation(Scene scene, const SourceOptions& options)
      : DepthSource(options), simulator_(inSharedWorld(std::move(scene), options.sim_world_start_wall_s)) {
    simulator_.setColour(options.colour);
    if (options.sim_world_start_wall_s > 0.0) pinPacing(0.0);  // its frames are stamped on the wall clock
  }

  std::uint64_t frameCount() const override { return simulator_.frameCount(); }
  double frameRate_hz() const override { return simulator_.scene().fps; }
  std::string describe() const override { return "sim:" + simulator_.scene().name; }

 private:
  ReadResult readFrame(DepthFrame& frame) override {
    if (options().realtime) skipOverwrittenFrames();
    if (next_ >= simulator_.frameCount()) return ReadResult::kEnd;
    GroundTruth truth;
    simulator_.render(next_++, frame, truth);
    return ReadResult::kFrame;
  }

  // In real time the simulator is a live sensor, and a live sensor's driver keeps only its newest
  // few frames: one kBacklogFrames older than a frame already due was overwritten before the host
  // read it. So a host too busy to keep up (or a renderer slower than the scene's frame rate) loses
  // frames, counted as dropped from the gap in the indices, instead of delivering them ever further
  // behind the other sensors' (the fusion drops what comes more than max_delay_s late); the frames
  // it loses are not rendered either. A hiccup of a frame or two (the first frame's floor search)
  // is caught up on, every frame still within the fusion's 0.15 s.
  static constexpr int kBacklogFrames = 3;
  void skipOverwrittenFrames() {
    const Scene& scene = simulator_.scene();
    const double now_s = fw::wallClockNow_s();
    while (next_ + kBacklogFrames < simulator_.frameCount()) {
      const std::optional<double> newer_due_s = dueWall_s(scene.start_time_s + (next_ + kBacklogFrames) / scene.fps);
      if (!newer_due_s || *newer_due_s > now_s) break;
      ++next_;
    }
  }

  KinectSimulator simulator_;
  int next_ = 0;
};

std::unique_ptr<DepthSource> openSimulation(const std::string& scene, const SourceOptions& options) {
  try {
    return std::make_unique<Simulation>(loadScene(scene), options);
  } catch (const std::runtime_error& e) {
    throw DepthSourceError("sim:" + scene + ": " + e.what());
  }
}

}  // namespace

void addSimulatorSource(DepthSourceTable& table) { table.add("sim", openSimulation); }

DepthSourceTable sourcesWithSimulator() {
  DepthSourceTable table = DepthSourceTable::core();
  addSimulatorSource(table);
  return table;
}

std::string simulatedDeviceUri(const std::string& scene, int frames, long seed) {
  return "kinect3d-sim://" + scene + "?frames=" + std::to_string(frames) +
         (seed >= 0 ? "&seed=" + std::to_string(seed) : "");
}

}  // namespace kinect3d::sim
