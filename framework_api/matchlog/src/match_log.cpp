#include "matchlog/match_log.h"

#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <variant>

namespace fw {

namespace fs = std::filesystem;

// Every table but run has seq, the writer's count of publications: their order across tables.
// Frames (sensor, robot, field) are in the column names where a position has one.
constexpr const char* kSchema = R"sql(
CREATE TABLE run (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE ball (seq INTEGER NOT NULL, ball_index INTEGER NOT NULL, wall_time_s REAL NOT NULL,
  source TEXT NOT NULL, source_time_s REAL NOT NULL, receive_time_s REAL NOT NULL, frame TEXT NOT NULL,
  state TEXT NOT NULL, x_m REAL, y_m REAL, z_m REAL, cov_xx_m2 REAL, cov_xy_m2 REAL, cov_xz_m2 REAL,
  cov_yy_m2 REAL, cov_yz_m2 REAL, cov_zz_m2 REAL, support_points INTEGER, is_static INTEGER,
  colour_verdict TEXT NOT NULL, colour_note TEXT NOT NULL, colour_score REAL,
  PRIMARY KEY (seq, ball_index));
CREATE TABLE omni_frame (seq INTEGER PRIMARY KEY, wall_time_s REAL NOT NULL, source_time_s REAL NOT NULL,
  receive_time_s REAL NOT NULL);
CREATE TABLE omni_ball (seq INTEGER NOT NULL, ball_index INTEGER NOT NULL, source TEXT NOT NULL,
  bearing_rad REAL, distance_m REAL, bearing_sigma_rad REAL, distance_sigma_m REAL,
  PRIMARY KEY (seq, ball_index));
CREATE TABLE omni_robot (seq INTEGER NOT NULL, robot_index INTEGER NOT NULL, bearing_rad REAL, distance_m REAL,
  bearing_sigma_rad REAL, distance_sigma_m REAL, PRIMARY KEY (seq, robot_index));
CREATE TABLE trajectory (seq INTEGER PRIMARY KEY, wall_time_s REAL NOT NULL, source TEXT NOT NULL,
  lost INTEGER NOT NULL, time_s REAL, state TEXT, x_m REAL, y_m REAL, z_m REAL, vx_mps REAL, vy_mps REAL,
  vz_mps REAL, gravity_mps2 REAL, drag_per_m REAL, curve_radps REAL, rolling_decel_mps2 REAL,
  support INTEGER, rms_m REAL, touchdown_x_m REAL, touchdown_y_m REAL, touchdown_time_s REAL,
  touchdown_sigma_m REAL, crossing_x_m REAL, crossing_z_m REAL, crossing_time_s REAL);
CREATE TABLE fused_ball (seq INTEGER PRIMARY KEY, wall_time_s REAL NOT NULL, none INTEGER NOT NULL,
  source_time_s REAL, receive_time_s REAL, state TEXT, air_probability REAL,
  x_field_m REAL, y_field_m REAL, z_field_m REAL, vx_field_mps REAL, vy_field_mps REAL, vz_field_mps REAL,
  x_robot_m REAL, y_robot_m REAL, z_robot_m REAL, cov_xx_m2 REAL, cov_xy_m2 REAL, cov_xz_m2 REAL,
  cov_yy_m2 REAL, cov_yz_m2 REAL, cov_zz_m2 REAL, sources TEXT, age_s REAL, goal_line INTEGER,
  goal_crossing_x_m REAL, goal_crossing_z_m REAL, goal_crossing_time_s REAL, goal_crossing_sigma_m REAL,
  goal_crossing_time_sigma_s REAL);
CREATE TABLE robot_pose (seq INTEGER PRIMARY KEY, wall_time_s REAL NOT NULL, source_time_s REAL NOT NULL,
  receive_time_s REAL NOT NULL, x_m REAL, y_m REAL, theta_rad REAL, odometry_x_m REAL, odometry_y_m REAL,
  odometry_theta_rad REAL);
CREATE TABLE event (seq INTEGER PRIMARY KEY, wall_time_s REAL NOT NULL, source TEXT NOT NULL,
  kind TEXT NOT NULL, message TEXT NOT NULL, source_time_s REAL, receive_time_s REAL, value REAL);
CREATE TABLE health (seq INTEGER PRIMARY KEY, wall_time_s REAL NOT NULL, plugin TEXT NOT NULL,
  frames INTEGER, rate_hz REAL, processing_p50_s REAL, processing_p99_s REAL, dropped_frames INTEGER,
  errors INTEGER, stuck INTEGER, second_end_wall_time_s REAL, processing_total_s REAL, latency_p50_s REAL,
  latency_p99_s REAL);
CREATE TABLE depth_frame (seq INTEGER PRIMARY KEY, wall_time_s REAL NOT NULL, source TEXT NOT NULL,
  frame_index INTEGER NOT NULL, source_time_s REAL NOT NULL, receive_time_s REAL NOT NULL,
  width INTEGER NOT NULL, height INTEGER NOT NULL, fx REAL, fy REAL, cx REAL, cy REAL, depth BLOB NOT NULL,
  gravity_x_S_mps2 REAL, gravity_y_S_mps2 REAL, gravity_z_S_mps2 REAL);
CREATE INDEX depth_frame_by_source ON depth_frame (source, seq);
CREATE TABLE colour_frame (seq INTEGER PRIMARY KEY, source_time_s REAL NOT NULL, width INTEGER NOT NULL,
  height INTEGER NOT NULL, fx REAL, fy REAL, cx REAL, cy REAL, offset_x_S_m REAL, offset_y_S_m REAL,
  offset_z_S_m REAL, jpeg BLOB NOT NULL);
CREATE TABLE team_message (seq INTEGER PRIMARY KEY, wall_time_s REAL NOT NULL, team_id INTEGER NOT NULL,
  robot_id INTEGER NOT NULL, sequence INTEGER NOT NULL, receive_time_s REAL NOT NULL, clock_offset_s REAL NOT NULL,
  clock_offset_sigma_s REAL NOT NULL, body BLOB NOT NULL);
)sql";

struct Statement {
  Statement(sqlite3* db, const char* sql, const std::string& path) : path(path) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt, nullptr) != SQLITE_OK) {
      throw MatchLogError(path + ": " + sqlite3_errmsg(db));
    }
  }
  ~Statement() { sqlite3_finalize(stmt); }

  // Binds the values in order, runs the statement to its end, resets it.
  template <typename... Values>
  void run(const Values&... values) {
    int index = 0;
    (bindOne(++index, values), ...);
    const int result = sqlite3_step(stmt);
    sqlite3_reset(stmt);
    sqlite3_clear_bindings(stmt);
    if (result == SQLITE_CONSTRAINT) {
      throw MatchLogRefused(path + ": a publication not recorded: " + sqlite3_errstr(result) +
                            " (a time stamp that is not a number?)");
    }
    if (result != SQLITE_DONE) throw MatchLogError(path + ": " + sqlite3_errstr(result));
  }
  // Steps a query: true while it has a row.
  bool row() {
    const int result = sqlite3_step(stmt);
    if (result == SQLITE_ROW) return true;
    if (result == SQLITE_DONE) return false;
    throw MatchLogError(path + ": " + sqlite3_errstr(result));
  }
  double real(int column) const {
    return sqlite3_column_type(stmt, column) == SQLITE_NULL ? NAN : sqlite3_column_double(stmt, column);
  }
  std::int64_t integer(int column) const { return sqlite3_column_int64(stmt, column); }
  bool isNull(int column) const { return sqlite3_column_type(stmt, column) == SQLITE_NULL; }
  std::string text(int column) const {
    const auto* text = sqlite3_column_text(stmt, column);
    return text == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(text));
  }

  sqlite3_stmt* stmt = nullptr;
  std::string path;

 private:
  void bindOne(int index, double value) { sqlite3_bind_double(stmt, index, value); }
  void bindOne(int index, int value) { sqlite3_bind_int64(stmt, index, value); }
  void bindOne(int index, bool value) { sqlite3_bind_int64(stmt, index, value ? 1 : 0); }
  void bindOne(int index, std::int64_t value) { sqlite3_bind_int64(stmt, index, value); }
  void bindOne(int index, std::uint64_t value) { sqlite3_bind_int64(stmt, index, static_cast<std::int64_t>(value)); }
  void bindOne(int index, const std::string& value) {
    sqlite3_bind_text(stmt, index, value.data(), static_cast<int>(value.size()), SQLITE_TRANSIENT);
  }
  void bindOne(int index, const char* value) { sqlite3_bind_text(stmt, index, value, -1, SQLITE_TRANSIENT); }
  void bindOne(int index, const std::vector<unsigned char>& blob) {
    sqlite3_bind_blob(stmt, index, blob.data(), static_cast<int>(blob.size()), SQLITE_TRANSIENT);
  }
  // The encoders' bytes stay valid until run() ends: bound, not copied.
  void bindOne(int index, const DepthEncoder::Bytes& blob) {
    sqlite3_bind_blob(stmt, index, blob.data, static_cast<int>(blob.size), SQLITE_STATIC);
  }
  void bindOne(int index, const JpegEncoder::Bytes& blob) {
    sqlite3_bind_blob(stmt, index, blob.data, static_cast<int>(blob.size), SQLITE_STATIC);
  }
  void bindOne(int index, const std::optional<double>& value) {
    if (value) {
      sqlite3_bind_double(stmt, index, *value);
    } else {
      sqlite3_bind_null(stmt, index);
    }
  }
};

namespace {

template <class... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;

fw::Frame frameFrom(const std::string& text) {
  if (text == "sensor") return fw::Frame::kSensor;
  if (text == "field") return fw::Frame::kField;
  return fw::Frame::kRobot;
}
fw::BallState stateFrom(const std::string& text) {
  return text == "air" ? fw::BallState::kAir : fw::BallState::kGround;
}

std::string joined(const std::vector<std::string>& parts) {
  std::string text;
  for (const std::string& part : parts) text += (text.empty() ? "" : ",") + part;
  return text;
}
std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    parts.push_back(text.substr(start, comma - start));
    start = comma + 1;
  }
  return parts;
}

Eigen::Matrix3d symmetric(const Statement& q, int first) {
  Eigen::Matrix3d m;
  m << q.real(first), q.real(first + 1), q.real(first + 2), q.real(first + 1), q.real(first + 3), q.real(first + 4),
      q.real(first + 2), q.real(first + 4), q.real(first + 5);
  return m;
}

}  // namespace

std::set<std::string> entriesOf(const std::string& base) {
  std::set<std::string> entries;
  std::error_code error;
  for (const std::filesystem::directory_entry& entry : std::filesystem::directory_iterator(base, error)) {
    entries.insert(entry.path().string());
  }
  return entries;
}

std::optional<std::string> newRunIn(const std::string& base, const std::set<std::string>& before) {
  for (const std::string& entry : entriesOf(base)) {
    if (before.count(entry) != 0) continue;
    try {
      MatchLogReader check(entry);
      return entry;
    } catch (const MatchLogError&) {
      // not a log, or one still being created
    }
  }
  return std::nullopt;
}

std::string claimRunFolder(const std::string& base, const std::string& robot, double wall_time_s) {
  const std::time_t seconds = static_cast<std::time_t>(wall_time_s);
  std::tm local{};
  localtime_r(&seconds, &local);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%d_%H-%M-%S", &local);
  const fs::path name = fs::path(base) / (std::string(stamp) + "_" + robot);
  std::error_code error;
  fs::create_directories(base, error);
  if (error) throw MatchLogError(base + ": cannot create the log folder: " + error.message());
  // create_directory is atomic: of two runs asking for one name, exactly one gets it.
  constexpr int kMaxTries = 1000;
  for (int n = 1; n <= kMaxTries; ++n) {
    const fs::path folder = n == 1 ? name : fs::path(name.string() + "-" + std::to_string(n));
    if (fs::create_directory(folder, error)) return folder.string();
    if (error) throw MatchLogError(folder.string() + ": cannot create the run's folder: " + error.message());
  }
  throw MatchLogError(base + ": " + std::to_string(kMaxTries) + " runs of '" + robot + "' started within one second");
}

// ---------------------------------------------------------------------------------------------

MatchLogWriter::MatchLogWriter(const std::string& folder, const RunInfo& run, int colour_jpeg_quality)
    : folder_(folder), path_((fs::path(folder) / kMatchLogFile).string()), colour_encoder_([&] {
        if (colour_jpeg_quality < 1 || colour_jpeg_quality > 100) {
          throw MatchLogError(folder + ": a colour JPEG quality of " + std::to_string(colour_jpeg_quality) +
                              " (1 to 100)");
        }
        return colour_jpeg_quality;
      }()) {
  std::error_code error;
  fs::create_directories(folder, error);
  if (error) throw MatchLogError(folder + ": cannot create the log folder: " + error.message());
  if (fs::exists(path_)) throw MatchLogError(path_ + ": a log is already there; a run never writes over another");
  if (sqlite3_open_v2(path_.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) != SQLITE_OK) {
    const std::string reason = db_ != nullptr ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    throw MatchLogError(path_ + ": " + reason);
  }
  try {
    // WAL: a commit is one append, and a process killed mid-write leaves the last commit intact.
    // synchronous=NORMAL: the OS, not each commit, flushes to the device (a kill loses nothing
    // committed; a power cut may lose the last commits, never the database).
    exec("PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;");
    exec("BEGIN;");
    exec(kSchema);
    exec("PRAGMA user_version=" + std::to_string(kMatchLogSchemaVersion) + ";");
    Statement insert(db_, "INSERT INTO run (key, value) VALUES (?, ?)", path_);
    insert.run("robot", run.robot);
    insert.run("software_version", run.software_version);
    insert.run("config_yaml", run.config_yaml);
    insert.run("start_wall_time_s", std::to_string(run.start_wall_time_s));
    insert.run("replayed_from", run.replayed_from);
    exec("COMMIT;");
  } catch (...) {
    sqlite3_close(db_);
    throw;
  }
}

MatchLogWriter::~MatchLogWriter() {
  try {
    commit();
  } catch (const MatchLogError&) {
    // The disk refused the last batch; what was committed before stays readable.
  }
  statements_.clear();
  sqlite3_close(db_);
}

void MatchLogWriter::exec(const std::string& sql) {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string reason = message != nullptr ? message : sqlite3_errmsg(db_);
    sqlite3_free(message);
    throw MatchLogError(path_ + ": " + reason);
  }
}

void MatchLogWriter::begin() {
  if (in_batch_) return;
  exec("BEGIN;");
  in_batch_ = true;
}

void MatchLogWriter::commit() {
  if (!in_batch_) return;
  in_batch_ = false;  // a failed COMMIT leaves no transaction open either way
  char* message = nullptr;
  if (sqlite3_exec(db_, "COMMIT;", nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string reason = message != nullptr ? message : sqlite3_errmsg(db_);
    sqlite3_free(message);
    sqlite3_exec(db_, "ROLLBACK;", nullptr, nullptr, nullptr);
    throw MatchLogError(path_ + ": " + reason);
  }
}

Statement& MatchLogWriter::statement(const char* sql) {
  std::unique_ptr<Statement>& statement = statements_[sql];
  if (statement == nullptr) statement = std::make_unique<Statement>(db_, sql, path_);
  return *statement;
}

std::uint64_t MatchLogWriter::bytesOnDisk() const {
  std::uint64_t bytes = 0;
  for (const std::string& file : {path_, path_ + "-wal"}) {
    std::error_code error;
    const auto size = fs::file_size(file, error);
    if (!error) bytes += size;
  }
  return bytes;
}

bool MatchLogWriter::fileGone() const {
  std::error_code error;
  return !fs::exists(path_, error) && !error;
}

void MatchLogWriter::write(const fw::JournalEntry& entry) {
  begin();
  const std::int64_t seq = next_seq_++;
  const double wall = entry.wall_time_s;
  std::visit(
      Overloaded{
          [&](const fw::BallFrame& frame) {
            Statement& insert =
                statement("INSERT INTO ball VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
            for (std::size_t i = 0; i < frame.balls.size(); ++i) {
              const fw::BallObservation& b = frame.balls[i];
              const Eigen::Matrix3d& c = b.covariance_m2;
              insert.run(seq, static_cast<int>(i), wall, b.source, b.stamp.source_time_s, b.stamp.receive_time_s,
                         fw::toString(b.frame), fw::toString(b.state), b.position_m.x(), b.position_m.y(),
                         b.position_m.z(), c(0, 0), c(0, 1), c(0, 2), c(1, 1), c(1, 2), c(2, 2), b.support_points,
                         b.is_static, fw::toString(b.colour), fw::toString(b.colour_note), b.colour_score);
            }
          },
          [&](const fw::OmniFrame& frame) {
            statement("INSERT INTO omni_frame VALUES (?, ?, ?, ?)")
                .run(seq, wall, frame.stamp.source_time_s, frame.stamp.receive_time_s);
            Statement& insert = statement("INSERT INTO omni_ball VALUES (?, ?, ?, ?, ?, ?, ?)");
            for (std::size_t i = 0; i < frame.balls.size(); ++i) {
              const fw::OmniBallObservation& b = frame.balls[i];
              insert.run(seq, static_cast<int>(i), b.source, b.bearing_rad, b.distance_m, b.bearing_sigma_rad,
                         b.distance_sigma_m);
            }
            Statement& insert_robot = statement("INSERT INTO omni_robot VALUES (?, ?, ?, ?, ?, ?)");
            for (std::size_t i = 0; i < frame.robots.size(); ++i) {
              const fw::OmniRobotObservation& r = frame.robots[i];
              insert_robot.run(seq, static_cast<int>(i), r.bearing_rad, r.distance_m, r.bearing_sigma_rad,
                               r.distance_sigma_m);
            }
          },
          [&](const fw::BallTrajectory& t) {
            Statement& insert = statement(
                "INSERT INTO trajectory VALUES (?, ?, ?, 0, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, "
                "?, ?)");
            using Maybe = std::optional<double>;
            const auto& td = t.touchdown;
            const auto& cr = t.crossing;
            insert.run(seq, wall, t.source, t.time_s, fw::toString(t.state), t.position_m.x(), t.position_m.y(),
                       t.position_m.z(), t.velocity_mps.x(), t.velocity_mps.y(), t.velocity_mps.z(), t.gravity_mps2,
                       t.drag_per_m, t.curve_radps, t.rolling_decel_mps2, t.support, t.rms_m,
                       td ? Maybe(td->point_m.x()) : Maybe(), td ? Maybe(td->point_m.y()) : Maybe(),
                       td ? Maybe(td->time_s) : Maybe(), td ? Maybe(td->sigma_m) : Maybe(),
                       cr ? Maybe(cr->x_m) : Maybe(), cr ? Maybe(cr->z_m) : Maybe(), cr ? Maybe(cr->time_s) : Maybe());
          },
          [&](const fw::TrajectoryCleared& cleared) {
            statement("INSERT INTO trajectory (seq, wall_time_s, source, lost) VALUES (?, ?, ?, 1)")
                .run(seq, wall, cleared.source);
          },
          [&](const fw::FusedBall& b) {
            const Eigen::Matrix3d& c = b.covariance_F;
            using Maybe = std::optional<double>;
            const auto& g = b.goal_crossing;
            statement(
                "INSERT INTO fused_ball VALUES (?, ?, 0, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, "
                "?, ?, ?, ?, ?, ?, ?)")
                .run(seq, wall, b.stamp.source_time_s, b.stamp.receive_time_s, fw::toString(b.state), b.air_probability,
                     b.position_F.x(), b.position_F.y(), b.position_F.z(), b.velocity_F.x(), b.velocity_F.y(),
                     b.velocity_F.z(), b.position_R.x(), b.position_R.y(), b.position_R.z(), c(0, 0), c(0, 1), c(0, 2),
                     c(1, 1), c(1, 2), c(2, 2), joined(b.sources), b.age_s, g ? Maybe(g->goal) : Maybe(),
                     g ? Maybe(g->x_m) : Maybe(), g ? Maybe(g->z_m) : Maybe(), g ? Maybe(g->time_s) : Maybe(),
                     g ? Maybe(g->sigma_m) : Maybe(), g ? Maybe(g->time_sigma_s) : Maybe());
          },
          [&](const fw::FusedBallCleared& none) {
            statement(
                "INSERT INTO fused_ball (seq, wall_time_s, none, source_time_s, receive_time_s) VALUES (?, ?, 1, ?, ?)")
                .run(seq, wall, none.stamp.source_time_s, none.stamp.receive_time_s);
          },
          [&](const fw::RobotPose& p) {
            using Maybe = std::optional<double>;
            const auto& o = p.odometry;
            statement("INSERT INTO robot_pose VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?)")
                .run(seq, wall, p.stamp.source_time_s, p.stamp.receive_time_s, p.x_m, p.y_m, p.theta_rad,
                     o ? Maybe(o->x_m) : Maybe(), o ? Maybe(o->y_m) : Maybe(), o ? Maybe(o->theta_rad) : Maybe());
          },
          [&](const fw::DepthImage& image) {
            const auto refused = [&](const std::string& why) {
              return MatchLogRefused(path_ + ": a depth image of " + image.source + " (frame " +
                                     std::to_string(image.index) + ") not recorded: " + why);
            };
            // The codecs read width x height pixels: an image that holds fewer is refused whole.
            const auto holds = [](std::size_t values, int width, int height, std::size_t per_pixel) {
              return width > 0 && height > 0 && values == static_cast<std::size_t>(width) * height * per_pixel;
            };
            if (!holds(image.depth_mm.size(), image.width, image.height, 1) ||
                (image.colour && !holds(image.colour->rgb.size(), image.colour->width, image.colour->height, 3))) {
              throw refused("its pixels do not fill its size");
            }
            // The colour is encoded before anything is inserted, so that a frame is recorded whole or
            // not at all; a failure (out of memory) refuses this frame, not the rest of the batch.
            JpegEncoder::Bytes jpeg{nullptr, 0};
            if (image.colour) {
              try {
                jpeg = colour_encoder_.encode(image.colour->rgb.data(), image.colour->width, image.colour->height);
              } catch (const ColourCodecError& e) {
                throw refused(e.what());
              }
            }
            const DepthEncoder::Bytes depth = depth_encoder_.encode(image.depth_mm.data(), image.width, image.height);
            const auto gravity = [&](int axis) {
              return image.gravity_S_mps2 ? std::optional<double>((*image.gravity_S_mps2)[axis]) : std::nullopt;
            };
            statement("INSERT INTO depth_frame VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)")
                .run(seq, wall, image.source, image.index, image.stamp.source_time_s, image.stamp.receive_time_s,
                     image.width, image.height, image.fx, image.fy, image.cx, image.cy, depth, gravity(0), gravity(1),
                     gravity(2));
            if (image.colour) {
              const fw::ColourImage& colour = *image.colour;
              statement("INSERT INTO colour_frame VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)")
                  .run(seq, colour.source_time_s, colour.width, colour.height, colour.fx, colour.fy, colour.cx,
                       colour.cy, colour.offset_S_m.x(), colour.offset_S_m.y(), colour.offset_S_m.z(), jpeg);
            }
          },
          [&](const fw::Event& e) {
            statement("INSERT INTO event VALUES (?, ?, ?, ?, ?, ?, ?, ?)")
                .run(seq, wall, e.source, e.kind, e.message, e.stamp.source_time_s, e.stamp.receive_time_s, e.value);
          },
          [&](const fw::PluginHealth& h) {
            const auto reported = [](double seconds) {  // NaN: the plugin reports none
              return std::isnan(seconds) ? std::nullopt : std::optional<double>(seconds);
            };
            statement("INSERT INTO health VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)")
                .run(seq, wall, h.plugin, h.frames, h.rate_hz, h.processing_p50_s, h.processing_p99_s, h.dropped_frames,
                     h.errors, h.stuck, h.wall_time_s, h.processing_total_s, reported(h.latency_p50_s),
                     reported(h.latency_p99_s));
          },
          [&](const fw::TeamMessage& m) {
            const std::string body = fw::packTeamMessage(m);
            statement("INSERT INTO team_message VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)")
                .run(seq, wall, m.team_id, m.robot_id, static_cast<std::int64_t>(m.sequence), m.receive_time_s,
                     m.clock_offset_s, m.clock_offset_sigma_s, std::vector<unsigned char>(body.begin(), body.end()));
          },
      },
      entry.item);
}

// ---------------------------------------------------------------------------------------------

MatchLogReader::MatchLogReader(const std::string& folder)
    : path_((fs::path(folder) / kMatchLogFile).string()), folder_(folder) {
  if (!fs::is_regular_file(path_)) {
    throw MatchLogError(
        path_ + ": no match log here (" +
        (fs::is_directory(folder) ? "the folder has no " + std::string(kMatchLogFile) : std::string("no such folder")) +
        ")");
  }
  try {
    open();
    Statement version(db_, "PRAGMA user_version", path_);
    version.row();
    const std::int64_t schema = version.integer(0);
    Statement tables(db_, "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'run'", path_);
    tables.row();
    if (tables.integer(0) == 0) fail("not a match log (no 'run' table)");
    if (schema < kOldestReadableSchemaVersion || schema > kMatchLogSchemaVersion) {
      fail("schema version " + std::to_string(schema) + ", this program reads versions " +
           std::to_string(kOldestReadableSchemaVersion) + " to " + std::to_string(kMatchLogSchemaVersion));
    }
    schema_ = static_cast<int>(schema);
    Statement integrity(db_, "PRAGMA quick_check", path_);
    integrity.row();
    if (integrity.text(0) != "ok") fail("damaged: " + integrity.text(0));
    Statement run(db_, "SELECT key, value FROM run", path_);
    while (run.row()) {
      const std::string key = run.text(0), value = run.text(1);
      if (key == "robot") run_.robot = value;
      if (key == "software_version") run_.software_version = value;
      if (key == "config_yaml") run_.config_yaml = value;
      if (key == "start_wall_time_s") run_.start_wall_time_s = std::atof(value.c_str());
      if (key == "replayed_from") run_.replayed_from = value;
    }
  } catch (const MatchLogError& e) {
    sqlite3_close(db_);
    db_ = nullptr;
    if (!private_copy_.empty()) {
      std::error_code ignored;
      fs::remove_all(private_copy_, ignored);
    }
    const std::string what = e.what();
    // SQLite's own messages ("file is not a database") get the file in front, ours have it already.
    throw MatchLogError(what.rfind(path_, 0) == 0 ? what : path_ + ": " + what);
  }
}

namespace {

bool nonEmptyFile(const fs::path& path) {
  std::error_code error;
  return fs::file_size(path, error) > 0 && !error;
}

// path as an SQLite URI ("file:/logs/a%3Fb/match.sqlite").
std::string fileUri(const std::string& path) {
  std::string uri = "file:";
  for (const char c : path) {
    if (c == '%' || c == '?' || c == '#') {
      char escaped[4];
      std::snprintf(escaped, sizeof escaped, "%%%02X", static_cast<unsigned char>(c));
      uri += escaped;
    } else {
      uri += c;
    }
  }
  return uri;
}

}  // namespace

void MatchLogReader::open() {
  const auto tryOpen = [&](const std::string& name, int flags) {
    if (sqlite3_open_v2(name.c_str(), &db_, flags, nullptr) == SQLITE_OK &&
        sqlite3_exec(db_, "SELECT count(*) FROM sqlite_master", nullptr, nullptr, nullptr) == SQLITE_OK) {
      return std::string();
    }
    const std::string reason = db_ != nullptr ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    return reason;
  };
  // A log closed cleanly has no write-ahead file: read as immutable, SQLite writes nothing anywhere
  // (a read-only medium, another user's folder, a folder the reader must leave as it found it).
  const fs::path wal = path_ + "-wal", shm = path_ + "-shm";
  std::string reason;
  if (!nonEmptyFile(wal)) {
    reason = tryOpen(fileUri(path_) + "?immutable=1", SQLITE_OPEN_READONLY | SQLITE_OPEN_URI);
    if (reason.empty()) return;
    throw MatchLogError(path_ + ": " + reason);
  }
  // Being written (a robot running), or left by a writer that was killed: with both of its files
  // there, a read-only reader shares them and adds none.
  if (fs::exists(shm)) {
    reason = tryOpen(path_, SQLITE_OPEN_READONLY);
    if (reason.empty()) return;
  }
  // Else (a -shm missing, or not to be read here) a private copy of the database and its
  // write-ahead file, in which SQLite may recover what the writer committed.
  std::string folder = (fs::temp_directory_path() / "kinect3d_log_XXXXXX").string();
  if (mkdtemp(folder.data()) == nullptr) throw MatchLogError(path_ + ": cannot make a private copy to read");
  private_copy_ = folder;
  std::error_code error;
  const fs::path copy = fs::path(folder) / kMatchLogFile;
  fs::copy_file(path_, copy, error);
  if (!error) fs::copy_file(wal, copy.string() + "-wal", error);
  if (error) throw MatchLogError(path_ + ": cannot make a private copy to read: " + error.message());
  reason = tryOpen(copy.string(), SQLITE_OPEN_READWRITE);
  if (!reason.empty()) throw MatchLogError(path_ + ": " + reason);
}

MatchLogReader::~MatchLogReader() {
  sqlite3_close(db_);
  if (!private_copy_.empty()) {
    std::error_code ignored;
    fs::remove_all(private_copy_, ignored);
  }
}

void MatchLogReader::fail(const std::string& reason) const { throw MatchLogError(path_ + ": " + reason); }

std::vector<fw::JournalEntry> MatchLogReader::entries(std::int64_t after_seq, std::int64_t* last_seq) const {
  // One read transaction: every table as of one commit, however the writer goes on meanwhile.
  struct Snapshot {
    explicit Snapshot(sqlite3* db) : db(db) { sqlite3_exec(db, "BEGIN", nullptr, nullptr, nullptr); }
    ~Snapshot() { sqlite3_exec(db, "COMMIT", nullptr, nullptr, nullptr); }
    sqlite3* db;
  } snapshot(db_);
  // Each query, of the rows after after_seq.
  const auto query = [&](const std::string& sql) {
    auto q = std::make_unique<Statement>(db_, sql.c_str(), path_);
    sqlite3_bind_int64(q->stmt, 1, after_seq);
    return q;
  };
  std::map<std::int64_t, fw::JournalEntry> by_seq;
  {
    const auto ball = query(
        "SELECT seq, wall_time_s, source, source_time_s, receive_time_s, frame, state, x_m, y_m, z_m, "
        "cov_xx_m2, cov_xy_m2, cov_xz_m2, cov_yy_m2, cov_yz_m2, cov_zz_m2, support_points, is_static" +
        std::string(schema_ >= 3 ? ", colour_verdict, colour_note, colour_score" : "") +
        " FROM ball WHERE seq > ? ORDER BY seq, ball_index");
    Statement& q = *ball;
    while (q.row()) {
      fw::JournalEntry& entry = by_seq[q.integer(0)];
      if (!std::holds_alternative<fw::BallFrame>(entry.item)) entry.item = fw::BallFrame{};
      entry.wall_time_s = q.real(1);
      auto& frame = std::get<fw::BallFrame>(entry.item);
      fw::BallObservation b;
      b.source = q.text(2);
      b.stamp = {q.real(3), q.real(4)};
      b.frame = frameFrom(q.text(5));
      b.state = stateFrom(q.text(6));
      b.position_m = {q.real(7), q.real(8), q.real(9)};
      b.covariance_m2 = symmetric(q, 10);
      b.support_points = static_cast<int>(q.integer(16));
      b.is_static = q.integer(17) != 0;
      if (schema_ >= 3) {  // version 2 logs were written before the colour check: not checked
        try {
          b.colour = fw::colourVerdictFrom(q.text(18));
          b.colour_note = fw::colourNoteFrom(q.text(19));
        } catch (const std::invalid_argument& e) {
          fail(std::string("ball row of seq ") + std::to_string(q.integer(0)) + ": " + e.what());
        }
        b.colour_score = q.real(20);
      }
      if (frame.balls.empty()) {
        frame.stamp = b.stamp;
        frame.source = b.source;
      }
      frame.balls.push_back(b);
    }
  }
  {
    const auto frames = query("SELECT seq, wall_time_s, source_time_s, receive_time_s FROM omni_frame WHERE seq > ?");
    Statement& q = *frames;
    while (q.row()) by_seq[q.integer(0)] = {q.real(1), fw::OmniFrame{{q.real(2), q.real(3)}, {}, {}}};
    const auto omni_balls = query(
        "SELECT seq, source, bearing_rad, distance_m, bearing_sigma_rad, distance_sigma_m FROM omni_ball "
        "WHERE seq > ? ORDER BY seq, ball_index");
    Statement& balls = *omni_balls;
    while (balls.row()) {
      auto found = by_seq.find(balls.integer(0));
      if (found == by_seq.end() || !std::holds_alternative<fw::OmniFrame>(found->second.item)) {
        fail("omni_ball row " + std::to_string(balls.integer(0)) + " has no omni_frame");
      }
      auto& frame = std::get<fw::OmniFrame>(found->second.item);
      fw::OmniBallObservation b;
      b.source = balls.text(1);
      frame.source = b.source;  // the log keeps it with each ball
      b.bearing_rad = balls.real(2);
      b.distance_m = balls.real(3);
      b.bearing_sigma_rad = balls.real(4);
      b.distance_sigma_m = balls.real(5);
      b.stamp = frame.stamp;
      frame.balls.push_back(b);
    }
    if (schema_ >= 9) {  // version 9 added the robots the omni camera saw
      const auto omni_robots = query(
          "SELECT seq, bearing_rad, distance_m, bearing_sigma_rad, distance_sigma_m FROM omni_robot WHERE seq > ? "
          "ORDER BY seq, robot_index");
      Statement& robots = *omni_robots;
      while (robots.row()) {
        auto found = by_seq.find(robots.integer(0));
        if (found == by_seq.end() || !std::holds_alternative<fw::OmniFrame>(found->second.item)) {
          fail("omni_robot row " + std::to_string(robots.integer(0)) + " has no omni_frame");
        }
        fw::OmniRobotObservation robot;
        robot.bearing_rad = robots.real(1);
        robot.distance_m = robots.real(2);
        robot.bearing_sigma_rad = robots.real(3);
        robot.distance_sigma_m = robots.real(4);
        std::get<fw::OmniFrame>(found->second.item).robots.push_back(robot);
      }
    }
  }
  {
    const auto trajectories = query(
        "SELECT seq, wall_time_s, source, lost, time_s, state, x_m, y_m, z_m, vx_mps, vy_mps, vz_mps, "
        "gravity_mps2, drag_per_m, curve_radps, rolling_decel_mps2, support, rms_m, touchdown_x_m, "
        "touchdown_y_m, touchdown_time_s, touchdown_sigma_m, crossing_x_m, crossing_z_m, crossing_time_s "
        "FROM trajectory WHERE seq > ?");
    Statement& q = *trajectories;
    while (q.row()) {
      fw::JournalEntry& entry = by_seq[q.integer(0)];
      entry.wall_time_s = q.real(1);
      if (q.integer(3) != 0) {
        entry.item = fw::TrajectoryCleared{q.text(2)};
        continue;
      }
      fw::BallTrajectory t;
      t.source = q.text(2);
      t.time_s = q.real(4);
      t.state = stateFrom(q.text(5));
      t.position_m = {q.real(6), q.real(7), q.real(8)};
      t.velocity_mps = {q.real(9), q.real(10), q.real(11)};
      t.gravity_mps2 = q.real(12);
      t.drag_per_m = q.real(13);
      t.curve_radps = q.real(14);
      t.rolling_decel_mps2 = q.real(15);
      t.support = static_cast<int>(q.integer(16));
      t.rms_m = q.real(17);
      if (!q.isNull(18)) t.touchdown = fw::Touchdown{{q.real(18), q.real(19)}, q.real(20), q.real(21)};
      if (!q.isNull(22)) t.crossing = fw::LineCrossing{q.real(22), q.real(23), q.real(24)};
      entry.item = t;
    }
  }
  {
    const auto fused = query(
        "SELECT seq, wall_time_s, none, source_time_s, receive_time_s, state, air_probability, x_field_m, "
        "y_field_m, z_field_m, vx_field_mps, vy_field_mps, vz_field_mps, x_robot_m, y_robot_m, z_robot_m, "
        "cov_xx_m2, cov_xy_m2, cov_xz_m2, cov_yy_m2, cov_yz_m2, cov_zz_m2, sources, age_s" +
        std::string(schema_ >= 7 ? ", goal_line, goal_crossing_x_m, goal_crossing_z_m, goal_crossing_time_s, "
                                   "goal_crossing_sigma_m, goal_crossing_time_sigma_s"
                                 : "") +
        " FROM fused_ball WHERE seq > ?");
    Statement& q = *fused;
    while (q.row()) {
      fw::JournalEntry& entry = by_seq[q.integer(0)];
      entry.wall_time_s = q.real(1);
      if (q.integer(2) != 0) {
        // Version 5 and older logs keep no time with it, and only the updates after one with a ball.
        entry.item = fw::FusedBallCleared{{q.isNull(3) ? 0.0 : q.real(3), q.isNull(4) ? 0.0 : q.real(4)}};
        continue;
      }
      fw::FusedBall b;
      b.stamp = {q.real(3), q.real(4)};
      b.state = stateFrom(q.text(5));
      b.air_probability = q.real(6);
      b.position_F = {q.real(7), q.real(8), q.real(9)};
      b.velocity_F = {q.real(10), q.real(11), q.real(12)};
      b.position_R = {q.real(13), q.real(14), q.real(15)};
      b.covariance_F = symmetric(q, 16);
      b.sources = split(q.text(22));
      b.age_s = q.real(23);
      if (schema_ >= 7 && !q.isNull(24)) {  // version 7 added the goal-line crossing
        b.goal_crossing = fw::GoalCrossing{
            static_cast<int>(q.integer(24)), q.real(25), q.real(26), q.real(27), q.real(28), q.real(29)};
      }
      entry.item = b;
    }
  }
  {
    const auto poses = query("SELECT seq, wall_time_s, source_time_s, receive_time_s, x_m, y_m, theta_rad" +
                             std::string(schema_ >= 8 ? ", odometry_x_m, odometry_y_m, odometry_theta_rad" : "") +
                             " FROM robot_pose WHERE seq > ?");
    Statement& q = *poses;
    while (q.row()) {
      fw::RobotPose pose{q.real(4), q.real(5), q.real(6), {q.real(2), q.real(3)}, std::nullopt};
      if (schema_ >= 8 && !q.isNull(7)) {  // version 8 added the wheels' odometry
        pose.odometry = fw::RobotPose::Odometry{q.real(7), q.real(8), q.real(9)};
      }
      by_seq[q.integer(0)] = {q.real(1), pose};
    }
  }
  {
    const auto events = query("SELECT seq, wall_time_s, source, kind, message, source_time_s, receive_time_s" +
                              std::string(schema_ >= 6 ? ", value" : "") + " FROM event WHERE seq > ?");
    Statement& q = *events;
    while (q.row()) {
      fw::Event event{q.text(2), q.text(3), q.text(4), {q.real(5), q.real(6)}, std::nullopt};
      if (schema_ >= 6 && !q.isNull(7)) event.value = q.real(7);
      by_seq[q.integer(0)] = {q.real(1), event};
    }
  }
  {
    // Version 5 added each second's total processing time and the latency.
    const auto health = query(
        "SELECT seq, wall_time_s, plugin, frames, rate_hz, processing_p50_s, processing_p99_s, dropped_frames, errors, "
        "stuck, second_end_wall_time_s" +
        std::string(schema_ >= 5 ? ", processing_total_s, latency_p50_s, latency_p99_s" : "") +
        " FROM health WHERE seq > ?");
    Statement& q = *health;
    while (q.row()) {
      fw::PluginHealth h;
      h.plugin = q.text(2);
      h.frames = static_cast<std::uint64_t>(q.integer(3));
      h.rate_hz = q.real(4);
      h.processing_p50_s = q.real(5);
      h.processing_p99_s = q.real(6);
      h.dropped_frames = static_cast<std::uint64_t>(q.integer(7));
      h.errors = static_cast<std::uint64_t>(q.integer(8));
      h.stuck = static_cast<std::uint64_t>(q.integer(9));
      h.wall_time_s = q.real(10);
      if (schema_ >= 5) {
        h.processing_total_s = q.real(11);
        h.latency_p50_s = q.real(12);
        h.latency_p99_s = q.real(13);
      }
      by_seq[q.integer(0)] = {q.real(1), h};
    }
  }
  if (schema_ >= 4) {  // version 4 added the teammates' messages
    const auto messages = query(
        "SELECT seq, wall_time_s, team_id, robot_id, sequence, receive_time_s, clock_offset_s, clock_offset_sigma_s, "
        "body FROM team_message WHERE seq > ?");
    Statement& q = *messages;
    while (q.row()) {
      const auto* body = static_cast<const std::uint8_t*>(sqlite3_column_blob(q.stmt, 8));
      fw::TeamMessage m;
      try {
        m = fw::unpackTeamMessage(body, static_cast<std::size_t>(sqlite3_column_bytes(q.stmt, 8)));
      } catch (const fw::TeamMessageError& e) {
        fail("team_message row of seq " + std::to_string(q.integer(0)) + ": " + e.what());
      }
      m.team_id = static_cast<int>(q.integer(2));
      m.robot_id = static_cast<int>(q.integer(3));
      m.sequence = static_cast<std::uint64_t>(q.integer(4));
      m.receive_time_s = q.real(5);
      m.clock_offset_s = q.real(6);
      m.clock_offset_sigma_s = q.real(7);
      by_seq[q.integer(0)] = {q.real(1), m};
    }
  }
  if (last_seq != nullptr) {
    const auto latest = query(
        "SELECT max(seq) FROM (SELECT seq FROM ball WHERE seq > ?1 UNION ALL "
        "SELECT seq FROM omni_frame WHERE seq > ?1 UNION ALL SELECT seq FROM trajectory WHERE "
        "seq > ?1 UNION ALL SELECT seq FROM fused_ball WHERE seq > ?1 UNION ALL SELECT seq FROM "
        "robot_pose WHERE seq > ?1 UNION ALL SELECT seq FROM event WHERE seq > ?1 UNION ALL "
        "SELECT seq FROM health WHERE seq > ?1 UNION ALL SELECT seq FROM depth_frame WHERE seq > ?1" +
        std::string(schema_ >= 4 ? " UNION ALL SELECT seq FROM team_message WHERE seq > ?1)" : ")"));
    *last_seq = latest->row() && !latest->isNull(0) ? latest->integer(0) : after_seq;
  }
  std::vector<fw::JournalEntry> entries;
  entries.reserve(by_seq.size());
  for (auto& [seq, entry] : by_seq) entries.push_back(std::move(entry));
  return entries;
}

std::vector<std::pair<std::string, std::uint64_t>> MatchLogReader::depthSources() const {
  Statement q(db_, "SELECT source, count(*) FROM depth_frame GROUP BY source ORDER BY source", path_);
  std::vector<std::pair<std::string, std::uint64_t>> sources;
  while (q.row()) sources.emplace_back(q.text(0), static_cast<std::uint64_t>(q.integer(1)));
  return sources;
}

namespace {
constexpr const char* kDepthTables = " FROM depth_frame d LEFT JOIN colour_frame c ON c.seq = d.seq ";
constexpr int kDepthSourceColumn = 26;  // d.source, after depthColumns()
}  // namespace

// A depth frame's row with its colour image's, when it has one.
std::string MatchLogReader::depthColumns() const {
  return std::string(
             "d.seq, d.wall_time_s, d.frame_index, d.source_time_s, d.receive_time_s, d.width, d.height, d.fx, "
             "d.fy, d.cx, d.cy, ") +
         depthColumn() +
         ", d.gravity_x_S_mps2, d.gravity_y_S_mps2, d.gravity_z_S_mps2, c.source_time_s, c.width, c.height, c.fx, "
         "c.fy, c.cx, c.cy, c.offset_x_S_m, c.offset_y_S_m, c.offset_z_S_m, c.jpeg";
}

DepthCodec MatchLogReader::depthCodec() const {
  if (schema_ >= 10) return DepthCodec::kZstdPalette;
  return schema_ >= 5 ? DepthCodec::kZstdRowDelta : DepthCodec::kPng;
}

// Named by its codec until version 10, which names it depth and says the codec by its version.
std::string MatchLogReader::depthColumn() const {
  switch (depthCodec()) {
    case DepthCodec::kZstdPalette:
      return "d.depth";
    case DepthCodec::kZstdRowDelta:
      return "d.depth_zstd";
    case DepthCodec::kPng:
      break;
  }
  return "d.png";
}

MatchLogReader::DepthFrames::DepthFrames(const MatchLogReader& log, const std::string& source)
    : log_(log),
      source_(source),
      query_(std::make_unique<Statement>(
          log.db_, ("SELECT " + log.depthColumns() + kDepthTables + "WHERE d.source = ? ORDER BY d.seq").c_str(),
          log.path_)) {
  sqlite3_bind_text(query_->stmt, 1, source.c_str(), -1, SQLITE_TRANSIENT);
}

MatchLogReader::DepthFrames::~DepthFrames() = default;

bool MatchLogReader::DepthFrames::next(fw::DepthImage& image, double& wall_time_s) {
  if (!query_->row()) return false;
  log_.decodeDepthRow(*query_, image, wall_time_s);
  image.source = source_;
  return true;
}

std::vector<MatchLogReader::DepthFrameStamp> MatchLogReader::depthFrameStamps(const std::string& source,
                                                                              std::int64_t after_seq) const {
  Statement q(db_,
              "SELECT seq, frame_index, source_time_s, wall_time_s FROM depth_frame WHERE source = ? AND seq > ? "
              "ORDER BY seq",
              path_);
  sqlite3_bind_text(q.stmt, 1, source.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_int64(q.stmt, 2, after_seq);
  std::vector<DepthFrameStamp> stamps;
  while (q.row()) stamps.push_back({q.integer(0), static_cast<std::uint64_t>(q.integer(1)), q.real(2), q.real(3)});
  return stamps;
}

std::optional<double> MatchLogReader::clockOffset_s(const std::string& source) const {
  for (const char* table : {"depth_frame", "ball"}) {
    Statement q(
        db_,
        (std::string("SELECT source_time_s - receive_time_s FROM ") + table + " WHERE source = ? ORDER BY seq LIMIT ?")
            .c_str(),
        path_);
    sqlite3_bind_text(q.stmt, 1, source.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_int(q.stmt, 2, kClockOffsetFrames);
    std::vector<double> offsets_s;
    while (q.row()) offsets_s.push_back(q.real(0));
    if (!offsets_s.empty()) return fw::quantile(offsets_s, 0.5);
  }
  return std::nullopt;
}

std::vector<MatchLogReader::Input> MatchLogReader::inputs() const {
  const std::string team = schema_ >= 4 ? " UNION ALL SELECT seq, wall_time_s, 3, '' FROM team_message" : "";
  Statement q(db_,
              ("SELECT seq, wall_time_s, 0, source FROM depth_frame UNION ALL SELECT seq, wall_time_s, 1, '' FROM "
               "omni_frame UNION ALL SELECT seq, wall_time_s, 2, '' FROM robot_pose" +
               team + " ORDER BY seq")
                  .c_str(),
              path_);
  std::vector<Input> inputs;
  while (q.row()) inputs.push_back({static_cast<Input::Kind>(q.integer(2)), q.text(3), q.real(1)});
  return inputs;
}

fw::DepthImage MatchLogReader::depthFrame(std::int64_t seq) const {
  Statement q(db_, ("SELECT " + depthColumns() + ", d.source" + kDepthTables + "WHERE d.seq = ?").c_str(), path_);
  sqlite3_bind_int64(q.stmt, 1, seq);
  if (!q.row()) fail("no depth frame at seq " + std::to_string(seq));
  fw::DepthImage image;
  double wall_time_s = 0.0;
  decodeDepthRow(q, image, wall_time_s);
  image.source = q.text(kDepthSourceColumn);
  return image;
}

void MatchLogReader::decodeDepthRow(Statement& q, fw::DepthImage& image, double& wall_time_s) const {
  wall_time_s = q.real(1);
  image.index = static_cast<std::uint64_t>(q.integer(2));
  image.stamp = {q.real(3), q.real(4)};
  image.width = static_cast<int>(q.integer(5));
  image.height = static_cast<int>(q.integer(6));
  image.fx = q.real(7);
  image.fy = q.real(8);
  image.cx = q.real(9);
  image.cy = q.real(10);
  const auto* bytes = static_cast<const std::uint8_t*>(sqlite3_column_blob(q.stmt, 11));
  const int size = sqlite3_column_bytes(q.stmt, 11);
  const std::string frame =
      "depth frame " + std::to_string(image.index) + " (seq " + std::to_string(q.integer(0)) + ")";
  const auto within = [](int side) { return side >= DepthImage::kMinSide_px && side <= DepthImage::kMaxSide_px; };
  if (!within(image.width) || !within(image.height)) {
    fail(frame + ": " + std::to_string(image.width) + "x" + std::to_string(image.height) +
         " is no depth sensor's size (each side " + std::to_string(DepthImage::kMinSide_px) + " to " +
         std::to_string(DepthImage::kMaxSide_px) + " pixels)");
  }
  try {
    decodeDepth(depthCodec(), bytes, static_cast<std::size_t>(size), image.width, image.height, image.depth_mm);
  } catch (const DepthCodecError& e) {
    fail(frame + ": its depth is " + e.what());
  }
  image.gravity_S_mps2.reset();
  if (!q.isNull(12)) image.gravity_S_mps2 = Eigen::Vector3d(q.real(12), q.real(13), q.real(14));
  image.colour.reset();
  if (!q.isNull(15)) image.colour = decodeColour(q, frame);
}

fw::ColourImage MatchLogReader::decodeColour(Statement& q, const std::string& frame) const {
  fw::ColourImage colour;
  colour.source_time_s = q.real(15);
  colour.width = static_cast<int>(q.integer(16));
  colour.height = static_cast<int>(q.integer(17));
  colour.fx = q.real(18);
  colour.fy = q.real(19);
  colour.cx = q.real(20);
  colour.cy = q.real(21);
  colour.offset_S_m = {q.real(22), q.real(23), q.real(24)};
  const auto* bytes = static_cast<const unsigned char*>(sqlite3_column_blob(q.stmt, 25));
  const int size = sqlite3_column_bytes(q.stmt, 25);
  const auto within = [](int side) { return side >= DepthImage::kMinSide_px && side <= DepthImage::kMaxSide_px; };
  const std::string not_jpeg = frame + ": its colour image is not a " + std::to_string(colour.width) + "x" +
                               std::to_string(colour.height) + " colour JPEG";
  if (!within(colour.width) || !within(colour.height) || size <= 0) fail(not_jpeg);
  try {
    decodeJpeg(bytes, static_cast<std::size_t>(size), colour.width, colour.height, colour.rgb);
  } catch (const ColourCodecError& e) {
    fail(frame + ": its colour image is " + e.what());
  }
  return colour;
}

}  // namespace fw
