// logger: records everything the plugins publish, and the raw depth, into a match log
// (kinect3d/match_log.h, docs/match-log.md), one folder per run. Each step writes what the world
// state journalled since the last one as one committed batch. When the log reaches its budget, the
// disk fills up or refuses a write, recording stops with a loud error and the robot plays on.
#include <cmath>
#include <filesystem>

#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "kinect3d/match_log.h"

namespace {

namespace fs = std::filesystem;

constexpr double kMegabyte = 1024.0 * 1024.0;

class LoggerPlugin : public fw::Plugin {
 public:
  explicit LoggerPlugin(const fw::PluginContext& context)
      : world_(*context.world),
        name_(context.config.path()),
        budget_bytes_(context.config.getDouble("budget_mb", 1.0, 1e8) * kMegabyte),
        min_free_bytes_(context.config.getDouble("min_free_mb", 0.0, 1e8) * kMegabyte) {
    const double start_s = fw::wallClockNow_s();
    kinect3d::RunInfo run;
    run.robot = context.robot_config->block("host").getString("robot_name");
    run.software_version = KINECT3D_VERSION;
    run.config_yaml = context.robot_config->toYaml();
    run.start_wall_time_s = start_s;
    const std::string folder = kinect3d::runFolderName(context.config.getString("folder"), run.robot, start_s);
    try {
      writer_ = std::make_unique<kinect3d::MatchLogWriter>(folder, run);
    } catch (const kinect3d::MatchLogError& e) {
      throw fw::ConfigError(context.config.originOf("folder") + ": logger.folder: " + e.what());
    }
    world_.openJournal(context.config.getBool("depth"));
    fw::logInfo(name_, "recording into " + folder);
  }

  ~LoggerPlugin() override {
    if (writer_ == nullptr) return;
    try {
      record();  // what the other plugins published last: they have all stopped by now
    } catch (const kinect3d::MatchLogError& e) {
      fw::logError(name_, std::string("the last batch was not recorded: ") + e.what());
    }
    fw::logInfo(name_, "log complete: " + writer_->folder());
  }

  fw::StepResult step() override {
    if (writer_ == nullptr) return fw::StepResult::kIdle;  // stopped recording
    try {
      record();
      const std::string full = fullBecause();
      if (!full.empty()) stopRecording(full);
    } catch (const kinect3d::MatchLogError& e) {
      stopRecording(e.what());
    }
    return fw::StepResult::kProcessed;
  }

 private:
  void record() {
    std::uint64_t refused = 0;
    const std::vector<fw::JournalEntry> entries = world_.takeJournal(&refused);
    for (const fw::JournalEntry& entry : entries) writer_->write(entry);
    if (refused > 0) {
      // The disk or this core could not keep up: say so in the log itself, where it is missed.
      writer_->write({fw::wallClockNow_s(),
                      fw::Event{name_, "log_behind", std::to_string(refused) + " publications not recorded", {}}});
      fw::logWarn(name_, "fell behind: " + std::to_string(refused) + " publications not recorded");
    }
    writer_->commit();
  }

  // Why recording must stop now, or nothing.
  std::string fullBecause() const {
    const std::uint64_t bytes = writer_->bytesOnDisk();
    if (bytes >= budget_bytes_) {
      return "the log reached its budget (" + std::to_string(std::lround(bytes / kMegabyte)) + " MB, logger.budget_mb)";
    }
    std::error_code error;
    const fs::space_info space = fs::space(writer_->folder(), error);
    if (!error && static_cast<double>(space.available) < min_free_bytes_) {
      return "the disk has " + std::to_string(std::lround(space.available / kMegabyte)) +
             " MB left (logger.min_free_mb)";
    }
    return "";
  }

  void stopRecording(const std::string& reason) {
    world_.closeJournal();
    try {
      writer_->write({fw::wallClockNow_s(), fw::Event{name_, "recording_stopped", reason, {}}});
      writer_->commit();
    } catch (const kinect3d::MatchLogError&) {
      // The disk refuses even this line; what was committed before stays readable.
    }
    fw::logError(name_, "RECORDING STOPPED: " + reason + ". " + writer_->folder() +
                            " holds the match up to now; detection and fusion go on");
    writer_.reset();
  }

  fw::WorldState& world_;
  const std::string name_;
  const double budget_bytes_;
  const double min_free_bytes_;
  std::unique_ptr<kinect3d::MatchLogWriter> writer_;
};

}  // namespace

FW_REGISTER_PLUGIN(LoggerPlugin, "logger", "0.1.0")
