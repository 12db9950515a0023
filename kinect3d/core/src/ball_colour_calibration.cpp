#include "kinect3d/ball_colour_calibration.h"

namespace kinect3d {

BallColourFit calibrateBallColour(DepthSource& source, DetectorConfig config, double live_seconds) {
  config.colour.mode = ColourCheckConfig::Mode::kOff;  // nothing to check against yet
  BallDetector detector(config, "calibrate");
  BallColourLearner learner;
  Detections detections;
  DepthFrame frame;
  const bool live = source.frameCount() == 0;
  std::optional<double> first_s;
  for (ReadResult result; (result = source.read(frame)) != ReadResult::kEnd;) {
    if (result != ReadResult::kFrame) continue;
    if (!first_s) first_s = frame.source_time_s;
    if (live && frame.source_time_s - *first_s > live_seconds) break;
    detector.detect(frame, detections);
    if (detections.balls.size() != 1 || !frame.colour || !detector.T_R_S()) continue;
    learner.add(*frame.colour, detector.T_R_S()->inverse() * detections.balls.front().position_m, config.ball.radius_m);
  }
  return learner.fit();
}

}  // namespace kinect3d
