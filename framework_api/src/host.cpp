#include "framework_api/host.h"

#include <pthread.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>

#include "framework_api/log.h"

namespace fw {

namespace {
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// 10 ms after the first failed step in a row, doubling up to a second.
Clock::duration errorBackoff(int consecutive_errors) {
  const int doublings = std::min(consecutive_errors - 1, 7);
  return std::min<Clock::duration>(std::chrono::milliseconds(10) * (1 << doublings), std::chrono::seconds(1));
}

constexpr double kHistogramLowest_s = 1e-6;
constexpr double kHistogramStep = 1.01;  // each bin's upper edge over its lower
const int kHistogramBins = static_cast<int>(std::ceil(std::log(100.0 / kHistogramLowest_s) / std::log(kHistogramStep)));

}  // namespace

void LatencyHistogram::add(double latency_s) {
  if (bins_.empty()) bins_.assign(kHistogramBins, 0);
  const double bin =
      std::floor(std::log(std::max(latency_s, kHistogramLowest_s) / kHistogramLowest_s) / std::log(kHistogramStep));
  ++bins_[static_cast<std::size_t>(std::min(bin, kHistogramBins - 1.0))];
  ++count_;
}

double LatencyHistogram::quantile(double q) const {
  if (count_ == 0) return std::numeric_limits<double>::quiet_NaN();
  const auto rank = std::min(static_cast<std::uint64_t>(q * count_), count_ - 1);
  std::uint64_t below = 0;
  std::size_t bin = 0;
  while (below + bins_[bin] <= rank) below += bins_[bin++];
  return kHistogramLowest_s * std::pow(kHistogramStep, bin + 0.5);  // the bin's middle
}

struct Host::Running {
  std::unique_ptr<PluginInstance> instance;
  double rate_hz = 0.0;
  // With a rate: also step as soon as a depth frame's balls arrive, on the thread of the plugin that
  // published them, right after its step (a woken thread of its own waited milliseconds for a core
  // under load). The thread of its own still steps at the rate and when the inline step found it busy.
  bool wake_on_ball_frame = false;
  std::uint64_t ball_frames_seen = 0;  // under the host's wake_mutex_
  std::mutex stepping;                 // one step at a time, on whichever thread takes it
  Clock::time_point started;           // when start() launched the plugins (its summary's elapsed time)
  std::thread thread;
  std::atomic<bool> finished{false};        // the thread has left run()
  std::atomic<Clock::rep> step_started{0};  // steady clock ticks; 0 = not in a step
  bool reported_stuck = false;              // this step was reported (watch() only)
  mutable std::mutex mutex;                 // guards summary and the second's step times
  PluginSummary summary;
  std::vector<double> step_times_s;  // of the processed steps since the last health
};

Host::Host(const Config& config, const std::string& plugin_dir) : config_(config) {
  world_.setBallFrameListener([this] {
    {
      std::lock_guard<std::mutex> lock(wake_mutex_);
      ++ball_frames_;
    }
    // Their own threads wake; whichever comes first, that or the end of the publishing plugin's step
    // (stepAfterBallFrame), takes the step.
    wake_.notify_all();
  });
  const ConfigView host = config.block("host");
  const std::string least = host.getChoice("log_level", {"info", "warn", "error"});
  setLeastLogLevel(least == "error" ? LogLevel::kError : least == "warn" ? LogLevel::kWarn : LogLevel::kInfo);
  max_consecutive_errors_ = host.getInt("max_consecutive_errors", 1, 1000000);
  stuck_after_s_ = host.getDouble("stuck_after_s", 0.05, 3600.0);
  const std::vector<std::string> names = host.getStringList("plugins");
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::string& name = names[i];
    if (std::find(names.begin(), names.begin() + i, name) != names.begin() + i) {
      throw ConfigError(host.originOf("plugins") + ": host.plugins lists '" + name +
                        "' twice; each plugin runs once (its block configures it)");
    }
    const ConfigView block = config.block(name);
    auto running = std::make_unique<Running>();
    running->rate_hz = block.has("rate_hz") ? block.getDouble("rate_hz", 0.1, 1000.0) : 0.0;
    running->wake_on_ball_frame = block.has("wake_on_ball_frame") && block.getBool("wake_on_ball_frame");
    const auto library = PluginLibrary::open(plugin_dir + "/" + name + ".so");
    if (library->name() != name) {
      throw PluginLoadError("'" + library->path() + "' declares the plugin name '" + library->name() + "', expected '" +
                            name + "'");
    }
    running->instance = library->create(PluginContext{block, &world_, &config_});
    running->summary.name = name;
    running->summary.version = library->version();
    running->summary.rate_hz_setting = running->rate_hz;
    logInfo("host", "loaded plugin " + name + " " + library->version() + " from " + library->path());
    plugins_.push_back(std::move(running));
  }
}

Host::~Host() {
  if (!stop_requested_) stop();
  // A plugin still inside its step after the stop's grace is waited for: its step uses the plugin
  // and the world state, so neither may be destroyed under it (a logger's last commit on a loaded
  // machine outlasted a second, and the team report crashed when the step ended).
  for (auto& plugin : plugins_) {
    if (plugin->thread.joinable()) plugin->thread.join();
  }
}

void Host::start() {
  const Clock::time_point now = Clock::now();
  for (auto& plugin : plugins_) plugin->started = now;
  for (auto& plugin : plugins_) {
    Running& running = *plugin;
    running.thread = std::thread([this, &running] { run(running); });
  }
}

std::vector<std::string> Host::stop(std::chrono::duration<double> grace) {
  {
    std::lock_guard<std::mutex> lock(wake_mutex_);
    stop_requested_ = true;
  }
  wake_.notify_all();
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(grace);
  {
    std::unique_lock<std::mutex> lock(wake_mutex_);
    wake_.wait_until(lock, deadline, [this] {
      return std::all_of(plugins_.begin(), plugins_.end(),
                         [](const auto& p) { return !p->thread.joinable() || p->finished.load(); });
    });
  }
  std::vector<std::string> stuck;
  for (auto& plugin : plugins_) {
    if (!plugin->thread.joinable()) continue;
    if (plugin->finished) {
      plugin->thread.join();
      continue;
    }
    stuck.push_back(plugin->summary.name);
    logError(plugin->summary.name, "did not stop within " + std::to_string(grace.count()) + " s: still inside a step");
  }
  // The last part of a second, which no health row took, belongs to the run as well.
  for (auto& plugin : plugins_) addToRun(*plugin, world_.takeLatencies(plugin->summary.name));
  return stuck;
}

void Host::addToRun(Running& plugin, const std::vector<double>& latencies_s) {
  std::lock_guard<std::mutex> lock(plugin.mutex);
  for (const double latency_s : latencies_s) plugin.summary.latency_s.add(latency_s);
}

void Host::watch() {
  const Clock::rep now = Clock::now().time_since_epoch().count();
  const auto stuck_after = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(stuck_after_s_));
  for (auto& plugin : plugins_) {
    const Clock::rep started = plugin->step_started;
    if (started == 0) {
      plugin->reported_stuck = false;
      continue;
    }
    if (plugin->reported_stuck || now - started < stuck_after.count()) continue;
    plugin->reported_stuck = true;
    std::lock_guard<std::mutex> lock(plugin->mutex);
    ++plugin->summary.stuck;
    logError(plugin->summary.name, "stuck: inside one step for more than " + std::to_string(stuck_after_s_) + " s");
  }
  if (secondsSince(last_health_) >= 1.0) publishHealth();
}

void Host::publishHealth() {
  const double second_s = secondsSince(last_health_);
  last_health_ = Clock::now();
  std::vector<PluginHealth> health;
  for (auto& plugin : plugins_) {
    PluginHealth h;
    std::vector<double> times;
    {
      std::lock_guard<std::mutex> lock(plugin->mutex);
      times.swap(plugin->step_times_s);
      h.plugin = plugin->summary.name;
      h.errors = plugin->summary.errors;
      h.stuck = plugin->summary.stuck;
    }
    h.wall_time_s = wallClockNow_s();
    h.frames = times.size();
    h.rate_hz = times.size() / second_s;
    // A source-driven plugin's step includes its wait for the frame: its own times, when it reports them.
    if (std::vector<double> own = world_.takeProcessingTimes(h.plugin); !own.empty()) times.swap(own);
    if (!times.empty()) {
      h.processing_p50_s = quantile(times, 0.5);
      h.processing_p99_s = quantile(times, 0.99);
      for (const double t_s : times) h.processing_total_s += t_s;
    }
    if (const std::vector<double> latencies = world_.takeLatencies(h.plugin); !latencies.empty()) {
      h.latency_p50_s = quantile(latencies, 0.5);
      h.latency_p99_s = quantile(latencies, 0.99);
      addToRun(*plugin, latencies);
    }
    h.dropped_frames = world_.droppedFrames(h.plugin);
    health.push_back(h);
  }
  world_.publishHealth(health);
}

bool Host::sourcesFinished() const {
  bool any_source = false;
  for (const auto& plugin : plugins_) {
    if (plugin->rate_hz > 0.0) continue;
    any_source = true;
    std::lock_guard<std::mutex> lock(plugin->mutex);
    if (!plugin->summary.end_of_stream && !plugin->summary.gave_up) return false;
  }
  return any_source;
}

std::vector<PluginSummary> Host::summaries() const {
  std::vector<PluginSummary> result;
  for (const auto& plugin : plugins_) {
    std::lock_guard<std::mutex> lock(plugin->mutex);
    result.push_back(plugin->summary);
    result.back().dropped_frames = world_.droppedFrames(plugin->summary.name);
  }
  return result;
}

void Host::run(Running& plugin) {
  // The thread goes by its plugin's name (top -H, perf, gdb; Linux allows 15 characters).
  pthread_setname_np(pthread_self(), plugin.summary.name.substr(0, 15).c_str());
  const Clock::time_point start = plugin.started;
  const auto period =
      plugin.rate_hz > 0.0
          ? std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / plugin.rate_hz))
          : Clock::duration::zero();
  Clock::time_point next_tick = start;
  int consecutive_errors = 0;
  bool gave_up = false;
  while (!stop_requested_) {
    if (period > Clock::duration::zero()) {
      std::unique_lock<std::mutex> lock(wake_mutex_);
      const bool woken = wake_.wait_until(lock, next_tick, [&] {
        return stop_requested_.load() || (plugin.wake_on_ball_frame && ball_frames_ != plugin.ball_frames_seen);
      });
      if (stop_requested_) break;
      plugin.ball_frames_seen = ball_frames_;
      if (!woken) {
        next_tick += period;
        // After a long stall, skip the missed ticks instead of bursting to catch up.
        if (next_tick < Clock::now()) next_tick = Clock::now() + period;
      }
    }
    std::optional<StepResult> result;
    {
      const std::lock_guard<std::mutex> stepping(plugin.stepping);
      result = stepOnce(plugin, start);
    }
    stepAfterBallFrame(plugin);
    if (result) {
      consecutive_errors = 0;
      if (*result == StepResult::kEndOfStream) break;
      continue;
    }
    if (givesUp(plugin, ++consecutive_errors)) {
      gave_up = true;
      break;
    }
    // A plugin that keeps failing waits longer each time (a source that cannot read must not spin),
    // and a stop request ends the wait at once.
    const Clock::duration backoff = errorBackoff(consecutive_errors);
    std::unique_lock<std::mutex> lock(wake_mutex_);
    if (wake_.wait_for(lock, backoff, [this] { return stop_requested_.load(); })) break;
  }
  // Asked to stop, a plugin with a rate takes one last step, so that what the sources published
  // last is processed (after a normal end they have all finished): the fusion's last world ball is
  // the one a replay of the log ends with.
  {
    const std::lock_guard<std::mutex> stepping(plugin.stepping);
    if (period > Clock::duration::zero() && stop_requested_ && !gave_up) stepOnce(plugin, start);
    {
      std::lock_guard<std::mutex> lock(plugin.mutex);
      plugin.summary.elapsed_s = secondsSince(start);
    }
    std::lock_guard<std::mutex> lock(wake_mutex_);
    plugin.finished = true;  // under `stepping` too: no step on another thread after this
  }
  wake_.notify_all();
}

void Host::stepAfterBallFrame(const Running& publisher) {
  for (auto& plugin : plugins_) {
    if (!plugin->wake_on_ball_frame || plugin.get() == &publisher) continue;
    // Busy: its own thread is inside a step and takes the frame right after it.
    const std::unique_lock<std::mutex> stepping(plugin->stepping, std::try_to_lock);
    if (!stepping.owns_lock()) continue;
    {
      std::lock_guard<std::mutex> lock(wake_mutex_);
      if (stop_requested_ || plugin->finished || plugin->ball_frames_seen == ball_frames_) continue;
      plugin->ball_frames_seen = ball_frames_;
    }
    // A failed step is counted and logged as on its own thread, whose next step decides whether
    // the plugin gives up.
    stepOnce(*plugin, plugin->started);
  }
}

bool Host::givesUp(Running& plugin, int consecutive_errors) {
  if (consecutive_errors < max_consecutive_errors_) return false;
  std::lock_guard<std::mutex> lock(plugin.mutex);
  plugin.summary.gave_up = true;
  logError(plugin.summary.name, "gave up after " + std::to_string(consecutive_errors) +
                                    " failed steps in a row; last: " + plugin.summary.last_error);
  return true;
}

std::optional<StepResult> Host::stepOnce(Running& plugin, Clock::time_point start) {
  StepResult result = StepResult::kIdle;
  std::string error;
  const Clock::time_point step_start = Clock::now();
  plugin.step_started = step_start.time_since_epoch().count();
  try {
    result = plugin.instance->step();
  } catch (const PluginError& e) {
    error = e.what();
  }
  plugin.step_started = 0;
  const double step_s = secondsSince(step_start);
  std::lock_guard<std::mutex> lock(plugin.mutex);
  PluginSummary& summary = plugin.summary;
  ++summary.steps;
  summary.elapsed_s = secondsSince(start);
  if (!error.empty()) {
    ++summary.errors;
    summary.last_error = error;
    if (worthLogging(summary.errors)) {
      logError(summary.name, "step failed (" + std::to_string(summary.errors) + "): " + error);
    }
    return std::nullopt;
  }
  if (result == StepResult::kProcessed) {
    ++summary.frames;
    if (plugin.step_times_s.size() < WorldState::kJournalCapacity) plugin.step_times_s.push_back(step_s);
  }
  if (result == StepResult::kEndOfStream && !summary.end_of_stream) {
    summary.end_of_stream = true;
    logInfo(summary.name, "end of stream");
  }
  return result;
}

void Host::replay(const std::vector<ReplayStep>& steps, const std::function<void()>& after_input) {
  const Clock::time_point start = Clock::now();
  std::map<std::string, Running*> by_name;
  for (auto& plugin : plugins_) by_name[plugin->summary.name] = plugin.get();
  // A source that skips what it cannot use (a frame without a time stamp) hands out nothing on a
  // step: it is stepped again, but never without end.
  constexpr int kMaxStepsPerItem = 1000;
  // However the replay ends, the host's wall clock is the system's again.
  struct ClockRestorer {
    ~ClockRestorer() { setReplayedWallClock(std::nullopt); }
  } restore_clock;
  // A plugin that hands out inputs in this replay is stepped only for them, rate or not: a step of
  // its own would hand out the next input before its moment.
  std::set<std::string> sources;
  for (const ReplayStep& step : steps) sources.insert(step.plugin);
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const auto found = by_name.find(steps[i].plugin);
    if (found == by_name.end()) {
      throw PluginError("replay step " + std::to_string(i) + ": no plugin '" + steps[i].plugin +
                        "' is loaded (host.plugins) to hand out its input");
    }
    Running& source = *found->second;
    setReplayedWallClock(steps[i].wall_time_s);
    std::optional<StepResult> result;
    for (int attempt = 0; attempt < kMaxStepsPerItem && !(result && *result != StepResult::kIdle); ++attempt) {
      result = stepOnce(source, start);
      if (!result) break;  // counted and logged: the input is lost, as it would be on the robot
    }
    if (result == StepResult::kEndOfStream || result == StepResult::kIdle) {
      throw PluginError("replay step " + std::to_string(i) + ": '" + steps[i].plugin +
                        "' has no input left to hand out; its source is not the log being replayed");
    }
    for (auto& plugin : plugins_) {
      if (plugin->rate_hz > 0.0 && sources.count(plugin->summary.name) == 0) stepOnce(*plugin, start);
    }
    if (after_input) after_input();
  }
}

void Host::replaySource(const std::string& source_name, const std::function<void()>& after_input) {
  const Clock::time_point start = Clock::now();
  const auto found = std::find_if(plugins_.begin(), plugins_.end(),
                                  [&](const auto& plugin) { return plugin->summary.name == source_name; });
  if (found == plugins_.end()) {
    throw PluginError("no plugin '" + source_name + "' is loaded (host.plugins) to hand out the recording");
  }
  Running& source = **found;
  for (int consecutive_errors = 0;;) {
    const std::optional<StepResult> result = stepOnce(source, start);
    if (!result) {
      // Counted and logged: the input is lost, as it would be on the robot.
      if (givesUp(source, ++consecutive_errors)) break;
      continue;
    }
    consecutive_errors = 0;
    if (*result == StepResult::kEndOfStream) break;
    if (*result == StepResult::kIdle) continue;
    for (auto& plugin : plugins_) {
      if (plugin->rate_hz > 0.0 && plugin.get() != &source) stepOnce(*plugin, start);
    }
    after_input();
  }
  for (auto& plugin : plugins_) {
    std::lock_guard<std::mutex> lock(plugin->mutex);
    plugin->summary.elapsed_s = secondsSince(start);
  }
}

std::string formatSummary(const PluginSummary& summary) {
  char line[512];
  char latency[64] = "";
  if (summary.latency_s.count() > 0) {
    std::snprintf(latency, sizeof latency, ", latency p50 %.2f ms, p99 %.2f ms", 1e3 * summary.latency_s.quantile(0.5),
                  1e3 * summary.latency_s.quantile(0.99));
  }
  char dropped[64] = "";
  if (summary.dropped_frames > 0) {
    std::snprintf(dropped, sizeof dropped, " (and %llu dropped by its source)",
                  static_cast<unsigned long long>(summary.dropped_frames));
  }
  std::snprintf(line, sizeof line, "%s %s: %llu frames%s in %.1f s (%.1f Hz), %llu errors%s%s%s%s",
                summary.name.c_str(), summary.version.c_str(), static_cast<unsigned long long>(summary.frames), dropped,
                summary.elapsed_s, summary.frameRate_hz(), static_cast<unsigned long long>(summary.errors), latency,
                summary.end_of_stream ? ", end of stream" : (summary.gave_up ? ", gave up" : ""),
                summary.stuck == 0 ? "" : (", stuck " + std::to_string(summary.stuck) + " times").c_str(),
                summary.last_error.empty() ? "" : (", last error: " + summary.last_error).c_str());
  return line;
}

sigset_t blockStopSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  for (const int signal_number : {SIGINT, SIGTERM, SIGHUP, SIGQUIT}) sigaddset(&signals, signal_number);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  return signals;
}

std::string stopSignalName(int signal_number) {
  switch (signal_number) {
    case SIGINT:
      return "SIGINT";
    case SIGTERM:
      return "SIGTERM";
    case SIGHUP:
      return "SIGHUP";
    case SIGQUIT:
      return "SIGQUIT";
    default:
      return "signal " + std::to_string(signal_number);
  }
}

}  // namespace fw
