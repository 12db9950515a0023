// The ball's bounce learnt from the bounces this robot's Kinect sees whole, so that the hops no
// sensor sees (behind the robot, after a lob over it) follow this ball on this floor rather than the
// configured guess (docs/fusion.md, "The learnt bounce").
//
// The Kinect's balls of the world's ball, in the field frame, are kept for the last fraction of a
// second. Once kSideSamples of them have risen from the lowest, the fall before it and the rise after
// it are each fitted by least squares as a flight under gravity (height) and a straight line (along
// the floor) over kSide_s, each within its own hop. A bounce is two such fits meeting the floor at the same moment: the
// restitution is the vertical speed kept there, and, for a ball moving along the floor, the bounce
// friction the share of horizontal speed lost. A ball deflected by a robot, caught or rolling does
// not meet the floor that way and teaches nothing.
//
// The learnt means start from the configured restitution and bounce friction, worth kPriorBounces
// bounces; their spreads from the configured ones, towards the spread the bounces show (never below
// a bounce's own fitting error).
#pragma once

#include <array>
#include <cstddef>

#include <Eigen/Core>

#include "fusion/fusion_config.h"

namespace fusion {

class BounceLearner {
 public:
  static constexpr int kSideSamples = 5;             // balls after the lowest when the bounce is judged ...
  static constexpr std::size_t kMinSideSamples = 4;  // ... and those of each side's own hop the fits need
  static constexpr double kSide_s = 0.2;             // each fit spans at most this (drag and spin stay small)
  static constexpr double kPriorBounces = 2;         // the configured bounce weighs as this many learnt ones

  explicit BounceLearner(const MotionConfig& configured);

  // This robot's Kinect ball of the track track_id at t_s (field frame), in time order; another
  // track starts afresh. True when it completed a bounce that was learnt.
  bool add(int track_id, double t_s, const Eigen::Vector3d& p_F);

  // The configured motion with the bounce learnt so far.
  const MotionConfig& motion() const { return motion_; }
  int bounces() const { return restitutions_.count; }

 private:
  struct Sample {
    double t_s;
    Eigen::Vector3d p_F;
  };
  // Sums of what the bounces showed, to a mean and a spread.
  struct Tally {
    int count = 0;
    double sum = 0.0, sum_of_squares = 0.0;
    void add(double value);
  };
  // The configured mean and spread with what the tally adds.
  static void learnt(const Tally& tally, double configured, double configured_sigma, double& mean, double& sigma);
  // The bounce at the lowest kept ball, if the balls before and after it show one.
  bool learnBounceAt(std::size_t lowest);

  MotionConfig configured_, motion_;
  int track_id_ = 0;
  // The newest balls, oldest first: a bounce's two sides at 30 Hz with room to spare.
  static constexpr std::size_t kKept = 24;
  std::array<Sample, kKept> samples_ = {};
  std::size_t count_ = 0;
  Tally restitutions_, frictions_;
};

}  // namespace fusion
