// vision_host: runs the plugins a robot configuration enables until a stop signal (SIGINT, SIGTERM,
// SIGHUP, SIGQUIT), the configured duration, or the end of every plugin's source; then prints a
// per-plugin summary. Exit codes (docs/architecture.md): 0 a clean stop, 1 a plugin gave up,
// 2 the configuration or a plugin could not be loaded, 3 a plugin was stuck and left behind.
#include <CLI/CLI.hpp>

#include <unistd.h>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include "framework_api/config.h"
#include "framework_api/host.h"
#include "framework_api/install_layout.h"
#include "framework_api/log.h"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  // Whatever reads our output may go away (tee, an ssh session): a write then fails with EPIPE
  // instead of killing the host mid-match.
  std::signal(SIGPIPE, SIG_IGN);
  // Likewise a file-size limit: the write fails (the logger says so and goes on), the robot plays.
  std::signal(SIGXFSZ, SIG_IGN);
  const sigset_t stop_signals = fw::blockStopSignals();

  CLI::App app{"Runs the vision plugins a robot configuration enables."};
  std::string robot_file;
  std::string defaults_dir;
  std::string plugin_dir = fw::defaultPluginDir();
  std::vector<std::string> overrides;
  bool print_config = false;
  app.add_option("--robot", robot_file, "Robot configuration, e.g. config/robots/demo.yaml")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("--defaults", defaults_dir,
                 "Folder of per-plugin defaults (default: <robot file folder>/../defaults if it exists, else "
                 "the installed share/kinect3d/config/defaults)");
  app.add_option("--plugin-dir", plugin_dir, "Folder holding the plugin libraries")->capture_default_str();
  app.add_option("--set", overrides, "Override a value: --set kinect3d.grid.voxel_m=0.2")->take_all();
  app.add_flag("--print-config", print_config, "Print the merged configuration and exit");
  CLI11_PARSE(app, argc, argv);

  if (defaults_dir.empty()) {
    // A team's own configuration tree (robots/ beside defaults/) first, then the installed one.
    const fs::path beside_robot = fs::path(robot_file).parent_path() / ".." / "defaults";
    std::error_code error;
    defaults_dir = fs::is_directory(beside_robot, error) ? beside_robot.lexically_normal().string()
                                                         : fw::defaultConfigDir() + "/defaults";
  }

  try {
    const fw::Config config = fw::Config::load(defaults_dir, robot_file, overrides);
    if (print_config) {
      std::cout << config.toYaml() << std::endl;
      return 0;
    }
    const fw::ConfigView host_config = config.block("host");
    const double duration_s = host_config.getDouble("duration_s", 0.0, 1e7);
    fw::Host host(config, plugin_dir);  // which also sets host.log_level
    fw::logInfo("host", "robot '" + host_config.getString("robot_name") + "' from " + robot_file);
    host.start();
    const auto started = std::chrono::steady_clock::now();
    const timespec poll{0, 100'000'000};  // 100 ms: stop latency well inside one second
    std::string reason;
    while (reason.empty()) {
      const int signal_number = sigtimedwait(&stop_signals, nullptr, &poll);
      if (signal_number > 0) {
        reason = fw::stopSignalName(signal_number);
      } else if (host.watch(); host.sourcesFinished()) {
        reason = "every source ended";
      } else if (duration_s > 0.0 &&
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count() >= duration_s) {
        reason = "duration reached";
      }
    }
    fw::logInfo("host", "stopping: " + reason);
    // Every plugin gets this long to leave its step: the whole stop stays within a second.
    constexpr std::chrono::milliseconds kStopGrace(800);
    const std::vector<std::string> stuck = host.stop(kStopGrace);
    std::cout << "Summary (" << reason << "):\n";
    bool gave_up = false;
    for (const fw::PluginSummary& summary : host.summaries()) {
      std::cout << "  " << fw::formatSummary(summary) << "\n";
      gave_up = gave_up || summary.gave_up;
    }
    if (!stuck.empty()) {
      // A plugin thread is still inside its code: end the process now, once what was printed is
      // out, rather than in the host's destructor, which would wait for it.
      std::cout.flush();
      std::fflush(nullptr);
      std::_Exit(3);
    }
    return gave_up ? 1 : 0;  // a plugin that gave up is a failed run, whatever else went well
  } catch (const std::exception& e) {
    fw::logError("host", e.what());
    return 2;
  }
}
