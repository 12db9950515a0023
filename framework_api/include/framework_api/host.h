// Runs the plugins a robot configuration enables, each on its own thread, all sharing one
// WorldState. vision_host is a thin command line around this class; tests drive it directly.
#pragma once

#include <signal.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "framework_api/config.h"
#include "framework_api/plugin_loader.h"
#include "framework_api/world_state.h"

namespace fw {

// The latencies a plugin reported over a whole run (WorldState::reportLatency), counted in bins 1 %
// wide from 1 us to 100 s: the run's quantiles to within 1 %, in fixed memory however long the match.
class LatencyHistogram {
 public:
  void add(double latency_s);
  std::uint64_t count() const { return count_; }
  // The q-quantile by nearest rank, as fw::quantile, to within 1 %; NaN before the first latency.
  double quantile(double q) const;

 private:
  std::vector<std::uint64_t> bins_;  // sized at the first latency: a plugin that reports none keeps none
  std::uint64_t count_ = 0;
};

struct PluginSummary {
  std::string name;
  std::string version;
  double rate_hz_setting = 0.0;  // 0 = driven by its own source (no rate_hz in its block)
  std::uint64_t steps = 0;
  std::uint64_t frames = 0;  // steps that processed something
  // Frames its source dropped (a live sensor's driver overwrites what a busy host did not read).
  std::uint64_t dropped_frames = 0;
  std::uint64_t errors = 0;
  std::string last_error;
  bool end_of_stream = false;
  bool gave_up = false;     // stopped after host.max_consecutive_errors failed steps in a row
  std::uint64_t stuck = 0;  // times a step ran longer than host.stuck_after_s
  double elapsed_s = 0.0;
  LatencyHistogram latency_s;  // over the run: from an input's arrival to its output (the fusion's)

  double frameRate_hz() const { return elapsed_s > 0.0 ? frames / elapsed_s : 0.0; }
};

class Host {
 public:
  // Loads every plugin named in host.plugins from plugin_dir (file <name>.so) and creates it with
  // its configuration block. Throws PluginLoadError or ConfigError naming the plugin and the cause.
  Host(const Config& config, const std::string& plugin_dir);
  ~Host();
  Host(const Host&) = delete;
  Host& operator=(const Host&) = delete;

  // Runs the plugins on their own threads, each at its rate or its source's pace.
  void start();

  // The deterministic mode, instead of start(): no threads, no pacing. For each step in order, with
  // the host's wall clock set to that moment (fw::wallClockNow_s), steps the named plugin until it
  // hands out one input, then every other plugin with a rate once (in host.plugins order; a plugin
  // with a rate that hands out inputs too, like the team plugin, is stepped only for them): every plugin
  // sees what it saw on the robot, in the order the robot received it, whatever the timing was
  // (kinect3d replay plays a match log's inputs so, with the sources reading that log). Throws
  // PluginError naming a step whose plugin is not loaded or has nothing left to hand out. Calls
  // after_input (if any) after each step, its input and the rated plugins done.
  struct ReplayStep {
    std::string plugin;  // the source plugin that hands out this input
    double wall_time_s;  // when the robot received it
  };
  void replay(const std::vector<ReplayStep>& steps, const std::function<void()>& after_input = {});
  // The deterministic mode for one recorded source, instead of start(): steps the plugin `source`
  // until its source ends (or until it gives up after host.max_consecutive_errors failed steps), and
  // after each input it hands out, every other plugin with a rate once, then after_input. The wall
  // clock is the system's: inputs arrive as fast as the plugins take them (kinect3d detect runs the
  // kinect3d plugin so). Throws PluginError when no plugin `source` is loaded.
  void replaySource(const std::string& source, const std::function<void()>& after_input);
  // Asks every plugin thread to stop after its current step and joins those that do within grace.
  // Returns the plugins still inside a step then (slow, or stuck in a blocking call): the host's
  // destructor waits for their steps to end before it destroys anything they use, so a caller that
  // must stop at once (vision_host) ends the process instead. Idempotent.
  std::vector<std::string> stop(std::chrono::duration<double> grace = std::chrono::seconds(1));
  // Call it now and then (every 100 ms) while running. Reports (once per step) every plugin that
  // has been inside one step for longer than host.stuck_after_s, and counts it in its summary; once
  // a second, publishes every plugin's health over that second to the world state.
  void watch();
  // True once every source-driven plugin (one without rate_hz) has reported end of stream or given
  // up, and there is at least one: then nothing new can reach the world state.
  bool sourcesFinished() const;

  std::vector<PluginSummary> summaries() const;
  WorldState& world() { return world_; }

 private:
  struct Running;
  void run(Running& plugin);
  // After a step of `publisher` on its own thread: every wake_on_ball_frame plugin with a depth
  // frame's balls it has not seen steps here, unless it is stepping now or has stopped.
  void stepAfterBallFrame(const Running& publisher);
  // One step, counted in the plugin's summary (an error logged too); nothing when it failed.
  std::optional<StepResult> stepOnce(Running& plugin, std::chrono::steady_clock::time_point start);
  // After a failed step: true (the plugin's summary says it gave up, and the log why) once it has
  // failed host.max_consecutive_errors times in a row.
  bool givesUp(Running& plugin, int consecutive_errors);
  void publishHealth();
  // Adds latencies taken from the world state to the plugin's figure for the whole run.
  static void addToRun(Running& plugin, const std::vector<double>& latencies_s);

  std::chrono::steady_clock::time_point last_health_ = std::chrono::steady_clock::now();
  // Declared first: plugins hold pointers to them and are destroyed before them.
  const Config config_;
  WorldState world_;
  std::vector<std::unique_ptr<Running>> plugins_;
  std::atomic<bool> stop_requested_{false};
  int max_consecutive_errors_ = 0;
  double stuck_after_s_ = 0.0;
  std::mutex wake_mutex_;
  std::condition_variable wake_;
  std::uint64_t ball_frames_ = 0;  // published so far (under wake_mutex_): steps wake_on_ball_frame plugins
};

// One summary line per plugin: "kinect3d 1.0.0: 301 frames in 10.0 s (30.1 Hz), 0 errors", and for
// a plugin that reports its latency: ", latency p50 0.81 ms, p99 2.10 ms".
std::string formatSummary(const PluginSummary& summary);

// For a program that runs a host: blocks every signal that asks a robot's program to end (SIGINT
// from Ctrl-C, SIGTERM from a service manager, SIGHUP from an ssh session that drops, SIGQUIT from
// Ctrl-\) in the calling thread and, by inheritance, in every plugin thread started after it, so
// that no handler runs inside a plugin and none kills the process mid-write; its main loop collects
// them with sigtimedwait(returned set, ...) between Host::watch() calls and stops the same clean way.
sigset_t blockStopSignals();
// "SIGHUP" and the like, for the summary line.
std::string stopSignalName(int signal_number);

}  // namespace fw
