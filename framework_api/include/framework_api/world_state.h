// The robot's shared world state: plugins publish to it and read from it from their own threads.
// Every accessor copies under a lock, so a reader never sees a half-written value.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "framework_api/replay_clock.h"
#include "framework_api/sensor_pose.h"
#include "framework_api/team_message.h"
#include "framework_api/types.h"

namespace fw {

// A source that lost the ball (its trajectory withdrawn), and an update of the world ball that left
// the world without one (stamp: the update's time, as a FusedBall's).
struct TrajectoryCleared {
  std::string source;
};
struct FusedBallCleared {
  Stamp stamp;
};

// What the fusion has learnt of its inputs' stamps: how many seconds each is late beyond its
// configured latency (fusion.omni.latency_s, fusion.pose.latency_s), as the fusion last reported
// it (within a millisecond of what it applies); none until learnt. The stages that place the same
// measurements (the team plugin) place them alike (fusion::omniSeen_s, fusion::poseStampFor_s).
struct LearntLatencies {
  std::optional<double> omni_s;
  std::optional<double> pose_s;
};

// One publication as the journal keeps it, with the host's wall clock when it was published.
using WorldItem = std::variant<BallFrame, OmniFrame, BallTrajectory, TrajectoryCleared, FusedBall, FusedBallCleared,
                               RobotPose, DepthImage, Event, PluginHealth, TeamMessage>;
struct JournalEntry {
  double wall_time_s = 0.0;
  WorldItem item;
};

class WorldState {
 public:
  // How many recent observations are kept per source (a second at 30 Hz).
  static constexpr std::size_t kHistoryPerSource = 30;

  // One frame's balls at once, so a reader never sees half a frame (the observations' source names
  // it; none: nothing is published). A depth plugin uses arriveDepthFrame and publishBallFrame.
  void publishBalls(const std::vector<BallObservation>& observations);
  void publishOmniFrame(const OmniFrame& frame);
  void publishFusedBall(const FusedBall& ball);
  // An update that left the world without a ball: journalled each time, so that the journal holds
  // every update of the world ball, with or without one.
  void clearFusedBall(const Stamp& stamp);
  void publishTrajectory(const BallTrajectory& trajectory);  // replaces that source's last one
  void clearTrajectory(const std::string& source);           // the source lost the ball
  void publishRobotPose(const RobotPose& pose);
  // Where a sensor sits on the robot (its configured pose_in_robot), for the stages that place its
  // measurements; replaced when it changes.
  void publishSensorPose(const std::string& source, const SensorPose& pose);
  std::optional<SensorPose> sensorPose(const std::string& source) const;
  void publishLearntLatencies(const LearntLatencies& latencies);
  LearntLatencies learntLatencies() const;
  // A teammate's message as the team plugin received it, its times on this host's clock.
  void publishTeamMessage(const TeamMessage& message);
  // The newest message of each teammate, by robot id.
  std::map<int, TeamMessage> teamMessages() const;

  // What the fusion takes in, in the order it came: robot poses, every depth frame's balls (a frame
  // without a ball too: it is evidence), omni images, teammates' messages.
  using Measurement = std::variant<RobotPose, BallFrame, OmniFrame, TeamMessage>;
  // A depth frame takes its place among the measurements when it arrives, before its balls are
  // known, and the poses published before it are handed to its detector at the same moment: so
  // whatever the threads' timing, a reader of measurementsSince() and the detector see what a
  // replay of the match log gives them (Host::replay). image goes into the journal with it (pass
  // one when journalWantsDepth()).
  struct DepthArrival {
    std::uint64_t place = 0;
    std::vector<RobotPose> poses;  // published since *pose_cursor, oldest first
  };
  DepthArrival arriveDepthFrame(std::optional<DepthImage> image, std::uint64_t* pose_cursor);
  // Fills an arrival's place with the frame's balls (frame.balls may be empty, frame.source names
  // the plugin). Readers go past a place left unfilled for kArrivalPatience_s (its plugin failed or
  // is stuck); balls that come later than that take a new place, as a late measurement.
  void publishBallFrame(std::uint64_t place, BallFrame frame);
  static constexpr double kArrivalPatience_s = 0.25;
  // The measurements after *cursor (a count the reader keeps, 0 at first) in their order, up to the
  // first place still waiting for its balls; at most kMeasurementsKept of the newest.
  static constexpr std::size_t kMeasurementsKept = 1024;
  std::vector<Measurement> measurementsSince(std::uint64_t* cursor) const;
  // Called after a depth plugin's balls are published (a frame's place filled), outside the state's
  // lock: the host wakes the plugins that step on a depth frame's balls. Set before any plugin runs.
  void setBallFrameListener(std::function<void()> listener) { ball_frame_listener_ = std::move(listener); }
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
  // And the time from an input's arrival on this host to the plugin's output (PluginHealth).
  void reportLatency(const std::string& plugin, double seconds);
  std::uint64_t droppedFrames(const std::string& plugin) const;
  // The processing times and latencies reported since the last call (none: the plugin reports none).
  std::vector<double> takeProcessingTimes(const std::string& plugin);
  std::vector<double> takeLatencies(const std::string& plugin);

  // Newest first.
  std::vector<BallObservation> recentBalls(const std::string& source) const;
  std::vector<OmniBallObservation> recentOmniBalls(const std::string& source) const;
  std::vector<std::string> ballSources() const;
  // A source's newest frame, with or without a ball: whether it sees the ball now.
  std::optional<BallFrame> newestBallFrame(const std::string& source) const;
  std::optional<BallTrajectory> trajectory(const std::string& source) const;
  std::optional<FusedBall> fusedBall() const;
  std::optional<RobotPose> robotPose() const;  // the newest

  // Increases with every publish; a reader that saw version v has nothing new while it is still v.
  std::uint64_t version() const;

  // The anchor the host's sources that replay recorded or simulated time keep to in real time.
  SharedPace& replayPace() { return replay_pace_; }

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
  void journal(WorldItem item);                                     // under mutex_
  void addBallFrame(BallFrame frame);                               // to the recent balls and the journal, under mutex_
  std::uint64_t takePlace(std::optional<Measurement> measurement);  // its number; under mutex_

  // A measurement's place: empty until a depth frame's balls fill it.
  struct Place {
    std::optional<Measurement> measurement;
    std::chrono::steady_clock::time_point taken;
    bool withdrawn;  // its balls came too late and took a new place
  };
  static std::chrono::steady_clock::duration patience();

  mutable std::mutex mutex_;
  SharedPace replay_pace_;
  std::map<std::string, History<BallFrame>> ball_frames_;  // frames with balls
  std::map<std::string, BallFrame> newest_ball_frames_;
  std::map<std::string, History<OmniFrame>> omni_frames_;  // frames with balls, by the balls' source
  std::map<std::string, BallTrajectory> trajectories_;
  std::optional<FusedBall> fused_ball_;
  History<RobotPose> robot_poses_;
  std::map<std::string, SensorPose> sensor_poses_;
  LearntLatencies learnt_latencies_;
  std::map<int, TeamMessage> team_messages_;
  std::deque<Place> places_;       // the newest kMeasurementsKept measurements
  std::uint64_t first_place_ = 0;  // the number of places_.front()
  std::map<std::string, std::uint64_t> dropped_frames_;
  std::map<std::string, std::vector<double>> processing_times_s_;
  std::map<std::string, std::vector<double>> latencies_s_;
  std::function<void()> ball_frame_listener_;
  void announceBallFrame() const {
    if (ball_frame_listener_) ball_frame_listener_();
  }
  std::uint64_t version_ = 0;
  bool journal_open_ = false;
  bool journal_depth_ = false;
  std::vector<JournalEntry> journal_;
  std::size_t journal_depth_images_ = 0;
  std::uint64_t journal_refused_ = 0;
};

}  // namespace fw
