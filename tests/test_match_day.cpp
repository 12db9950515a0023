// Match day with bad luck: the robot plays whatever happens to its log (a folder it cannot create,
// a full disk, a file-size limit hit mid-run, its folder deleted under it, a restart within the same
// second), stops the same clean way on every terminating signal, and replays a log whose clocks
// jump, through the host and `kinect3d replay`, without a stall.
#include <gtest/gtest.h>
#include <sched.h>
#include <sys/mount.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <string>
#include <thread>

#include "demo_log.h"
#include "framework_api/host.h"
#include "host_process.h"
#include "match_view.h"
#include "matchlog/match_log.h"
#include "run_command.h"
#include "scoped_temp_dir.h"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

fw::Config demoConfig(std::vector<std::string> overrides) {
  overrides.insert(overrides.begin(), "host.plugins=[localisation, kinect3d, omni, fusion, logger]");
  return fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults",
                          std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml", overrides);
}

const fw::PluginSummary& summaryOf(const std::vector<fw::PluginSummary>& all, const std::string& name) {
  const auto found = std::find_if(all.begin(), all.end(), [&](const auto& s) { return s.name == name; });
  if (found == all.end()) throw std::runtime_error("no summary for " + name);
  return *found;
}

// The frames a depth plugin's source delivered, detected or dropped by the source (as a live
// sensor's are when the host is too busy to read them in time): every frame of the scene, however
// busy the machine.
std::uint64_t framesAccountedFor(const fw::PluginSummary& summary) { return summary.frames + summary.dropped_frames; }

// The run folders under base, oldest first (their names start with the date and time).
std::vector<std::string> runFolders(const fs::path& base) {
  std::vector<std::string> runs;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(base, error)) runs.push_back(entry.path().string());
  std::sort(runs.begin(), runs.end());
  return runs;
}

std::vector<fw::Event> eventsOf(const std::string& folder, const std::string& kind) {
  std::vector<fw::Event> events;
  for (const fw::Event& event : itemsOf<fw::Event>(fw::MatchLogReader(folder).entries())) {
    if (event.kind == kind) events.push_back(event);
  }
  return events;
}

// A path under a regular file: no folder can be made there, not even by root.
fs::path unwritable(const ScopedTempDir& dir) {
  const fs::path file = dir.path() / "a_file";
  std::ofstream(file) << "not a folder";
  return file / "logs";
}

TEST(MatchDay, ARobotWhoseLogFolderCannotBeCreatedPlaysAndRecordsIntoTheFallback) {
  ScopedTempDir dir;
  const fs::path fallback = dir.path() / "fallback";
  fw::Host host(
      demoConfig({"logger.folder=" + unwritable(dir).string(), "logger.fallback_folder=" + fallback.string()}),
      PRODUCT_PLUGIN_DIR);
  runUntilSourcesEnd(host);
  EXPECT_EQ(framesAccountedFor(summaryOf(host.summaries(), "kinect3d")), 105u) << "every frame detected";
  const std::vector<std::string> runs = runFolders(fallback);
  ASSERT_EQ(runs.size(), 1u);
  const std::vector<fw::Event> why = eventsOf(runs[0], "recording_fallback");
  ASSERT_EQ(why.size(), 1u);
  EXPECT_NE(why[0].message.find("cannot create the log folder"), std::string::npos) << why[0].message;
  const fw::MatchLogReader log(runs[0]);
  EXPECT_FALSE(itemsOf<fw::BallFrame>(log.entries()).empty()) << "the match is recorded";
  EXPECT_TRUE(log.depthSources().empty()) << "the fallback (RAM on most robots) takes no depth";
}

TEST(MatchDay, WithNowhereToRecordOrAFullDiskTheRobotStillPlays) {
  ScopedTempDir dir;
  for (const std::vector<std::string>& settings :
       {std::vector<std::string>{"logger.folder=" + unwritable(dir).string(), "logger.fallback_folder=''"},
        std::vector<std::string>{"logger.folder=" + (dir.path() / "logs").string(),
                                 "logger.fallback_folder=" + (dir.path() / "fallback").string(),
                                 "logger.min_free_mb=100000000"}}) {
    SCOPED_TRACE(settings.back());
    fw::Host host(demoConfig(settings), PRODUCT_PLUGIN_DIR);
    runUntilSourcesEnd(host);
    const auto summaries = host.summaries();
    EXPECT_EQ(framesAccountedFor(summaryOf(summaries, "kinect3d")), 105u);
    EXPECT_EQ(summaryOf(summaries, "logger").errors, 0u);
    EXPECT_GT(summaryOf(summaries, "fusion").frames, 0u);
    EXPECT_FALSE(host.world().recentBalls("kinect3d").empty()) << "the lob was seen";
  }
  EXPECT_TRUE(runFolders(dir.path() / "logs").empty()) << "a full disk gets no log at all";
  EXPECT_TRUE(runFolders(dir.path() / "fallback").empty());
}

TEST(MatchDay, RunsStartedWithinTheSameSecondGetFoldersOfTheirOwn) {
  ScopedTempDir dir;
  const double now_s = fw::wallClockNow_s();
  const std::string first = fw::claimRunFolder(dir.path().string(), "demo", now_s);
  const std::string second = fw::claimRunFolder(dir.path().string(), "demo", now_s);
  const std::string third = fw::claimRunFolder(dir.path().string(), "demo", now_s);
  EXPECT_EQ(second, first + "-2");
  EXPECT_EQ(third, first + "-3");
  // Two loggers writing there at once: each its own log.
  std::vector<std::thread> runs;
  for (int i = 0; i < 2; ++i) {
    runs.emplace_back(
        [&] { const fw::MatchLogWriter writer(fw::claimRunFolder(dir.path().string(), "twin", now_s), {}); });
  }
  for (std::thread& run : runs) run.join();
  EXPECT_EQ(runFolders(dir.path()).size(), 5u);
}

TEST(MatchDay, ALogFolderDeletedUnderTheRobotIsNoticedAndRecordingResumesElsewhere) {
  ScopedTempDir dir;
  const fs::path base = dir.path() / "logs";
  fw::Host host(demoConfig({"logger.folder=" + base.string()}), PRODUCT_PLUGIN_DIR);
  host.start();
  // Once the first batch is committed, the team's laptop deletes the folder (a careless rsync).
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  std::string first;
  while (Clock::now() < deadline && first.empty()) {
    const std::vector<std::string> runs = runFolders(base);
    std::error_code error;
    if (!runs.empty() && fs::file_size(fs::path(runs[0]) / "match.sqlite-wal", error) > 0 && !error) first = runs[0];
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    host.watch();
  }
  ASSERT_FALSE(first.empty()) << "the logger never committed a batch";
  fs::remove_all(first);
  while (!host.sourcesFinished() && Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    host.watch();
  }
  host.stop();
  EXPECT_EQ(framesAccountedFor(summaryOf(host.summaries(), "kinect3d")), 105u);
  const std::vector<std::string> runs = runFolders(base);
  ASSERT_EQ(runs.size(), 1u) << "a new log, the deleted one gone (in the same second it may take the same name)";
  const std::vector<fw::Event> resumed = eventsOf(runs[0], "recording_resumed");
  ASSERT_EQ(resumed.size(), 1u);
  EXPECT_NE(resumed[0].message.find("was deleted or moved while the robot wrote it"), std::string::npos)
      << resumed[0].message;
  EXPECT_NE(resumed[0].message.find(first), std::string::npos) << "it names where the match before was";
}

TEST(MatchDay, ADiskThatRefusesWritesMidRunIsSaidWhereRecordingResumes) {
  ScopedTempDir dir;
  const fs::path base = dir.path() / "logs";
  // A 2 MB file-size limit: the log's database is refused a write after a few dozen depth frames,
  // as a full disk would refuse it (min_free_mb 0: no early warning).
  HostProcess host(
      {"--robot", std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml", "--set",
       "host.plugins=[localisation, kinect3d, omni, fusion, logger]", "--set", "logger.min_free_mb=0", "--set",
       "logger.folder=" + base.string(), "--set", "logger.fallback_folder=" + (dir.path() / "fallback").string()},
      "ulimit -f 2048 &&");
  EXPECT_EQ(host.waitExit(std::chrono::seconds(120)), 0);
  const std::string out = host.readAll();
  EXPECT_NE(out.find("RECORDING STOPPED"), std::string::npos) << out;
  std::smatch summary;
  ASSERT_TRUE(std::regex_search(out, summary, std::regex(R"(kinect3d 0\.1\.0: (\d+) frames( \(and (\d+) dropped)?)")))
      << out;
  EXPECT_EQ(std::stoul(summary[1]) + (summary[3].matched ? std::stoul(summary[3]) : 0), 105u)
      << "every frame detected:\n"
      << out;
  const std::vector<std::string> runs = runFolders(base);
  ASSERT_GE(runs.size(), 2u) << out;
  const std::vector<fw::Event> resumed = eventsOf(runs[1], "recording_resumed");
  ASSERT_EQ(resumed.size(), 1u);
  EXPECT_NE(resumed[0].message.find("recording resumed"), std::string::npos) << resumed[0].message;
  EXPECT_NE(resumed[0].message.find(runs[0]), std::string::npos) << resumed[0].message;
}

TEST(MatchDay, SighupStopsTheRobotCleanlyWithItsLogClosed) {
  ScopedTempDir dir;
  const fs::path base = dir.path() / "logs";
  HostProcess host({"--robot", std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml", "--set",
                    "host.plugins=[localisation, kinect3d, omni, fusion, logger]", "--set",
                    "logger.folder=" + base.string()});
  ASSERT_TRUE(host.waitForOutput("sensor aligned with the floor"));
  host.signal(SIGHUP);
  EXPECT_EQ(host.waitExit(std::chrono::seconds(60)), 0);
  const std::string out = host.readAll();
  EXPECT_NE(out.find("Summary (SIGHUP)"), std::string::npos) << out;
  EXPECT_NE(out.find("log complete"), std::string::npos) << out;
  const std::vector<std::string> runs = runFolders(base);
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_FALSE(fs::exists(runs[0] + "/match.sqlite-wal")) << "the log was closed, not abandoned";
  EXPECT_FALSE(fs::exists(runs[0] + "/match.sqlite-shm"));
  EXPECT_NO_THROW(fw::MatchLogReader{runs[0]});
}

// A copy of log whose every stamp (depth, balls, omni images, poses) from its 30th depth frame on
// is moved by jump_s.
void copyWithClockJump(const std::string& log_folder, const std::string& copy_folder, double jump_s) {
  const fw::MatchLogReader log(log_folder);
  fw::MatchLogWriter copy(copy_folder, log.run());
  const std::vector<fw::MatchLogReader::DepthFrameStamp> depth = log.depthFrameStamps("kinect3d");
  const double jump_from_wall_s = depth.at(30).wall_time_s;
  const auto moved = [&](double wall_s, fw::Stamp& stamp) {
    if (wall_s >= jump_from_wall_s) stamp.source_time_s += jump_s;
  };
  std::vector<fw::JournalEntry> entries = log.entries();
  fw::MatchLogReader::DepthFrames frames(log, "kinect3d");
  fw::DepthImage image;
  double image_wall_s = 0.0;
  bool has_image = frames.next(image, image_wall_s);
  for (fw::JournalEntry& entry : entries) {
    while (has_image && image_wall_s <= entry.wall_time_s) {
      moved(image_wall_s, image.stamp);
      copy.write({image_wall_s, image});
      has_image = frames.next(image, image_wall_s);
    }
    if (auto* balls = std::get_if<fw::BallFrame>(&entry.item)) {
      moved(entry.wall_time_s, balls->stamp);
      for (fw::BallObservation& ball : balls->balls) moved(entry.wall_time_s, ball.stamp);
    } else if (auto* omni = std::get_if<fw::OmniFrame>(&entry.item)) {
      moved(entry.wall_time_s, omni->stamp);
    } else if (auto* pose = std::get_if<fw::RobotPose>(&entry.item)) {
      moved(entry.wall_time_s, pose->stamp);
    }
    copy.write(entry);
  }
  for (; has_image; has_image = frames.next(image, image_wall_s)) {
    moved(image_wall_s, image.stamp);
    copy.write({image_wall_s, image});
  }
  copy.commit();
}

TEST(MatchDay, ALogWhoseClocksJumpReplaysInTheHostAndInReplayWithoutAStall) {
  ScopedTempDir dir;
  runDemo((dir.path() / "live").string());
  const std::string live = onlySubfolder(dir.path() / "live");
  // What the live run logged (a busy machine may have logged fewer frames than the scene has).
  const std::vector<fw::JournalEntry> logged = fw::MatchLogReader(live).entries();
  const std::uint64_t depth_frames = fw::MatchLogReader(live).depthSources().at(0).second;
  const std::size_t omni_frames = itemsOf<fw::OmniFrame>(logged).size();
  const std::size_t poses = itemsOf<fw::RobotPose>(logged).size();
  for (const double jump_s : {1e9, 100.0, -1e6}) {
    SCOPED_TRACE("stamps jump by " + std::to_string(jump_s) + " s at depth frame 30");
    const std::string name = std::to_string(static_cast<long long>(jump_s));
    const std::string jumped = (dir.path() / ("jumped" + name)).string();
    copyWithClockJump(live, jumped, jump_s);
    // The robot's plugins re-run the log at its own pace (3.5 s): every source plays to its end.
    const fs::path rerun = dir.path() / ("rerun" + name);
    fw::Host host(demoConfig({"kinect3d.source=log:" + jumped, "omni.source=log:" + jumped,
                              "localisation.source=log:" + jumped, "logger.folder=" + rerun.string()}),
                  PRODUCT_PLUGIN_DIR);
    runUntilSourcesEnd(host);
    const auto summaries = host.summaries();
    EXPECT_EQ(summaryOf(summaries, "kinect3d").frames, depth_frames);
    EXPECT_EQ(summaryOf(summaries, "omni").frames, omni_frames);
    EXPECT_EQ(summaryOf(summaries, "localisation").frames, poses);
    EXPECT_EQ(summaryOf(summaries, "fusion").stuck, 0u);
    const double t0 = fw::MatchLogReader(live).depthFrameStamps("kinect3d").front().source_time_s;
    const auto after_jump = [&](const std::vector<fw::JournalEntry>& entries) {
      std::size_t count = 0;
      for (const fw::FusedBall& ball : itemsOf<fw::FusedBall>(entries)) {
        count += jump_s > 0 ? ball.stamp.source_time_s > t0 + jump_s : ball.stamp.source_time_s < t0 + 10.0 + jump_s;
      }
      return count;
    };
    EXPECT_GT(after_jump(fw::MatchLogReader(onlySubfolder(rerun)).entries()), 10u)
        << "the world ball goes on after the jump";
    // `kinect3d replay` of the same log, as fast as it can.
    const std::string replayed = (dir.path() / ("replayed" + name)).string();
    const auto [status, out] =
        runCommand(std::string(KINECT3D_EXE) + " replay " + jumped + " --output " + replayed + " 2>&1");
    EXPECT_EQ(status, 0) << out;
    EXPECT_NE(out.find("the fusion starts again from it"), std::string::npos) << out;
    EXPECT_GT(after_jump(fw::MatchLogReader(onlySubfolder(replayed)).entries()), 10u);
  }
}

// The files in folder, by name.
std::vector<std::string> filesIn(const fs::path& folder) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// A log left by a writer that was killed: its write-ahead files still there, holding the last batches.
std::string crashedLog(const fs::path& base, const std::string& from) {
  const std::string folder = (base / "crashed").string();
  const pid_t child = fork();
  if (child == 0) {
    const fw::MatchLogReader log(from);
    fw::MatchLogWriter writer(folder, log.run());
    for (const fw::JournalEntry& entry : log.entries()) writer.write(entry);
    fw::MatchLogReader::DepthFrames frames(log, "kinect3d");
    fw::DepthImage image;
    double wall_s = 0.0;
    for (int i = 0; i < 5 && frames.next(image, wall_s); ++i) writer.write({wall_s, image});
    writer.commit();
    _exit(0);  // no destructor: the database is never closed
  }
  waitpid(child, nullptr, 0);
  return folder;
}

// Every command that opens a log, on log (output under out); "" when each succeeded, else what failed.
std::string readWithEveryCommand(const std::string& prefix, const std::string& log, const fs::path& out) {
  const std::string exe = std::string(KINECT3D_EXE);
  std::string failed;
  for (const std::string& command :
       {exe + " info log:" + log, exe + " export " + log + " --omni " + (out / "omni.jsonl").string(),
        exe + " replay " + log + " --output " + (out / "replayed").string(),
        exe + " report match " + log + " --out " + (out / "report").string()}) {
    const auto [status, output] = runCommand(prefix + command + " 2>&1");
    if (status != 0) failed += "'" + command + "' exited " + std::to_string(status) + ":\n" + output + "\n";
  }
  return failed;
}

TEST(MatchDay, LogsOpenReadOnlyOnAReadOnlyMountAndAsAnotherUserAndNothingIsWrittenBesideThem) {
  ScopedTempDir dir;
  runDemo((dir.path() / "live").string());
  const std::string clean = onlySubfolder(dir.path() / "live");
  const std::string crashed = crashedLog(dir.path(), clean);
  ASSERT_TRUE(fs::exists(crashed + "/match.sqlite-wal"));
  const std::vector<std::string> clean_files = filesIn(clean), crashed_files = filesIn(crashed);

  // Another user, who may read the logs but not write beside them (as root: nobody; else the
  // folders are made read-only for their owner).
  const fs::path out = dir.path() / "out";
  fs::create_directories(out);
  std::string as_other;
  fs::permissions(dir.path(), fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                  fs::perms::others_read | fs::perms::others_exec);
  fs::permissions(out, fs::perms::all);
  for (const std::string& log : {clean, crashed}) {
    for (const auto& entry : fs::recursive_directory_iterator(fs::path(log).parent_path())) {
      fs::permissions(entry.path(), fs::perms::others_read | fs::perms::group_read, fs::perm_options::add);
      if (entry.is_directory()) fs::permissions(entry.path(), fs::perms::others_exec, fs::perm_options::add);
    }
    if (geteuid() != 0) fs::permissions(log, fs::perms::owner_write, fs::perm_options::remove);
  }
  const std::string prefix = geteuid() == 0 ? "setpriv --reuid=65534 --regid=65534 --clear-groups " : "";
  EXPECT_EQ(readWithEveryCommand(prefix, clean, out / "clean"), "");
  EXPECT_EQ(readWithEveryCommand(prefix, crashed, out / "crashed"), "");
  EXPECT_EQ(filesIn(clean), clean_files);
  EXPECT_EQ(filesIn(crashed), crashed_files);
  for (const std::string& log : {clean, crashed}) fs::permissions(log, fs::perms::owner_write, fs::perm_options::add);

  // A read-only mount, in a mount namespace of this test's own.
  if (unshare(CLONE_NEWNS) != 0 || mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0 ||
      mount(dir.path().c_str(), dir.path().c_str(), nullptr, MS_BIND | MS_REC, nullptr) != 0 ||
      mount(nullptr, dir.path().c_str(), nullptr, MS_REMOUNT | MS_BIND | MS_RDONLY, nullptr) != 0) {
    GTEST_SKIP() << "the read-only mount needs root (a mount namespace); the other-user part ran";
  }
  // Unmounted before the temporary folder is removed (the mount is this process's alone).
  const struct Unmount {
    std::string path;
    ~Unmount() { umount2(path.c_str(), MNT_DETACH); }
  } unmount{dir.path().string()};
  ASSERT_NE(access(clean.c_str(), W_OK), 0) << "the mount is read-only";
  ScopedTempDir writable;
  for (const std::string& log : {clean, crashed}) {
    SCOPED_TRACE(log);
    EXPECT_EQ(readWithEveryCommand("", log, writable.path() / fs::path(log).filename()), "");
    kinect3d::MatchView view(log);  // what `kinect3d view` serves
    EXPECT_FALSE(view.run()["frames_t_s"].empty());
    EXPECT_TRUE(view.frame(0).has_value());
    EXPECT_TRUE(view.depthPng(0).has_value());
  }
  EXPECT_EQ(filesIn(clean), clean_files);
  EXPECT_EQ(filesIn(crashed), crashed_files);
}

}  // namespace
