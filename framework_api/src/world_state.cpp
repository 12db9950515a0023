#include "framework_api/world_state.h"

namespace fw {

template <typename T>
void WorldState::pushCapped(std::deque<T>& history, const T& value) {
  history.push_front(value);
  if (history.size() > kHistoryPerSource) history.pop_back();
}

void WorldState::publishBall(const BallObservation& observation) {
  std::lock_guard<std::mutex> lock(mutex_);
  pushCapped(balls_[observation.source], observation);
  ++version_;
}

void WorldState::publishBalls(const std::vector<BallObservation>& observations) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const BallObservation& observation : observations) pushCapped(balls_[observation.source], observation);
  ++version_;
}

void WorldState::publishOmniFrame(const OmniFrame& frame) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const OmniBallObservation& ball : frame.balls) pushCapped(omni_balls_[ball.source], ball);
  ++version_;
}

void WorldState::clearFusedBall() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (fused_ball_) {
    fused_ball_.reset();
    ++version_;
  }
}

void WorldState::publishTrajectory(const BallTrajectory& trajectory) {
  std::lock_guard<std::mutex> lock(mutex_);
  trajectories_[trajectory.source] = trajectory;
  ++version_;
}

void WorldState::clearTrajectory(const std::string& source) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (trajectories_.erase(source) > 0) ++version_;
}

std::optional<BallTrajectory> WorldState::trajectory(const std::string& source) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = trajectories_.find(source);
  if (found == trajectories_.end()) return std::nullopt;
  return found->second;
}

void WorldState::publishFusedBall(const FusedBall& ball) {
  std::lock_guard<std::mutex> lock(mutex_);
  fused_ball_ = ball;
  ++version_;
}

void WorldState::publishRobotPose(const RobotPose& pose) {
  std::lock_guard<std::mutex> lock(mutex_);
  pushCapped(robot_poses_, pose);
  ++version_;
}

std::vector<BallObservation> WorldState::recentBalls(const std::string& source) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = balls_.find(source);
  if (found == balls_.end()) return {};
  return {found->second.begin(), found->second.end()};
}

std::vector<OmniBallObservation> WorldState::recentOmniBalls(const std::string& source) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = omni_balls_.find(source);
  if (found == omni_balls_.end()) return {};
  return {found->second.begin(), found->second.end()};
}

std::vector<std::string> WorldState::ballSources() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> sources;
  for (const auto& entry : balls_) sources.push_back(entry.first);
  return sources;
}

std::optional<FusedBall> WorldState::fusedBall() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return fused_ball_;
}

std::optional<RobotPose> WorldState::robotPose() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (robot_poses_.empty()) return std::nullopt;
  return robot_poses_.front();
}

std::vector<RobotPose> WorldState::recentRobotPoses() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return {robot_poses_.begin(), robot_poses_.end()};
}

std::uint64_t WorldState::version() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return version_;
}

}  // namespace fw
