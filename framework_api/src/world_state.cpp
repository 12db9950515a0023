#include "framework_api/world_state.h"

#include <algorithm>

namespace fw {

namespace {
// The value under key, if there is one.
template <typename Map>
std::optional<typename Map::mapped_type> valueAt(const Map& map, const std::string& key) {
  const auto found = map.find(key);
  if (found == map.end()) return std::nullopt;
  return found->second;
}
}  // namespace

template <typename T>
void WorldState::History<T>::push(T value) {
  newest_first.push_front(std::move(value));
  if (newest_first.size() > kHistoryPerSource) newest_first.pop_back();
  ++published;
}

template <typename T>
std::vector<T> WorldState::History<T>::since(std::uint64_t* cursor) const {
  const std::uint64_t unseen = std::min<std::uint64_t>(published - std::min(*cursor, published), newest_first.size());
  *cursor = published;
  return {newest_first.rend() - static_cast<std::ptrdiff_t>(unseen), newest_first.rend()};
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

std::chrono::steady_clock::duration WorldState::patience() {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(kArrivalPatience_s));
}

std::uint64_t WorldState::takePlace(std::optional<Measurement> measurement) {
  places_.push_back({std::move(measurement), std::chrono::steady_clock::now(), false});
  if (places_.size() > kMeasurementsKept) {
    places_.pop_front();
    ++first_place_;
  }
  return first_place_ + places_.size() - 1;
}

void WorldState::addBallFrame(BallFrame frame) {
  newest_ball_frames_[frame.source] = frame;
  if (!frame.balls.empty()) {
    ball_frames_[frame.source].push(frame);
    journal(std::move(frame));  // a frame without a ball is in the log as its depth frame
  }
  ++version_;
}

void WorldState::publishBalls(const std::vector<BallObservation>& observations) {
  if (observations.empty()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    BallFrame frame{observations.front().stamp, observations, observations.front().source};
    takePlace(frame);
    addBallFrame(std::move(frame));
  }
  announceBallFrame();
}

void WorldState::publishOmniFrame(const OmniFrame& frame) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!frame.balls.empty()) omni_frames_[frame.source].push(frame);
  takePlace(frame);
  journal(frame);
  ++version_;
}

WorldState::DepthArrival WorldState::arriveDepthFrame(std::optional<DepthImage> image, std::uint64_t* pose_cursor) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (image && journal_depth_) journal(std::move(*image));
  return {takePlace(std::nullopt), robot_poses_.since(pose_cursor)};
}

void WorldState::publishBallFrame(std::uint64_t place, BallFrame frame) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (place >= first_place_ && place < first_place_ + places_.size()) {
      Place& taken = places_[place - first_place_];
      if (std::chrono::steady_clock::now() - taken.taken < patience()) {
        taken.measurement = frame;
      } else {
        // A reader may have gone past its place: it comes now, a late measurement, to every reader.
        taken.withdrawn = true;
        takePlace(frame);
      }
    }
    addBallFrame(std::move(frame));
  }
  announceBallFrame();
}

std::vector<WorldState::Measurement> WorldState::measurementsSince(std::uint64_t* cursor) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto now = std::chrono::steady_clock::now();
  std::vector<Measurement> measurements;
  std::uint64_t place = std::max(*cursor, first_place_);
  for (; place < first_place_ + places_.size(); ++place) {
    const Place& next = places_[place - first_place_];
    if (next.measurement) {
      measurements.push_back(*next.measurement);
    } else if (!next.withdrawn && now - next.taken < patience()) {
      break;  // a depth frame still being processed: what came after it waits for it
    }
  }
  *cursor = place;
  return measurements;
}

void WorldState::publishSensorPose(const std::string& source, const SensorPose& pose) {
  std::lock_guard<std::mutex> lock(mutex_);
  sensor_poses_[source] = pose;
  ++version_;
}

std::optional<SensorPose> WorldState::sensorPose(const std::string& source) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return valueAt(sensor_poses_, source);
}

void WorldState::publishLearntLatencies(const LearntLatencies& latencies) {
  std::lock_guard<std::mutex> lock(mutex_);
  learnt_latencies_ = latencies;
  ++version_;
}

LearntLatencies WorldState::learntLatencies() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return learnt_latencies_;
}

void WorldState::publishTeamMessage(const TeamMessage& message) {
  std::lock_guard<std::mutex> lock(mutex_);
  team_messages_[message.robot_id] = message;
  takePlace(message);
  journal(message);
  ++version_;
}

std::map<int, TeamMessage> WorldState::teamMessages() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return team_messages_;
}

void WorldState::clearFusedBall(const Stamp& stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  journal(FusedBallCleared{stamp});
  if (fused_ball_) {
    fused_ball_.reset();
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
  return valueAt(trajectories_, source);
}

void WorldState::publishFusedBall(const FusedBall& ball) {
  std::lock_guard<std::mutex> lock(mutex_);
  fused_ball_ = ball;
  journal(ball);
  ++version_;
}

void WorldState::publishRobotPose(const RobotPose& pose) {
  std::lock_guard<std::mutex> lock(mutex_);
  robot_poses_.push(pose);
  takePlace(pose);
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

namespace {
// A plugin's reported times until the host takes them: bounded when nobody does.
void keep(std::map<std::string, std::vector<double>>& by_plugin, const std::string& plugin, double seconds,
          std::size_t capacity) {
  std::vector<double>& times = by_plugin[plugin];
  if (times.size() < capacity) times.push_back(seconds);
}
std::vector<double> take(std::map<std::string, std::vector<double>>& by_plugin, const std::string& plugin) {
  std::vector<double> times;
  const auto found = by_plugin.find(plugin);
  if (found != by_plugin.end()) times.swap(found->second);
  return times;
}
}  // namespace

void WorldState::reportProcessingTime(const std::string& plugin, double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  keep(processing_times_s_, plugin, seconds, kJournalCapacity);
}

void WorldState::reportLatency(const std::string& plugin, double seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  keep(latencies_s_, plugin, seconds, kJournalCapacity);
}

std::uint64_t WorldState::droppedFrames(const std::string& plugin) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = dropped_frames_.find(plugin);
  return found == dropped_frames_.end() ? 0 : found->second;
}

std::vector<double> WorldState::takeProcessingTimes(const std::string& plugin) {
  std::lock_guard<std::mutex> lock(mutex_);
  return take(processing_times_s_, plugin);
}

std::vector<double> WorldState::takeLatencies(const std::string& plugin) {
  std::lock_guard<std::mutex> lock(mutex_);
  return take(latencies_s_, plugin);
}

namespace {
// The observations of frames kept newest first, newest first, at most kHistoryPerSource of them.
template <typename Observation, typename Frames>
std::vector<Observation> newestObservations(const Frames& frames, std::size_t most) {
  std::vector<Observation> observations;
  for (const auto& frame : frames) {
    for (auto ball = frame.balls.rbegin(); ball != frame.balls.rend() && observations.size() < most; ++ball) {
      observations.push_back(*ball);
    }
  }
  return observations;
}
}  // namespace

std::vector<BallObservation> WorldState::recentBalls(const std::string& source) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = ball_frames_.find(source);
  if (found == ball_frames_.end()) return {};
  return newestObservations<BallObservation>(found->second.newest_first, kHistoryPerSource);
}

std::vector<OmniBallObservation> WorldState::recentOmniBalls(const std::string& source) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = omni_frames_.find(source);
  if (found == omni_frames_.end()) return {};
  return newestObservations<OmniBallObservation>(found->second.newest_first, kHistoryPerSource);
}

std::vector<std::string> WorldState::ballSources() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> sources;
  for (const auto& entry : ball_frames_) sources.push_back(entry.first);
  return sources;
}

std::optional<BallFrame> WorldState::newestBallFrame(const std::string& source) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return valueAt(newest_ball_frames_, source);
}

std::optional<FusedBall> WorldState::fusedBall() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return fused_ball_;
}

std::optional<RobotPose> WorldState::robotPose() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (robot_poses_.newest_first.empty()) return std::nullopt;
  return robot_poses_.newest_first.front();
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
