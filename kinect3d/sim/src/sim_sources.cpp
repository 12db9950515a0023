#include "kinect3d/sim/sim_sources.h"

#include "framework_api/types.h"
#include "kinect3d/sim/kinect_simulator.h"

namespace kinect3d::sim {

namespace {

// sim:<scene>: frame by frame, as the simulator renders them.
class Simulation : public DepthSource {
 public:
  Simulation(Scene scene, const SourceOptions& options)
      : DepthSource(options),
        simulator_(inSharedWorld(std::move(scene), options.sim_world_start_wall_s)),
        live_(options.realtime && options.sim_world_start_wall_s > 0.0) {
    simulator_.setColour(options.colour);
    if (options.sim_world_start_wall_s > 0.0) pinPacing(0.0);  // its frames are stamped on the wall clock
  }

  std::uint64_t frameCount() const override { return simulator_.frameCount(); }
  double frameRate_hz() const override { return simulator_.scene().fps; }
  std::string describe() const override { return "sim:" + simulator_.scene().name; }

 private:
  ReadResult readFrame(DepthFrame& frame) override {
    if (live_) skipOverwrittenFrames();
    if (next_ >= simulator_.frameCount()) return ReadResult::kEnd;
    GroundTruth truth;
    simulator_.render(next_++, frame, truth);
    return ReadResult::kFrame;
  }

  // A live sensor's driver keeps only its newest frame: one whose successor has already been taken
  // was overwritten before the host read it. So a host too busy to keep up loses frames (counted as
  // dropped, from the gap in the indices) instead of falling ever further behind its world, and the
  // frames it loses are not rendered either.
  void skipOverwrittenFrames() {
    const Scene& scene = simulator_.scene();
    const double now_s = fw::wallClockNow_s();
    while (next_ + 1 < simulator_.frameCount() && scene.start_time_s + (next_ + 1) / scene.fps <= now_s) ++next_;
  }

  KinectSimulator simulator_;
  const bool live_;  // in real time in a world shared with other hosts, on the wall clock
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
