// logger: records everything the plugins publish, and the raw depth, into a match log
// (kinect3d/match_log.h, docs/match-log.md), one folder per run. Each step writes what the world
// state journalled since the last one as one committed batch.
//
// The robot plays whatever happens to its log. When the log folder cannot be created or written,
// the disk is (nearly) full or refuses a write, or the run's folder is deleted under the robot, the
// logger says so loudly and records into logger.fallback_folder instead (without depth: it is RAM
// on most robots); when that fails too, it keeps the newest publications in memory and says that
// nothing is being recorded. Every retry_s it tries again (the folder first); where recording
// resumes, a `recording_resumed` event says what was missed and why, and what memory still held
// follows it. A run that went to the fallback stays there. Only the budget, the team's own choice,
// stops recording for good.
#include <cmath>
#include <deque>
#include <filesystem>
#include <optional>

#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "matchlog/match_log.h"

namespace {

namespace fs = std::filesystem;

constexpr double kMegabyte = 1024.0 * 1024.0;
// What memory keeps while nothing is recorded: about a minute of a robot's publications without depth.
constexpr std::size_t kMemoryEntries = 20000;

std::string megabytes(double bytes) { return std::to_string(std::lround(bytes / kMegabyte)) + " MB"; }

// The free space of the file system that holds path, or of the nearest existing folder above it.
std::optional<double> availableBytes(fs::path path) {
  std::error_code error;
  while (!path.empty() && !fs::exists(path, error)) path = path.parent_path();
  const fs::space_info space = fs::space(path.empty() ? fs::path(".") : path, error);
  if (error) return std::nullopt;
  return static_cast<double>(space.available);
}

class LoggerPlugin : public fw::Plugin {
 public:
  explicit LoggerPlugin(const fw::PluginContext& context)
      : world_(*context.world),
        name_(context.config.path()),
        folder_(context.config.getString("folder")),
        fallback_folder_(context.config.getString("fallback_folder")),
        with_depth_(context.config.getBool("depth")),
        colour_jpeg_quality_(context.config.getInt("colour_jpeg_quality", 1, 100)),
        budget_bytes_(context.config.getDouble("budget_mb", 1.0, 1e8) * kMegabyte),
        min_free_bytes_(context.config.getDouble("min_free_mb", 0.0, 1e8) * kMegabyte),
        retry_s_(context.config.getDouble("retry_s", 0.5, 3600.0)) {
    run_.robot = context.robot_config->block("host").getString("robot_name");
    run_.software_version = KINECT3D_VERSION;
    run_.config_yaml = context.robot_config->toYaml();
    run_.replayed_from = context.robot_config->block("host").getString("replay_of");
    run_.start_wall_time_s = fw::wallClockNow_s();
    world_.openJournal(false);  // from now on nothing published is missed
    startRecording();
  }

  ~LoggerPlugin() override {
    if (writer_ == nullptr) {
      if (!stopped_for_good_) {
        fw::logError(name_, "the end of the match was NOT RECORDED (" + gap_->reason + "): its last " +
                                std::to_string(memory_.size()) + " publications were only in memory");
      }
      return;
    }
    try {
      record();  // what the other plugins published last: they have all stopped by now
    } catch (const fw::MatchLogError& e) {
      fw::logError(name_, std::string("the last batch was not recorded: ") + e.what());
    }
    if (writer_->fileGone()) {
      fw::logError(name_, "the log " + writer_->folder() + " was deleted or moved while the robot wrote it");
    } else {
      fw::logInfo(name_, "log complete: " + writer_->folder());
    }
  }

  fw::StepResult step() override {
    if (writer_ != nullptr) {
      try {
        record();
        checkLog();
      } catch (const fw::MatchLogError& e) {
        lose(e.what());
      }
    } else if (!stopped_for_good_) {
      keepInMemory();
    }
    if (writer_ == nullptr && !stopped_for_good_ && fw::wallClockNow_s() >= next_try_s_) {
      startRecording();
    }
    return fw::StepResult::kProcessed;
  }

 private:
  // Why recording stopped or never started, since when, and where the match up to then is.
  struct Gap {
    double since_wall_s;
    std::string reason;
    std::string previous_folder;  // empty: nothing recorded before
  };

  void record() {
    std::uint64_t refused = 0;
    const std::vector<fw::JournalEntry> entries = world_.takeJournal(&refused);
    for (const fw::JournalEntry& entry : entries) {
      try {
        writer_->write(entry);
      } catch (const fw::MatchLogRefused& e) {
        if (fw::worthLogging(++unrecordable_)) {
          fw::logWarn(name_, std::string(e.what()) + " (" + std::to_string(unrecordable_) + " so far)");
        }
      }
    }
    if (refused > 0) {
      // The disk or this core could not keep up: say so in the log itself, where it is missed.
      writer_->write({fw::wallClockNow_s(),
                      fw::Event{name_, "log_behind", std::to_string(refused) + " publications not recorded", {}}});
      fw::logWarn(name_, "fell behind: " + std::to_string(refused) + " publications not recorded");
    }
    writer_->commit();
  }

  // Ends recording into this log when it is gone, full, or its disk is.
  void checkLog() {
    if (writer_->fileGone()) {
      lose("the log " + writer_->folder() + " was deleted or moved while the robot wrote it");
      return;
    }
    const std::uint64_t bytes = writer_->bytesOnDisk();
    if (bytes >= budget_bytes_) {
      stopForGood("the log reached its budget (" + megabytes(bytes) + ", logger.budget_mb)");
      return;
    }
    const std::optional<double> available = availableBytes(writer_->folder());
    if (available && *available < min_free_bytes_) {
      lose("the disk of " + writer_->folder() + " has " + megabytes(*available) + " left (logger.min_free_mb)");
    }
  }

  // Writes the event into the log if the disk still takes it, and drops the writer.
  void closeWith(const std::string& kind, const std::string& message) {
    world_.openJournal(false);  // nobody copies depth frames for a log that is not there
    try {
      writer_->write({fw::wallClockNow_s(), fw::Event{name_, kind, message, {}}});
      writer_->commit();
    } catch (const fw::MatchLogError&) {
      // The disk refuses even this line: the next log's recording_resumed tells the story.
    }
    writer_.reset();
  }

  void stopForGood(const std::string& reason) {
    const std::string folder = writer_->folder();
    closeWith("recording_stopped", reason);
    world_.closeJournal();
    stopped_for_good_ = true;
    fw::logError(name_, "RECORDING STOPPED: " + reason + ". " + folder +
                            " holds the match up to now; detection and fusion go on");
  }

  // Recording failed: say so everywhere it can be seen, then look for another place at once.
  void lose(const std::string& reason) {
    const std::string folder = writer_->folder();
    closeWith("recording_stopped", reason);
    gap_ = Gap{fw::wallClockNow_s(), reason, folder};
    fw::logError(name_, "RECORDING STOPPED: " + reason + ". " + folder +
                            " holds the match up to now; detection and fusion go on");
    startRecording();
  }

  // Keeps the newest publications while no log takes them (depth frames aside).
  void keepInMemory() {
    std::uint64_t refused = 0;
    for (fw::JournalEntry& entry : world_.takeJournal(&refused)) {
      if (std::holds_alternative<fw::DepthImage>(entry.item)) continue;
      memory_.push_back(std::move(entry));
    }
    forgotten_ += refused;
    while (memory_.size() > kMemoryEntries) {
      memory_.pop_front();
      ++forgotten_;
    }
  }

  // Opens a new log in the folder, else in the fallback folder; else nothing is recorded for now.
  void startRecording() {
    next_try_s_ = fw::wallClockNow_s() + retry_s_;
    const std::string why_not = tryPlace(folder_, with_depth_, "");
    if (why_not.empty()) return;
    const std::string why_not_fallback =
        fallback_folder_.empty() ? "no logger.fallback_folder" : tryPlace(fallback_folder_, false, why_not);
    if (why_not_fallback.empty()) return;
    const std::string why = why_not + "; fallback: " + why_not_fallback;
    if (why != last_why_not_) {  // said once, not at every retry
      fw::logError(name_, "NOT RECORDING: " + why + ". Detection and fusion go on; the newest publications are kept " +
                              "in memory and recording is tried again every " + std::to_string(retry_s_) + " s");
      last_why_not_ = why;
    }
    if (!gap_) gap_ = Gap{fw::wallClockNow_s(), why, ""};
  }

  // A log under base: "" when recording there now, else why not. why_not_folder: why this is the
  // fallback ("" for the folder itself).
  std::string tryPlace(const std::string& base, bool depth, const std::string& why_not_folder) {
    const std::optional<double> available = availableBytes(base);
    if (available && *available < min_free_bytes_) {
      return base + ": the disk has " + megabytes(*available) + " left (logger.min_free_mb)";
    }
    try {
      writer_ = std::make_unique<fw::MatchLogWriter>(fw::claimRunFolder(base, run_.robot, fw::wallClockNow_s()), run_,
                                                     colour_jpeg_quality_);
      if (gap_ || !why_not_folder.empty()) writeResumed(why_not_folder);
    } catch (const fw::MatchLogError& e) {
      writer_.reset();
      return e.what();
    }
    world_.openJournal(depth);
    if (!why_not_folder.empty()) {
      fw::logError(name_, "RECORDING INTO THE FALLBACK " + writer_->folder() + " (no depth): " + why_not_folder);
    } else if (gap_) {
      fw::logWarn(name_, "recording resumed into " + writer_->folder());
    } else {
      fw::logInfo(name_, "recording into " + writer_->folder());
    }
    gap_.reset();
    last_why_not_.clear();
    return "";
  }

  // The first lines of a log that does not start with the run: what was missed and why, then what
  // memory held.
  void writeResumed(const std::string& why_not_folder) {
    const double now_s = fw::wallClockNow_s();
    std::string message;
    if (gap_) {
      message = "recording resumed " + std::to_string(std::lround(now_s - gap_->since_wall_s)) +
                " s after it stopped: " + gap_->reason;
      if (!gap_->previous_folder.empty()) message += "; the match before is in " + gap_->previous_folder;
    } else {
      message = "recording starts in the fallback folder";
    }
    if (!why_not_folder.empty()) message += "; without depth, because logger.folder cannot be used: " + why_not_folder;
    if (!memory_.empty() || forgotten_ > 0) {
      message += "; " + std::to_string(memory_.size()) + " publications kept in memory follow, " +
                 std::to_string(forgotten_) + " were lost";
    }
    writer_->write({now_s, fw::Event{name_, gap_ ? "recording_resumed" : "recording_fallback", message, {}}});
    for (const fw::JournalEntry& entry : memory_) writer_->write(entry);
    writer_->commit();
    memory_.clear();
    forgotten_ = 0;
  }

  fw::WorldState& world_;
  const std::string name_;
  const std::string folder_;
  const std::string fallback_folder_;  // empty: none
  const bool with_depth_;
  const int colour_jpeg_quality_;
  const double budget_bytes_;
  const double min_free_bytes_;
  const double retry_s_;
  fw::RunInfo run_;
  std::unique_ptr<fw::MatchLogWriter> writer_;  // null: not recording
  bool stopped_for_good_ = false;
  std::string last_why_not_;  // what the last NOT RECORDING said
  std::optional<Gap> gap_;    // since when and why nothing is recorded (before the first log, too)
  std::deque<fw::JournalEntry> memory_;
  std::uint64_t forgotten_ = 0;     // publications neither recorded nor kept
  std::uint64_t unrecordable_ = 0;  // publications the log could not hold
  double next_try_s_ = 0.0;
};

}  // namespace

FW_REGISTER_PLUGIN(LoggerPlugin, "logger", "0.1.0")
