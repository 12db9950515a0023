// The match log: one folder per run holding match.sqlite, an SQLite database of everything the
// plugins published (balls per source with both stamps and covariance, omni images, trajectories,
// fused balls, robot poses, events, per-plugin health once a second) and the raw depth of the
// depth plugins, each frame compressed losslessly (kinect3d/depth_codec.h), with its colour image as
// JPEG. The schema is in docs/match-log.md; its version is the database's user_version.
//
// Written in batches (one transaction per commit(), the logger commits every 200 ms) in WAL mode,
// so a process killed at any moment leaves a database that opens with every committed batch.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "framework_api/world_state.h"
#include "matchlog/colour_codec.h"
#include "matchlog/depth_codec.h"

struct sqlite3;
struct sqlite3_stmt;

namespace fw {

constexpr int kMatchLogSchemaVersion = 10;
// Logs back to this version are read (version 2 has no colour verdicts: its balls read as not checked;
// versions 2 and 3 have no teammates' messages; versions 2 to 4 hold their depth as PNG, 5 to 9 as
// zstd on row differences; versions 2 to 5 keep no value with an event, and no time with the world
// ball's 'none', which they record only after a ball; versions 2 to 6 have no goal-line crossing
// with the world ball; versions 2 to 8 have no robots seen by the omni camera).
constexpr int kOldestReadableSchemaVersion = 2;
constexpr const char* kMatchLogFile = "match.sqlite";

// A log that cannot be written or read: names the file and the reason.
class MatchLogError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// One publication the log cannot hold (a time stamp that is not a number where the log needs one);
// the log itself is fine and takes the next.
class MatchLogRefused : public MatchLogError {
 public:
  using MatchLogError::MatchLogError;
};

// What a run was: stored once, at the start.
struct RunInfo {
  std::string robot;
  std::string software_version;
  std::string config_yaml;  // the merged configuration the run used
  double start_wall_time_s = 0.0;
  std::string replayed_from;  // a replay: the log it re-ran; empty for a live run
};

// Creates and returns "<base>/2026-11-22_14-03-07_demo", the folder of a run of robot started at
// wall_time_s (local time), or "..._demo-2", "-3", ... when another run took that name (a restart
// within the same second, two robots sharing a base): the folder is created here, so no two callers
// ever get the same one. Throws MatchLogError naming base and the reason when it cannot create it.
std::string claimRunFolder(const std::string& base, const std::string& robot, double wall_time_s);

// What a program that starts a logger uses to find the run folder it made: the entries of base
// before it starts (none when base does not exist yet), then a folder under base not among them
// that holds a readable match log, if there is one yet.
std::set<std::string> entriesOf(const std::string& base);
std::optional<std::string> newRunIn(const std::string& base, const std::set<std::string>& before);

// A prepared statement, finalised with its owner.
struct Statement;

class MatchLogWriter {
 public:
  // Creates folder (and its parents) and folder/match.sqlite, which must not exist yet. Colour
  // images are kept as JPEG at colour_jpeg_quality (1-100; the logger's logger.colour_jpeg_quality,
  // whose shipped default this is: a test holds them equal).
  static constexpr int kDefaultColourJpegQuality = 90;
  MatchLogWriter(const std::string& folder, const RunInfo& run, int colour_jpeg_quality = kDefaultColourJpegQuality);
  ~MatchLogWriter();  // commits what is pending
  MatchLogWriter(const MatchLogWriter&) = delete;
  MatchLogWriter& operator=(const MatchLogWriter&) = delete;

  // Adds one publication to the current batch. Throws MatchLogRefused when the log cannot hold it
  // (the batch goes on), MatchLogError when the disk refuses it.
  void write(const fw::JournalEntry& entry);
  // Ends the batch: from here on, a crash keeps it.
  void commit();

  const std::string& folder() const { return folder_; }
  // The database and its write-ahead log, in bytes.
  std::uint64_t bytesOnDisk() const;
  // The database file is no longer where it was created (its folder deleted or moved under the
  // writer): whatever is written from now on is lost.
  bool fileGone() const;

 private:
  void exec(const std::string& sql);
  void begin();
  Statement& statement(const char* sql);

  std::string folder_;
  std::string path_;
  sqlite3* db_ = nullptr;
  std::map<std::string, std::unique_ptr<Statement>> statements_;  // prepared once, by their SQL
  bool in_batch_ = false;
  std::int64_t next_seq_ = 1;
  JpegEncoder colour_encoder_;
  DepthEncoder depth_encoder_;
};

class MatchLogReader {
 public:
  // Opens folder/match.sqlite for reading, writing nothing beside it: a log closed cleanly is read
  // as immutable (read-only media and other users' folders work); one being written, or left by a
  // killed writer, is shared read-only with its write-ahead files, or read from a private copy
  // (removed with the reader) when they cannot be shared. Throws MatchLogError naming the file and
  // what is wrong (missing, not a database, not a match log, another schema version, damaged).
  explicit MatchLogReader(const std::string& folder);
  ~MatchLogReader();
  MatchLogReader(const MatchLogReader&) = delete;
  MatchLogReader& operator=(const MatchLogReader&) = delete;

  const std::string& folder() const { return folder_; }
  const RunInfo& run() const { return run_; }
  // Everything but the depth, in the order it was logged; with after_seq, only what was logged
  // after that place (a reader following a log as it grows). last_seq: set to the newest place read
  // (depth included), to pass as after_seq next time. One consistent snapshot of the log.
  std::vector<fw::JournalEntry> entries(std::int64_t after_seq = 0, std::int64_t* last_seq = nullptr) const;
  // The depth plugins that recorded depth, and how many frames each.
  std::vector<std::pair<std::string, std::uint64_t>> depthSources() const;

  // Where each depth frame of one source sits in the log, without decoding it (for random access).
  struct DepthFrameStamp {
    std::int64_t seq;  // its place in the log
    std::uint64_t index;
    double source_time_s;
    double wall_time_s;
  };
  std::vector<DepthFrameStamp> depthFrameStamps(const std::string& source, std::int64_t after_seq = 0) const;
  // What the run took in from outside, in the order it arrived: each depth frame (with the plugin
  // that read it), omni image and robot pose, and when it was logged. What a replay plays.
  struct Input {
    enum class Kind { kDepth = 0, kOmni = 1, kPose = 2, kTeam = 3 } kind;
    std::string depth_source;  // kDepth: the plugin that read it
    double wall_time_s;
  };
  std::vector<Input> inputs() const;
  // A source's clock against the host's: the median of (source time - receive time) over its first
  // kClockOffsetFrames depth frames, else over its first balls; nothing when it logged neither. What
  // puts a source time on the log's wall-clock timeline (the match report, the viewer).
  static constexpr int kClockOffsetFrames = 30;
  std::optional<double> clockOffset_s(const std::string& source) const;
  // One depth frame by its seq. Throws MatchLogError naming it when it is missing or undecodable.
  fw::DepthImage depthFrame(std::int64_t seq) const;

  // The depth frames of one source in order, one at a time (a match's depth does not fit in memory).
  class DepthFrames {
   public:
    DepthFrames(const MatchLogReader& log, const std::string& source);
    ~DepthFrames();
    DepthFrames(const DepthFrames&) = delete;
    DepthFrames& operator=(const DepthFrames&) = delete;
    // The next frame and when it was logged; false at the end. Throws MatchLogError naming the
    // frame when its image cannot be decoded.
    bool next(fw::DepthImage& image, double& wall_time_s);

   private:
    const MatchLogReader& log_;
    std::string source_;
    std::unique_ptr<Statement> query_;
  };

 private:
  void open();
  [[noreturn]] void fail(const std::string& reason) const;
  // How this log's depth is encoded, and the columns of a depth frame with its colour image.
  DepthCodec depthCodec() const;
  std::string depthColumn() const;
  std::string depthColumns() const;
  // A depth_frame row's columns (depthColumns()) into image.
  void decodeDepthRow(Statement& row, fw::DepthImage& image, double& wall_time_s) const;
  // The colour columns of the same row; frame names the depth frame in errors.
  fw::ColourImage decodeColour(Statement& row, const std::string& frame) const;
  std::string path_;
  std::string folder_;
  sqlite3* db_ = nullptr;
  std::string private_copy_;  // a folder of ours to remove, when reading a copy
  RunInfo run_;
  int schema_ = kMatchLogSchemaVersion;  // of the log being read
};

}  // namespace fw
