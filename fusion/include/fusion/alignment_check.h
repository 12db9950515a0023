// While the robot plays: do the Kinect's ground balls still lie where the omni camera sees them?
// The floor shows a Kinect that tilted or dropped (kinect3d's FloorCalibrationCheck); only another
// sensor shows one turned about the vertical or shifted on the robot. Each omni ball is paired with
// the Kinect's ground ball at the same moment (the stamps moved by each source's configured
// latency; the Kinect's ball from a line through its frames around that moment), and a window of
// pairs is fitted with the turn about the Kinect's position and the shift that carry the Kinect's
// balls onto the omni's, each pair weighted by its noise (the omni's bearing and distance, the
// Kinect's covariance). The omni's remaining time offset is fitted with them, since it moves every
// omni ball back along its motion: the fusion's learnt latency is not used, because it is learnt
// from the Kinect's balls and a turned Kinect would have taught it a wrong one. Everything here is
// in the robot frame: the robot's pose plays no part.
#pragma once

#include <deque>
#include <optional>
#include <vector>

#include "framework_api/time_line.h"
#include "framework_api/types.h"
#include "fusion/fusion_config.h"

namespace fusion {

// How the Kinect's balls must be moved to lie on the omni's: turned by yaw about the Kinect's
// position, then shifted by offset (robot frame). If the omni camera is as calibrated, the Kinect's
// pose_in_robot is off by these: its yaw by yaw_rad and its x, y by offset_m.
struct KinectMisalignment {
  double yaw_rad = 0.0;
  double yaw_sigma_rad = 0.0;
  Eigen::Vector2d offset_m = Eigen::Vector2d::Zero();
  Eigen::Matrix2d offset_covariance_m2 = Eigen::Matrix2d::Zero();
  double omni_time_offset_s = 0.0;  // how late the omni's stamps seem beyond its configured latency
  int pairs = 0;                    // used in the fit (those inside its gate)
  double mean_gap_m = 0.0;          // mean distance between the paired balls before the correction
};

class AlignmentCheck {
 public:
  // config: the fusion's (alignment_check, and the sensors' latencies and the omni's noise);
  // kinect_xy_R: where pose_in_robot puts the Kinect (the turn's centre).
  AlignmentCheck(const FusionConfig& config, const Eigen::Vector2d& kinect_xy_R);

  // A Kinect frame and an omni image, each stamped on its own clock. Either may arrive first.
  void addKinectFrame(double stamp_s, const std::vector<fw::BallObservation>& balls_R);
  void addOmniFrame(double stamp_s, const std::vector<fw::OmniBallObservation>& balls);

  // The misalignment when the latest fits confirm that the sensors disagree beyond the limits,
  // once per episode (until a fit is back within them); nothing otherwise.
  std::optional<KinectMisalignment> takeAlarm();
  // The latest fit, once the first window was full.
  const std::optional<KinectMisalignment>& latestFit() const { return latest_; }

 private:
  struct KinectFrame {
    double t_s;
    std::optional<fw::BallObservation> ball;  // only when the frame holds exactly one ball, on the floor
  };
  struct OmniImage {
    double t_s;
    std::vector<fw::OmniBallObservation> balls;
  };
  struct Pair {
    Eigen::Vector2d kinect_m, omni_m;
    Eigen::Vector2d velocity_mps;   // of the Kinect's ball in the robot frame
    Eigen::Matrix2d covariance_m2;  // of omni - kinect, timing aside
  };

  struct KinectLine {
    Eigen::Vector2d position_m, velocity_mps;
    Eigen::Matrix2d covariance_m2;
  };

  void pairWaitingImages();
  std::optional<KinectLine> kinectLineAt(double t_s) const;
  void pair(const OmniImage& image);
  KinectMisalignment fit() const;
  bool beyondLimits(const KinectMisalignment& fit) const;

  FusionConfig config_;
  Eigen::Vector2d kinect_xy_R_;
  std::deque<KinectFrame> kinect_;  // the last second
  fw::TimeLine kinect_time_line_;   // a jump in the Kinect's clock drops what is held
  std::deque<OmniImage> waiting_;   // omni images no later Kinect frame has bracketed yet
  std::deque<Pair> pairs_;          // the last window
  int new_pairs_ = 0;               // since the last fit
  int disagreements_ = 0;           // fits in a row beyond the limits
  bool alarmed_ = false;
  std::optional<KinectMisalignment> latest_, alarm_;
};

}  // namespace fusion
