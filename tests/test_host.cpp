#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "framework_api/host.h"
#include "host_process.h"
#include "scoped_temp_dir.h"

namespace {

using Clock = std::chrono::steady_clock;

fw::Config exchangeConfig(const std::vector<std::string>& overrides = {}) {
  return fw::Config::load(std::string(TEST_CONFIG_DIR) + "/defaults",
                          std::string(TEST_CONFIG_DIR) + "/robots/exchange.yaml", overrides);
}

const fw::PluginSummary& summaryOf(const std::vector<fw::PluginSummary>& all, const std::string& name) {
  for (const auto& summary : all) {
    if (summary.name == name) return summary;
  }
  throw std::runtime_error("no summary for " + name);
}

TEST(Host, PluginsExchangeDataThroughWorldState) {
  fw::Host host(exchangeConfig(), TEST_PLUGIN_DIR);
  host.start();
  // Until the consumer republished and every plugin ran a few steps (generous for a busy machine).
  const auto enough = [&] {
    const auto summaries = host.summaries();
    return host.world().fusedBall() && summaryOf(summaries, "tp_producer").frames > 5 &&
           summaryOf(summaries, "tp_consumer").frames > 1 && summaryOf(summaries, "tp_faulty").errors > 2;
  };
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  while (!enough() && Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  // Each plugin's thread goes by its name, so that top -H says who takes the time.
  std::set<std::string> threads;
  for (const auto& task : std::filesystem::directory_iterator("/proc/self/task")) {
    std::string name;
    std::getline(std::ifstream(task.path() / "comm"), name);
    threads.insert(name);
  }
  host.stop();
  for (const char* plugin : {"tp_producer", "tp_consumer", "tp_faulty"}) EXPECT_EQ(threads.count(plugin), 1u) << plugin;

  const auto fused = host.world().fusedBall();
  ASSERT_TRUE(fused.has_value()) << "the consumer never republished the producer's ball";
  EXPECT_TRUE(fused->position_R.isApprox(Eigen::Vector3d(0.5, 3.0, 1.25)));
  EXPECT_EQ(fused->sources, std::vector<std::string>{"tp_producer"});

  const auto summaries = host.summaries();
  ASSERT_EQ(summaries.size(), 3u);
  EXPECT_GT(summaryOf(summaries, "tp_producer").frames, 5u);
  EXPECT_GT(summaryOf(summaries, "tp_consumer").frames, 1u);
  EXPECT_DOUBLE_EQ(summaryOf(summaries, "tp_consumer").rate_hz_setting, 100.0);
  // A plugin that fails every step is counted, not fatal.
  const fw::PluginSummary& faulty = summaryOf(summaries, "tp_faulty");
  EXPECT_GT(faulty.errors, 2u);
  EXPECT_EQ(faulty.frames, 0u);
  EXPECT_EQ(faulty.last_error, "frame checksum mismatch");
}

TEST(Host, APluginThatWakesOnBallFramesStepsOnEachArrivalNotOnlyOnItsTicks) {
  // Ticks 10 s apart: in the minute this test may wait, ticks alone step the consumer at most 7 times.
  fw::Host host(exchangeConfig({"host.plugins=[tp_producer, tp_consumer]", "tp_producer.frames=200",
                                "tp_consumer.rate_hz=0.1", "tp_consumer.wake_on_ball_frame=true"}),
                TEST_PLUGIN_DIR);
  host.world().openJournal(false);  // for the consumer's "stepped_on" events
  host.start();
  const auto consumer_steps = [&] { return summaryOf(host.summaries(), "tp_consumer").frames; };
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  while (consumer_steps() < 20 && Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  host.stop();
  // The producer published 200 balls 5 ms apart; however the threads fell, most woke the consumer.
  EXPECT_GE(consumer_steps(), 20u);
  EXPECT_TRUE(host.world().fusedBall().has_value());
  // Each ball's step is taken by whichever comes first: the consumer's woken thread or the
  // producer's, right after the step that published the ball. The producer's needs no wake-up, so
  // it wins often (on a loaded core a wake-up costs milliseconds).
  std::uint64_t refused = 0;
  std::map<std::string, int> steps_on_thread;
  for (const fw::JournalEntry& entry : host.world().takeJournal(&refused)) {
    if (const auto* event = std::get_if<fw::Event>(&entry.item); event && event->kind == "stepped_on") {
      ++steps_on_thread[event->message];
    }
  }
  EXPECT_GE(steps_on_thread["tp_producer"], 1)
      << "no step on the producer's thread; on the consumer's: " << steps_on_thread["tp_consumer"];
}

TEST(Host, ReportsEndOfStream) {
  fw::Host host(exchangeConfig({"host.plugins=[tp_producer]", "tp_producer.frames=3"}), TEST_PLUGIN_DIR);
  host.start();
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  while (!host.sourcesFinished() && Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_TRUE(host.sourcesFinished());
  host.stop();
  EXPECT_EQ(host.summaries().at(0).frames, 3u);
  EXPECT_EQ(host.world().recentBalls("tp_producer").size(), 3u);
}

TEST(Host, ReplayStepsEachInputsPluginThenTheRatedOnesAtTheRobotsMoment) {
  fw::Host host(exchangeConfig({"host.plugins=[tp_producer, tp_consumer]", "tp_producer.frames=3"}), TEST_PLUGIN_DIR);
  host.replay({{"tp_producer", 1000.0}, {"tp_producer", 1000.5}});
  const auto balls = host.world().recentBalls("tp_producer");
  ASSERT_EQ(balls.size(), 2u);
  EXPECT_DOUBLE_EQ(balls[0].stamp.receive_time_s, 1000.5) << "stamped with the replayed wall clock";
  EXPECT_DOUBLE_EQ(balls[1].stamp.receive_time_s, 1000.0);
  ASSERT_TRUE(host.world().fusedBall());
  EXPECT_DOUBLE_EQ(host.world().fusedBall()->stamp.receive_time_s, 1000.5) << "the consumer stepped after it";
  EXPECT_EQ(summaryOf(host.summaries(), "tp_consumer").steps, 2u) << "once per input";
  EXPECT_GT(fw::wallClockNow_s(), 1.7e9) << "the system clock again after the replay";

  try {
    host.replay({{"tp_producer", 1001.0}, {"tp_producer", 1001.5}});
    FAIL() << "the producer had one frame left for two inputs";
  } catch (const fw::PluginError& e) {
    EXPECT_NE(std::string(e.what()).find("'tp_producer' has no input left"), std::string::npos) << e.what();
  }
  try {
    host.replay({{"tp_nobody", 1002.0}});
    FAIL() << "no such plugin";
  } catch (const fw::PluginError& e) {
    EXPECT_NE(std::string(e.what()).find("no plugin 'tp_nobody' is loaded"), std::string::npos) << e.what();
  }
  EXPECT_GT(fw::wallClockNow_s(), 1.7e9);
}

TEST(Host, ReplayOfOneSourceStepsItToItsEndAndTheRatedOnesAfterEachInput) {
  fw::Host host(exchangeConfig({"host.plugins=[tp_producer, tp_consumer]", "tp_producer.frames=3"}), TEST_PLUGIN_DIR);
  std::vector<std::size_t> balls_seen;  // after each input, what the world state holds
  std::vector<bool> consumed;
  host.replaySource("tp_producer", [&] {
    balls_seen.push_back(host.world().recentBalls("tp_producer").size());
    consumed.push_back(host.world().fusedBall().has_value());
  });
  EXPECT_EQ(balls_seen, (std::vector<std::size_t>{1, 2, 3})) << "one call per input, each after it";
  EXPECT_EQ(consumed, (std::vector<bool>{true, true, true})) << "the consumer stepped before each call";
  EXPECT_EQ(summaryOf(host.summaries(), "tp_consumer").steps, 3u) << "once per input";
  EXPECT_TRUE(summaryOf(host.summaries(), "tp_producer").end_of_stream);

  fw::Host failing(exchangeConfig({"host.plugins=[tp_faulty]", "host.max_consecutive_errors=4"}), TEST_PLUGIN_DIR);
  int inputs = 0;
  failing.replaySource("tp_faulty", [&] { ++inputs; });
  EXPECT_EQ(inputs, 0);
  EXPECT_TRUE(failing.summaries().at(0).gave_up) << "a source that only fails ends the replay";
  EXPECT_EQ(failing.summaries().at(0).errors, 4u);
  try {
    failing.replaySource("tp_nobody", [] {});
    FAIL() << "no such plugin";
  } catch (const fw::PluginError& e) {
    EXPECT_NE(std::string(e.what()).find("no plugin 'tp_nobody' is loaded"), std::string::npos) << e.what();
  }
}

TEST(Host, APluginThatKeepsFailingBacksOffThenGivesUp) {
  fw::Host host(exchangeConfig({"host.plugins=[tp_faulty]", "host.max_consecutive_errors=4"}), TEST_PLUGIN_DIR);
  const auto started = Clock::now();
  host.start();
  const auto deadline = started + std::chrono::seconds(60);
  while (!host.sourcesFinished() && Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const double elapsed_s = std::chrono::duration<double>(Clock::now() - started).count();
  ASSERT_TRUE(host.sourcesFinished()) << "a source that only fails ends";
  host.stop();
  const fw::PluginSummary summary = host.summaries().at(0);
  EXPECT_TRUE(summary.gave_up);
  EXPECT_EQ(summary.errors, 4u) << "no spinning: exactly the allowed failures";
  EXPECT_GT(elapsed_s, 0.07) << "10 + 20 + 40 ms of backoff between the failures, plus the steps";
  EXPECT_NE(fw::formatSummary(summary).find(", gave up, last error: frame checksum mismatch"), std::string::npos)
      << fw::formatSummary(summary);
}

TEST(LatencyHistogram, GivesTheRunsQuantilesToWithinOnePercent) {
  fw::LatencyHistogram histogram;
  EXPECT_TRUE(std::isnan(histogram.quantile(0.5))) << "no latency yet";
  // 1 to 1000 ms, shuffled: the median 501 ms and the 99th percentile 991 ms by nearest rank.
  std::vector<double> latencies_s;
  for (int ms = 1; ms <= 1000; ++ms) latencies_s.push_back(ms * 1e-3);
  std::shuffle(latencies_s.begin(), latencies_s.end(), std::mt19937(7));
  for (const double latency_s : latencies_s) histogram.add(latency_s);
  EXPECT_EQ(histogram.count(), 1000u);
  EXPECT_NEAR(histogram.quantile(0.5), fw::quantile(latencies_s, 0.5), 0.01 * 0.501);
  EXPECT_NEAR(histogram.quantile(0.99), fw::quantile(latencies_s, 0.99), 0.01 * 0.991);
  EXPECT_NEAR(histogram.quantile(0.0), 1e-3, 1e-5);
  EXPECT_NEAR(histogram.quantile(1.0), 1.0, 0.01);
  // Beyond the bins' range it still counts, in the end bins: nothing is lost or out of bounds.
  histogram.add(0.0);
  histogram.add(1e6);
  EXPECT_EQ(histogram.count(), 1002u);
  EXPECT_LT(histogram.quantile(0.0), 1e-5);
  EXPECT_GT(histogram.quantile(1.0), 99.0);

  fw::PluginSummary summary{};
  summary.name = "fusion";
  summary.latency_s = histogram;
  const std::string line = fw::formatSummary(summary);
  EXPECT_NE(line.find("0 errors, latency p50 "), std::string::npos) << line;
  EXPECT_NE(line.find(" ms, p99 9"), std::string::npos) << line;
}

TEST(Host, APluginStillInsideItsStepWhenTheStopsGraceEndsIsWaitedForThenDestroyed) {
  // A logger committing a large batch on a loaded machine can outlast a stop's grace. stop() names
  // it, and the host's destruction waits for its step to end instead of freeing the world state and
  // the plugin under it (the team report crashed when such a step ended); the plugin is destroyed
  // then, as a logger must be to close its log.
  const ScopedTempDir dir;
  const std::string started = (dir.path() / "started").string(), done = (dir.path() / "done").string();
  std::vector<std::string> still_inside;
  {
    fw::Host host(exchangeConfig({"host.plugins=[tp_slow]", "tp_slow.step_s=2.0", "tp_slow.started_file=" + started,
                                  "tp_slow.done_file=" + done}),
                  TEST_PLUGIN_DIR);
    host.start();
    const auto deadline = Clock::now() + std::chrono::seconds(60);
    while (!std::filesystem::exists(started) && Clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ASSERT_TRUE(std::filesystem::exists(started)) << "its first step never began";
    still_inside = host.stop(std::chrono::milliseconds(50));
    EXPECT_FALSE(std::filesystem::exists(done)) << "destroyed while its step was running";
  }
  EXPECT_EQ(still_inside, std::vector<std::string>{"tp_slow"});
  std::ifstream steps_file(done);
  ASSERT_TRUE(steps_file.is_open()) << "the plugin was never destroyed";
  int steps = 0;
  steps_file >> steps;
  EXPECT_EQ(steps, 1) << "destroyed once its one step had ended";
}

TEST(Host, UnknownPluginIsALoadError) {
  try {
    fw::Host host(exchangeConfig({"host.plugins=[tp_valid, tp_throwing]"}), TEST_PLUGIN_DIR);
    FAIL() << "expected an error";
  } catch (const fw::ConfigError& e) {
    // tp_throwing has no defaults file, so it is refused before its library is even opened.
    EXPECT_NE(std::string(e.what()).find("no configuration block 'tp_throwing'"), std::string::npos) << e.what();
  }
}

void expectCleanStopOn(int signal_number, const std::string& name) {
  HostProcess host(
      {"--robot", std::string(TEST_CONFIG_DIR) + "/robots/exchange.yaml", "--plugin-dir", TEST_PLUGIN_DIR});
  // Every plugin has started once the faulty one has failed a step.
  ASSERT_TRUE(host.waitForOutput("step failed (1): frame checksum mismatch"));
  const auto signalled = Clock::now();
  host.signal(signal_number);
  const int status = host.waitExit(std::chrono::milliseconds(3000));
  const double stop_s = std::chrono::duration<double>(Clock::now() - signalled).count();
  EXPECT_EQ(status, 0);
  EXPECT_LT(stop_s, 1.0) << "the host must stop within one second";
  const std::string out = host.readAll();
  EXPECT_NE(out.find("Summary (" + name + ")"), std::string::npos) << out;
  EXPECT_NE(out.find("tp_producer 0.1.0: "), std::string::npos) << out;
  EXPECT_NE(out.find("last error: frame checksum mismatch"), std::string::npos) << out;
}

TEST(HostProcess, StopsCleanlyOnSigint) { expectCleanStopOn(SIGINT, "SIGINT"); }
TEST(HostProcess, StopsCleanlyOnSigterm) { expectCleanStopOn(SIGTERM, "SIGTERM"); }
TEST(HostProcess, StopsCleanlyOnSighupWhenItsSshSessionDrops) { expectCleanStopOn(SIGHUP, "SIGHUP"); }
TEST(HostProcess, StopsCleanlyOnSigquit) { expectCleanStopOn(SIGQUIT, "SIGQUIT"); }

TEST(HostProcess, BadConfigExitsNonZeroNamingTheKey) {
  HostProcess host({"--robot", std::string(TEST_CONFIG_DIR) + "/robots/exchange.yaml", "--plugin-dir", TEST_PLUGIN_DIR,
                    "--set", "tp_producer.frames=many"});
  EXPECT_EQ(host.waitExit(std::chrono::milliseconds(3000)), 2);
  const std::string out = host.readAll();
  EXPECT_NE(out.find("--set tp_producer.frames=many: tp_producer.frames has the wrong type; "
                     "expected an integer"),
            std::string::npos)
      << out;
}

TEST(HostProcess, ReportsAStuckPluginAndStillStopsWithinASecond) {
  HostProcess host({"--robot", std::string(TEST_CONFIG_DIR) + "/robots/exchange.yaml", "--plugin-dir", TEST_PLUGIN_DIR,
                    "--set", "host.plugins=[tp_producer, tp_stuck]", "--set", "host.stuck_after_s=0.3"});
  ASSERT_TRUE(host.waitForOutput("[tp_stuck] stuck: inside one step"));  // it blocks after 40 ms
  const auto signalled = Clock::now();
  host.signal(SIGTERM);
  const int status = host.waitExit(std::chrono::milliseconds(3000));
  const double stop_s = std::chrono::duration<double>(Clock::now() - signalled).count();
  EXPECT_EQ(status, 3) << "a plugin left behind is a failed stop";
  EXPECT_LT(stop_s, 1.0);
  const std::string out = host.readAll();
  EXPECT_NE(out.find("[tp_stuck] stuck: inside one step for more than 0.3"), std::string::npos) << out;
  EXPECT_NE(out.find("[tp_stuck] did not stop within 0.8"), std::string::npos) << out;
  EXPECT_NE(out.find("tp_stuck 0.1.0: 3 frames"), std::string::npos) << "the summary is still printed:\n" << out;
  EXPECT_NE(out.find("stuck 1 times"), std::string::npos) << out;
}

TEST(HostProcess, AtLogLevelWarnItPrintsItsErrorsAndSummaryButNotItsProgress) {
  HostProcess host({"--robot", std::string(TEST_CONFIG_DIR) + "/robots/exchange.yaml", "--plugin-dir", TEST_PLUGIN_DIR,
                    "--set", "host.plugins=[tp_producer, tp_stuck]", "--set", "host.stuck_after_s=0.3", "--set",
                    "host.log_level=warn"});
  ASSERT_TRUE(host.waitForOutput("[tp_stuck] stuck: inside one step"));
  host.signal(SIGTERM);
  host.waitExit(std::chrono::milliseconds(3000));
  const std::string out = host.readAll();
  EXPECT_EQ(out.find(" INFO "), std::string::npos) << "the plugins' loading, said at info:\n" << out;
  EXPECT_NE(out.find(" ERROR [tp_stuck] stuck"), std::string::npos) << out;
  EXPECT_NE(out.find("Summary ("), std::string::npos) << out;
}

TEST(HostProcess, AnUnknownLogLevelIsRefusedNamingTheKeyAndTheLevels) {
  HostProcess host({"--robot", std::string(TEST_CONFIG_DIR) + "/robots/exchange.yaml", "--plugin-dir", TEST_PLUGIN_DIR,
                    "--set", "host.log_level=verbose"});
  EXPECT_EQ(host.waitExit(std::chrono::milliseconds(3000)), 2);
  const std::string out = host.readAll();
  EXPECT_NE(out.find("host.log_level"), std::string::npos) << out;
  EXPECT_NE(out.find("'info' 'warn' 'error'"), std::string::npos) << out;
}

TEST(HostProcess, KeepsRunningWhenItsOutputIsClosed) {
  HostProcess host({"--robot", std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml", "--plugin-dir",
                    PRODUCT_PLUGIN_DIR, "--set", "host.duration_s=1.5"});
  host.closeOutput();  // the console plugin and the logs now write into a pipe nobody reads
  EXPECT_EQ(host.waitExit(std::chrono::milliseconds(8000)), 0) << "not killed by SIGPIPE (141)";
}

TEST(HostProcess, PluginListedTwiceIsAnError) {
  HostProcess host({"--robot", std::string(TEST_CONFIG_DIR) + "/robots/exchange.yaml", "--plugin-dir", TEST_PLUGIN_DIR,
                    "--set", "host.plugins=[tp_producer, tp_consumer, tp_producer]"});
  EXPECT_EQ(host.waitExit(std::chrono::milliseconds(3000)), 2);
  const std::string out = host.readAll();
  EXPECT_NE(out.find("host.plugins lists 'tp_producer' twice"), std::string::npos) << out;
}

TEST(HostProcess, DemoConfigRunsWithShippedPlugins) {
  HostProcess host({"--robot", std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml", "--plugin-dir",
                    PRODUCT_PLUGIN_DIR, "--set", "host.duration_s=0.5"});
  EXPECT_EQ(host.waitExit(std::chrono::milliseconds(5000)), 0);
  EXPECT_NE(host.readAll().find("Summary (duration reached)"), std::string::npos);
}

}  // namespace
