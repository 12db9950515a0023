// Runs the detector on simulated scenes and scores it against the ground truth: the measurements
// behind docs/accuracy.md and the scenario tests.
#pragma once

#include <string>
#include <vector>

#include "framework_api/types.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/colour_check.h"
#include "kinect3d/sim/calibration_scene.h"
#include "kinect3d/sim/kinect_simulator.h"

namespace kinect3d::sim {

struct EvaluatedFrame {
  GroundTruth truth;
  std::vector<fw::BallObservation> balls;
  double process_s = 0.0;
  double colour_s = 0.0;  // of which the colour check
};

// Renders every frame of the scene (with colour when the config's colour check is on) and runs one
// detector, configured by `config`, over them.
std::vector<EvaluatedFrame> runDetectorOnScene(const Scene& scene, const DetectorConfig& config);
// The same frames with only the balls trajectories and fusion follow (not those colour rejected).
std::vector<EvaluatedFrame> followedOnly(std::vector<EvaluatedFrame> frames);

// The match ball's colours learnt as `kinect3d calibrate ball-colour` learns them, from a simulated
// calibration session (with colour) recorded and read back, the detector given the session's pose.
BallColourFit learnBallColourInSession(const CalibrationSession& session, const DetectorConfig& config);

// Which frames count: the ball should be found when it is in this range of the sensor, its centre
// this far inside the image border, shows at least this share of a whole ball's pixels, and is this
// far from every other structure. The detector reports a ball cut by the border only while its
// centre is in the view (more than half of it: a hand cut by the border fits a ball's outline as
// well as a ball's half does); the margin covers the centre's fit.
struct EvaluationCriteria {
  double min_range_m = 0.8;
  double max_range_m = 7.0;
  double min_centre_inside_r = 0.33;  // radii, in the image
  double min_visible_fraction = 0.3;
  double min_clearance_m = 0.6;
  double match_m = 0.3;  // a reported ball this close to the true one is the ball
};

struct DetectionScore {
  int frames = 0;
  int eligible = 0;                        // frames where the ball should be found
  int found = 0;                           // eligible frames with a reported ball within match_m
  int reported = 0;                        // balls reported, in any frame
  int off_truth = 0;                       // reported balls farther than match_m from the true ball (or with none)
  std::vector<double> errors_m;            // 3D error of the nearest reported ball, eligible found frames
  std::vector<double> off_truth_ranges_m;  // each ball off the truth: its distance from the sensor

  double recall() const { return eligible ? double(found) / eligible : 1.0; }
  void add(const DetectionScore& other);
};

bool shouldBeFound(const GroundTruth& truth, const Scene& scene, const EvaluationCriteria& criteria);
DetectionScore scoreFrames(const std::vector<EvaluatedFrame>& frames, const Scene& scene,
                           const EvaluationCriteria& criteria);

// One detector over real depth images (16-bit, units_per_m to the metre: 1000 for millimetres,
// 5000 for TUM RGB-D; PNG or TIFF, 640 x 480, fx = fy = 525 at cx, cy), each played twice in order
// as a TUM sequence through the product's tum: source.
struct RealFramesResult {
  int frames = 0;
  int balls = 0;         // reported over all frames
  bool aligned = false;  // the floor was found (or the pose given) by the last frame
};
RealFramesResult detectOnDepthImages(const std::vector<std::string>& images, double cx, double cy,
                                     const DetectorConfig& config, int units_per_m = 1000);

// The colour check everywhere in a real frame with registered colour (fx = fy = 525 at cx, cy; depth
// in millimetres): a ball-sized sphere behind the surface at every 16th pixel with depth, checked
// against the model.
struct RealColourCheck {
  int places = 0, confirmed = 0, no_evidence = 0, rejected = 0;
};
RealColourCheck checkEverywhere(const std::string& depth_image, const std::string& colour_image, double cx, double cy,
                                const BallColourModel& model, double radius_m = 0.11);

}  // namespace kinect3d::sim
