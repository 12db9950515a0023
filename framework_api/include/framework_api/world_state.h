// The robot's shared world state: plugins publish to it and read from it from their own threads.
// Every accessor copies under a lock, so a reader never sees a half-written value.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "framework_api/types.h"

namespace fw {

class WorldState {
 public:
  // How many recent observations are kept per source (a second at 30 Hz).
  static constexpr std::size_t kHistoryPerSource = 30;

  void publishBall(const BallObservation& observation);
  // Every ball of one frame at once, so a reader never sees half a frame.
  void publishBalls(const std::vector<BallObservation>& observations);
  void publishOmniFrame(const OmniFrame& frame);
  void publishFusedBall(const FusedBall& ball);
  void clearFusedBall();                                     // the world has no ball
  void publishTrajectory(const BallTrajectory& trajectory);  // replaces that source's last one
  void clearTrajectory(const std::string& source);           // the source lost the ball
  void publishRobotPose(const RobotPose& pose);

  // Newest first.
  std::vector<BallObservation> recentBalls(const std::string& source) const;
  std::vector<OmniBallObservation> recentOmniBalls(const std::string& source) const;
  std::vector<std::string> ballSources() const;
  std::optional<BallTrajectory> trajectory(const std::string& source) const;
  std::optional<FusedBall> fusedBall() const;
  std::optional<RobotPose> robotPose() const;       // the newest
  std::vector<RobotPose> recentRobotPoses() const;  // newest first, kHistoryPerSource of them

  // Increases with every publish; a reader that saw version v has nothing new while it is still v.
  std::uint64_t version() const;

 private:
  template <typename T>
  static void pushCapped(std::deque<T>& history, const T& value);

  mutable std::mutex mutex_;
  std::map<std::string, std::deque<BallObservation>> balls_;
  std::map<std::string, std::deque<OmniBallObservation>> omni_balls_;
  std::map<std::string, BallTrajectory> trajectories_;
  std::optional<FusedBall> fused_ball_;
  std::deque<RobotPose> robot_poses_;
  std::uint64_t version_ = 0;
};

}  // namespace fw
