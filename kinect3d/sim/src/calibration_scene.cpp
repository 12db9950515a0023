#include "kinect3d/sim/calibration_scene.h"

#include <filesystem>
#include <fstream>

#include "kinect3d/sim/kinect_simulator.h"
#include "kinect3d/sim/scene.h"
#include "kinect3d/sim/sequence_writer.h"

namespace kinect3d::sim {

void writeCalibrationSession(const CalibrationSession& session, const std::string& dir) {
  TumSequenceWriter writer(dir);
  std::ofstream marks(std::filesystem::path(dir) / "marks.yaml");
  marks << "# A simulated calibration session: the ball on each mark in turn (robot frame, metres; seconds\n"
           "# from the recording's first frame).\nmarks:\n";
  std::uint64_t index = 0;
  double start_s = 0.0;
  for (const Eigen::Vector2d& mark : session.marks_xy_m) {
    Scene scene;
    scene.name = "calibration";
    scene.duration_s = session.seconds_per_mark;
    scene.sensor_pose = session.pose;
    scene.noise.seed = session.noise_seed + index;
    if (session.colour) scene.look = *session.colour;
    BallLaunch ball;
    ball.position_m = {mark.x(), mark.y(), scene.physics.radius_m};
    ball.hanging = true;  // resting: never moves
    scene.ball = ball;
    KinectSimulator simulator(scene);
    simulator.setColour(session.colour.has_value());
    DepthFrame frame;
    GroundTruth truth;
    for (int i = 0; i < simulator.frameCount(); ++i, ++index) {
      simulator.render(i, frame, truth);
      frame.source_time_s = scene.start_time_s + index / scene.fps;
      frame.index = index;
      if (frame.colour) frame.colour->source_time_s = frame.source_time_s;
      writer.write(frame);
    }
    marks << "  - {x: " << mark.x() << ", y: " << mark.y() << ", from_s: " << start_s + 0.1
          << ", to_s: " << start_s + session.seconds_per_mark - 0.1 << "}\n";
    start_s += session.seconds_per_mark;
  }
  if (!marks.flush()) throw std::runtime_error("cannot write '" + dir + "/marks.yaml'");
}

}  // namespace kinect3d::sim
