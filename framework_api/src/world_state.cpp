#include "framework_api/world_state.h"

namespace fw {

template <typename T>
void WorldState::pushCapped(std::deque<T>& history, const T& value) {
  history.push_front(value);
  if (history.size() > kHistoryPerSource) history.pop_back();
}

void WorldState::journal(WorldItem item) {
  if (!journal_open_) return;
  const bool is_depth = std::holds_alternative<DepthImage>(item);
  if (journal_.size() >= kJournalCapacity || (is_depth && journal_depth_images_ >= kJournalDepthImages)) {
    ++journal_refused_;
    return;
  }
  if (is_depth) ++journal_depth_images_;
  journal_.push_back({wallClockNow_s(), std::move(item)});
}

void WorldState::publishBall(const BallObservation& observation) {
  std::lock_guard<std::mutex> lock(mutex_);
  pushCapped(balls_[observation.source], observation);
  journal(BallFrame{observation.stamp, {observation}});
  ++version_;
}

void WorldState::publishBalls(const std::vector<BallObservation>& observations) {
  if (observations.empty()) return;
  std::lock_guard<std::mutex> lock(mutex_);
  for (const BallObservation& observation : observations) pushCapped(balls_[observation.source], observation);
  journal(BallFrame{observations.front().stamp, observations});
  ++version_;
}

void WorldState::publishOmniFrame(const OmniFrame& frame) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const OmniBallObservation& ball : frame.balls) pushCapped(omni_balls_[ball.source], ball);
  journal(frame);
  ++version_;
}

void WorldState::clearFusedBall() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (fused_ball_) {
    fused_ball_.reset();
    journal(FusedBallCleared{});
    ++version_;
  }
}

void WorldState::publishTrajectory(const BallTrajectory& trajectory) {
  std::lock_guard<std::mutex> lock(mutex_);
  trajectories_[trajectory.source] = trajectory;
  journal(trajectory);
  ++version_;
}

void WorldState::clearTrajectory(const std::string& source) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (trajectories_.erase(source) > 0) {
    journal(TrajectoryCleared{source});
    ++version_;
  }
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
  journal(ball);
  ++version_;
}

void WorldState::publishRobotPose(const RobotPose& pose) {
  std::lock_guard<std::mutex> lock(mutex_);
  pushCapped(robot_poses_, pose);
  journal(pose);
  ++version_;
}

void WorldState::publishDepthImage(DepthImage image) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (journal_depth_) journal(std::move(image));
}

void WorldState::publishEvent(const Event& event) {
  std::lock_guard<std::mutex> lock(mutex_);
  journal(event);
}

void WorldState::publishHealth(const std::vector<PluginHealth>& health) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const PluginHealth& plugin : health) journal(plugin);
}

void WorldState::reportDroppedFrames(const std::string& plugin, std::uint64_t total) {
  std::lock_guard<std::mutex> lock(mutex_);
  dropped_frames_[plugin] = total;
}

void WorldState::reportProcessingTime(const std::string& plugin, double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<double>& times = processing_times_s_[plugin];
  if (times.size() < kJournalCapacity) times.push_back(seconds);  // bounded when nobody takes them
}

std::uint64_t WorldState::droppedFrames(const std::string& plugin) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = dropped_frames_.find(plugin);
  return found == dropped_frames_.end() ? 0 : found->second;
}

std::vector<double> WorldState::takeProcessingTimes(const std::string& plugin) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<double> times;
  const auto found = processing_times_s_.find(plugin);
  if (found != processing_times_s_.end()) times.swap(found->second);
  return times;
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

void WorldState::openJournal(bool with_depth) {
  std::lock_guard<std::mutex> lock(mutex_);
  journal_open_ = true;
  journal_depth_ = with_depth;
}

void WorldState::closeJournal() {
  std::lock_guard<std::mutex> lock(mutex_);
  journal_open_ = false;
  journal_depth_ = false;
  journal_.clear();
  journal_depth_images_ = 0;
}

bool WorldState::journalOpen() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return journal_open_;
}

bool WorldState::journalWantsDepth() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return journal_depth_;
}

std::vector<JournalEntry> WorldState::takeJournal(std::uint64_t* refused) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (refused != nullptr) *refused += journal_refused_;
  journal_refused_ = 0;
  journal_depth_images_ = 0;
  std::vector<JournalEntry> items;
  items.swap(journal_);
  return items;
}

}  // namespace fw
