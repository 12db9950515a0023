// sim:<scene>: the simulator as a depth source, frame by frame.
#include "../sources.h"
#include "kinect3d/sim/kinect_simulator.h"

namespace kinect3d {

namespace {

class Simulation : public DepthSource {
 public:
  Simulation(sim::Scene scene, const SourceOptions& options)
      : DepthSource(options), simulator_(std::move(scene)) {}

  std::uint64_t frameCount() const override { return simulator_.frameCount(); }
  double frameRate_hz() const override { return simulator_.scene().fps; }
  std::string describe() const override { return "sim:" + simulator_.scene().name; }

 private:
  ReadResult readFrame(DepthFrame& frame) override {
    if (next_ >= simulator_.frameCount()) return ReadResult::kEnd;
    sim::GroundTruth truth;
    simulator_.render(next_++, frame, truth);
    return ReadResult::kFrame;
  }

  sim::KinectSimulator simulator_;
  int next_ = 0;
};

}  // namespace

std::unique_ptr<DepthSource> openSimulation(const std::string& scene, const SourceOptions& options) {
  try {
    return std::make_unique<Simulation>(sim::loadScene(scene), options);
  } catch (const DepthSourceError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw DepthSourceError(std::string("sim:") + scene + ": " + e.what());
  }
}

}  // namespace kinect3d
