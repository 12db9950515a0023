// A second opinion from colour (docs/colour.md): the match ball's main colours, learnt from a
// recording of it (`kinect3d calibrate ball-colour`), and the check of each ball the depth found
// against the colour image: the ball's sphere projected into the colour camera, the colours inside
// its disc against the learnt ones, and the disc's outline (edges across the circle the depth
// predicts).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "framework_api/types.h"
#include "kinect3d/depth_frame.h"

namespace kinect3d {

// One of the ball's main colours under the hall's light, in CIE L*a*b* (L 0-100).
struct BallColour {
  Eigen::Vector3d lab = Eigen::Vector3d::Zero();
  Eigen::Vector3d sigma = Eigen::Vector3d::Ones();  // its spread over the ball, per axis
  double share = 1.0;                               // of the ball's pixels
};
using BallColourModel = std::vector<BallColour>;

// Where a ball of radius_m centred at centre_S (the depth camera's optical frame) shows in a colour
// image: its disc. None when the centre is not in front of the camera.
struct BallDisc {
  Eigen::Vector2d centre_px = Eigen::Vector2d::Zero();
  double radius_px = 0.0;
};
std::optional<BallDisc> discOf(const fw::ColourImage& image, const Eigen::Vector3d& centre_S, double radius_m);

struct ColourCheckConfig {
  enum class Mode { kOff, kOn, kRequired };
  Mode mode = Mode::kOff;
  BallColourModel ball_colours;
  double confirm_score = 0.5;    // confirmed from this colour score up, with the outline ...
  double min_outline = 0.5;      // ... seen on this share of the circle
  double reject_score = 0.2;     // rejected below this colour score
  double min_radius_px = 3.0;    // a smaller disc is too far to judge
  double dark_lightness = 12.0;  // L*: a disc darker than this is too dark to judge
  double max_blur_px = 4.0;      // an outline smeared wider than this: blurred
};

// What the check found for one ball.
struct ColourEvidence {
  fw::ColourVerdict verdict = fw::ColourVerdict::kNotChecked;
  fw::ColourNote note = fw::ColourNote::kNone;
  // The share of the disc (of what shows of it) the ball's colours explain, 0 when a main colour is missing.
  double score = 0.0;
  double outline = 0.0;  // share of the circle with an edge across it
};

class ColourCheck {
 public:
  explicit ColourCheck(ColourCheckConfig config);
  const ColourCheckConfig& config() const { return config_; }

  // The verdict on a ball at centre_S (depth camera's optical frame) of radius_m, from the frame's
  // colour image (none: no evidence), judged on what of the ball its depth shows is not hidden
  // behind something nearer. With mode kRequired, anything not confirmed is rejected (the note
  // still says why).
  ColourEvidence check(const DepthFrame& frame, const Eigen::Vector3d& centre_S, double radius_m) const;

 private:
  ColourCheckConfig config_;
};

// How well a model tells the ball from everything else in the recording it was learnt from.
struct BallColourFit {
  BallColourModel model;
  int frames = 0;  // colour frames the ball was taken from
  int ball_pixels = 0, other_pixels = 0;
  double ball_explained = 0.0;             // share of the ball's pixels the model explains
  double other_explained = 0.0;            // share of everything else's pixels it explains
  std::vector<double> other_explained_by;  // per colour
  double ball_score_p10 = 0.0;             // the colour score of the ball's own discs: 10th percentile
  double other_score_p99 = 0.0;            // and of ball-sized discs placed elsewhere: 99th percentile
};

// Collects the ball's pixels (inside its disc) and everything else's (away from it) from colour
// images of a recording where the depth found the one ball, and learns its main colours.
class BallColourLearner {
 public:
  void add(const fw::ColourImage& image, const Eigen::Vector3d& centre_S, double radius_m);
  int frames() const { return frames_; }
  // Throws std::runtime_error when the recording showed too little of the ball.
  BallColourFit fit() const;

 private:
  std::vector<Eigen::Vector3f> ball_lab_, other_lab_;
  // Ball-sized discs of the recording (the ball's own and elsewhere), as Lab samples, for the scores.
  std::vector<std::vector<Eigen::Vector3f>> ball_discs_, other_discs_;
  int frames_ = 0;
};

// A disc's Lab samples against a model: the share any of its colours explains, and the colour score
// (that share, cut down when one of the ball's main colours does not show: a white shirt is not a
// white ball with black panels), with the ball in `light` (the cube root of the hall's light over the
// session's). Without a light, at the level that explains the disc best, from a quarter to twice the
// session's. With panels_blend (a far ball, its panels a few pixels wide), a sample that is two of
// the main colours blended shows each in its part. Which colour explains a sample (-1 for none).
// Shared by the check and the learner's report.
struct ColourMatch {
  double explained = 0.0;
  double score = 0.0;
  double light = 1.0;
};
ColourMatch colourMatch(const BallColourModel& model, const std::vector<Eigen::Vector3f>& lab, double light,
                        bool panels_blend = false);
ColourMatch colourMatch(const BallColourModel& model, const std::vector<Eigen::Vector3f>& lab,
                        bool panels_blend = false);
int explainingColour(const BallColourModel& model, const Eigen::Vector3f& lab, double light);

// The model as the robot file writes it: a flow list of {lab: [L, a, b], sigma: [...], share: s}.
std::string ballColoursYaml(const BallColourModel& model);

}  // namespace kinect3d
