// The robot's shared world state: plugins publish to it and read from it from their own threads.
// Every accessor copies under a lock, so a reader never sees a half-written value.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "framework_api/types.h"

namespace fw {

// A source that lost the ball (its trajectory withdrawn), and a world that has no ball any more.
struct TrajectoryCleared {
  std::string source;
};
struct FusedBallCleared {};

// One publication as the journal keeps it, with the host's wall clock when it was published.
using WorldItem = std::variant<BallFrame, OmniFrame, BallTrajectory, TrajectoryCleared, FusedBall, FusedBallCleared,
                               RobotPose, DepthImage, Event, PluginHealth>;
struct JournalEntry {
  double wall_time_s = 0.0;
  WorldItem item;
};

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
  // Only into the journal (nobody acts on them; the match log and the viewer show them). Every item is
  // a plain value: nothing in the journal may point into a plugin's library, which is unloaded with
  // the plugin while the journal's reader may still hold the item.
  void publishDepthImage(DepthImage image);
  void publishEvent(const Event& event);
  void publishHealth(const std::vector<PluginHealth>& health);
  // What a source-driven plugin knows better than the host, for the host's health: its dropped
  // frames so far (gaps in its source's counter), and the time it spent on a frame, without the
  // wait for it (the host's step time includes that wait).
  void reportDroppedFrames(const std::string& plugin, std::uint64_t total);
  void reportProcessingTime(const std::string& plugin, double seconds);
  std::uint64_t droppedFrames(const std::string& plugin) const;
  // The processing times reported since the last call (none: the plugin reports none).
  std::vector<double> takeProcessingTimes(const std::string& plugin);

  // What one reader has not seen yet, in the order it was published (not by time stamp, which may
  // jump): the items published after *cursor (a count the reader keeps, 0 at first), at most the
  // kHistoryPerSource newest; *cursor moves past them.
  std::vector<BallFrame> ballFramesSince(const std::string& source, std::uint64_t* cursor) const;
  std::vector<OmniFrame> omniFramesSince(const std::string& source, std::uint64_t* cursor) const;
  std::vector<RobotPose> robotPosesSince(std::uint64_t* cursor) const;

  // Newest first.
  std::vector<BallObservation> recentBalls(const std::string& source) const;
  std::vector<OmniBallObservation> recentOmniBalls(const std::string& source) const;
  std::vector<std::string> ballSources() const;
  std::optional<BallTrajectory> trajectory(const std::string& source) const;
  std::optional<FusedBall> fusedBall() const;
  std::optional<RobotPose> robotPose() const;  // the newest

  // Increases with every publish; a reader that saw version v has nothing new while it is still v.
  std::uint64_t version() const;

  // The journal: every publication in order, for the one reader that must see each of them (the
  // match log). Off until that reader opens it, so a robot without a log pays nothing. Bounded: when
  // its reader falls behind, new items are refused and counted rather than the robot running out of
  // memory (depth images, large, have their own smaller bound).
  static constexpr std::size_t kJournalCapacity = 8192;
  static constexpr std::size_t kJournalDepthImages = 60;  // two seconds at 30 Hz
  // with_depth: depth images are journalled too (the depth plugins copy each frame only then).
  void openJournal(bool with_depth);
  void closeJournal();  // and drops what it held: its reader has stopped for good
  bool journalOpen() const;
  bool journalWantsDepth() const;
  // Everything journalled since the last call, oldest first; adds to *refused what did not fit.
  std::vector<JournalEntry> takeJournal(std::uint64_t* refused);

 private:
  // The newest publications of one kind, and how many there were in all (readers' cursors).
  template <typename T>
  struct History {
    std::deque<T> newest_first;
    std::uint64_t published = 0;
    void push(T value);
    std::vector<T> since(std::uint64_t* cursor) const;
  };
  void journal(WorldItem item);  // under mutex_

  mutable std::mutex mutex_;
  std::map<std::string, History<BallFrame>> ball_frames_;
  std::map<std::string, History<OmniFrame>> omni_frames_;  // frames with balls, by the balls' source
  std::map<std::string, BallTrajectory> trajectories_;
  std::optional<FusedBall> fused_ball_;
  History<RobotPose> robot_poses_;
  std::map<std::string, std::uint64_t> dropped_frames_;
  std::map<std::string, std::vector<double>> processing_times_s_;
  std::uint64_t version_ = 0;
  bool journal_open_ = false;
  bool journal_depth_ = false;
  std::vector<JournalEntry> journal_;
  std::size_t journal_depth_images_ = 0;
  std::uint64_t journal_refused_ = 0;
};

}  // namespace fw
