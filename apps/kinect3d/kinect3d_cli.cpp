// kinect3d: the depth pipeline's command line. See docs/cli.md.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <set>

#include "ball_calibration.h"
#include "calibrate_pose.h"
#include "calibration_plot.h"
#include "calibration_report.h"
#include "detect_line.h"
#include "framework_api/config.h"
#include "framework_api/host.h"
#include "framework_api/install_layout.h"
#include "framework_api/log.h"
#include "fusion/json_lines.h"
#include "fusion_report.h"
#include "kinect3d/config_io.h"
#include "kinect3d/sim/accuracy_report.h"
#include "kinect3d/sim/calibration_scene.h"
#include "kinect3d/sim/field_sensors.h"
#include "kinect3d/sim/sequence_writer.h"
#include "kinect3d/sim/trajectory_report.h"
#include "match_report.h"
#include "match_tools.h"
#include "match_view.h"
#include "offline_fusion.h"
#include "source_tools.h"
#include "team_packet.h"
#include "team_report.h"
#include "view_server.h"

namespace {

// The configuration every command that runs the detector takes: the shipped defaults, a robot
// file, --set overrides.
struct ConfigOptions {
  std::string robot_file;
  std::string defaults_dir = fw::defaultConfigDir() + "/defaults";
  std::vector<std::string> overrides;

  void addTo(CLI::App* command, bool with_robot_file = true) {
    if (with_robot_file) {
      command->add_option("--config", robot_file, "Robot configuration file (default: the shipped defaults)")
          ->check(CLI::ExistingFile);
      command->add_option("--set", overrides, "Override a value: --set kinect3d.grid.voxel_m=0.2")->take_all();
    }
    command->add_option("--defaults", defaults_dir, "Folder of per-plugin defaults")->capture_default_str();
  }
  fw::Config load() const { return fw::Config::load(defaults_dir, robot_file, overrides); }
};

void runFuse(const kinect3d::RecordedFiles& files, const fw::Config& config, const std::string& output) {
  const kinect3d::FusionRun run = kinect3d::fuseRecorded(config, files);
  fusion::writeFusedFile(output, run.updates);
  const auto with_ball = std::count_if(run.updates.begin(), run.updates.end(),
                                       [](const fusion::FusionUpdate& update) { return update.ball.has_value(); });
  fw::logInfo("fuse", std::to_string(run.updates.size()) + " updates, " + std::to_string(with_ball) +
                          " with a ball; omni latency behind the Kinect " +
                          (run.omni_latency_s ? std::to_string(std::lround(1000 * *run.omni_latency_s)) + " ms"
                                              : std::string("not learnt")) +
                          ", pose latency " +
                          (run.pose_latency_s ? std::to_string(std::lround(1000 * *run.pose_latency_s)) + " ms"
                                              : std::string("not learnt")));
}

void addFuse(CLI::App& app) {
  struct Options {
    kinect3d::RecordedFiles files;
    std::string output;
    ConfigOptions config;
  };
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(
      "fuse", "Detection and fusion offline, in source-time order: one JSON line per fused update (docs/fusion.md)");
  command->add_option("--depth", options->files.depth, "Depth source URI (none: the omni camera alone)");
  command->add_option("--omni", options->files.omni, "Omni camera balls, JSON lines")->check(CLI::ExistingFile);
  command->add_option("--pose", options->files.pose, "Robot poses, JSON lines (none: at the field origin facing +y)")
      ->check(CLI::ExistingFile);
  command->add_option("--output", options->output, "Fused balls, JSON lines")->required();
  options->config.addTo(command);
  command->callback([options] {
    if (options->files.depth.empty() && options->files.omni.empty()) {
      throw CLI::ValidationError("fuse", "give --depth, --omni or both");
    }
    runFuse(options->files, options->config.load(), options->output);
  });
}

void addSimulate(CLI::App& app) {
  struct Options {
    std::string scene, out_dir, format = "tum";
    int frames = 0, seed = -1;
  };
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(
      "simulate", "Render a simulated scene to a sequence on disk, with the omni camera's and localisation's files");
  command->add_option("scene", options->scene, "Built-in scene name or scene file (.yaml)")->required();
  command->add_option("--out", options->out_dir, "Output folder")->required();
  command->add_option("--format", options->format, "Sequence format")
      ->check(CLI::IsMember({"tum", "fakenect", "oni"}))
      ->capture_default_str();
  command->add_option("--frames", options->frames, "Number of frames (default: the scene's duration)")
      ->check(CLI::PositiveNumber);
  command->add_option("--seed", options->seed, "Noise seed (default: the scene's)")->check(CLI::NonNegativeNumber);
  command->callback([options] {
    kinect3d::sim::writeSimulatedSequence(options->scene, options->out_dir, options->format, options->frames,
                                          options->seed);
    kinect3d::sim::Scene scene = kinect3d::sim::loadScene(options->scene);
    kinect3d::sim::OmniCameraModel omni;
    kinect3d::sim::LocalisationModel localisation;
    if (options->seed >= 0) omni.seed = localisation.seed = static_cast<std::uint64_t>(options->seed);
    if (options->frames > 0) scene.duration_s = options->frames / scene.fps;
    kinect3d::writeFieldSensorFiles(scene, omni, localisation, options->out_dir);
  });
}

void addSimulateSession(CLI::App& app) {
  struct Options {
    std::string out_dir, ball = "orange";
    int seed = 1;
    ConfigOptions config;
  };
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(
      "simulate-session",
      "Render a calibration session for a robot file's sensor mounting: the match ball on four marks, with colour");
  command->add_option("--out", options->out_dir, "Output folder (a TUM sequence with rgb/ and marks.yaml)")->required();
  command->add_option("--ball", options->ball, "The match ball's look")
      ->check(CLI::IsMember(kinect3d::sim::ColourLook::ballNames()))
      ->capture_default_str();
  command->add_option("--seed", options->seed, "Noise seed")->check(CLI::NonNegativeNumber)->capture_default_str();
  options->config.addTo(command);
  command->callback([options] {
    const fw::Config config = options->config.load();
    kinect3d::sim::CalibrationSession session;
    const std::optional<fw::SensorPose> pose = kinect3d::readDetectorConfig(config.block("kinect3d")).ground.pose;
    if (!pose) {
      throw CLI::ValidationError("--config", "the session needs the sensor's mounting: kinect3d.sensor.pose_in_robot");
    }
    session.pose = *pose;
    session.noise_seed = static_cast<std::uint64_t>(options->seed);
    session.colour = kinect3d::sim::ColourLook::withBall(options->ball);
    kinect3d::sim::writeCalibrationSession(session, options->out_dir);
    fw::logInfo("simulate-session", "wrote " + options->out_dir + ": the " + options->ball +
                                        " ball on 4 marks, 1 s each, with colour; sensor at " +
                                        fw::poseInRobotYaml(session.pose));
  });
}

void addInfo(CLI::App& app) {
  auto uri = std::make_shared<std::string>();
  CLI::App* command = app.add_subcommand("info", "Print what a depth source delivers");
  command->add_option("source", *uri, "Depth source URI: openni2:, oni:<file>, tum:<dir>, sim:<scene>")->required();
  command->callback([uri] { kinect3d::printSourceInfo(*uri); });
}

void addSnapshot(CLI::App& app) {
  struct Options {
    std::vector<std::string> uris;
    std::vector<int> frames;
    std::string png, bt;
    ConfigOptions config;
  };
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(
      "snapshot",
      "Colour-map one frame of each source side by side, its colour image under it where it has one (--out), or "
      "save the scene map (--bt)");
  command->add_option("sources", options->uris, "Depth source URIs")->required();
  command->add_option("--frame", options->frames, "Frame number (0 = first): one for all sources, or one per source")
      ->check(CLI::NonNegativeNumber);
  command->add_option("--out", options->png, "PNG file to write");
  command->add_option("--bt", options->bt,
                      "OctoMap .bt file: the scene map after the detector has run up to --frame on the first source");
  options->config.addTo(command);
  command->callback([options] {
    if (options->png.empty() && options->bt.empty()) throw CLI::ValidationError("snapshot", "give --out, --bt or both");
    if (options->frames.size() > 1 && options->frames.size() != options->uris.size()) {
      throw CLI::ValidationError("--frame", "give one frame number, or one per source");
    }
    if (!options->png.empty()) kinect3d::writeDepthPanels(options->uris, options->frames, options->png);
    if (!options->bt.empty()) {
      const int last = options->frames.empty() ? 0 : options->frames.front();
      kinect3d::writeSceneMap(options->uris.front(), last, options->config.load(), options->bt);
    }
  });
}

void addDetect(CLI::App& app) {
  struct Options {
    std::string source, output;
    ConfigOptions config;
  };
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(
      "detect", "Run the robot's kinect3d plugin on every frame of a recording; one JSON line per frame");
  command->add_option("--source", options->source, "Depth source URI (default: kinect3d.source of the configuration)");
  options->config.addTo(command);
  command->add_option("--output", options->output, "Write the JSON lines here instead of stdout");
  command->callback([options] {
    // The kinect3d plugin alone, reading as fast as it can.
    std::vector<std::string> detect_only = {"host.plugins=[kinect3d]", "kinect3d.realtime=false"};
    if (!options->source.empty()) detect_only.push_back("kinect3d.source=" + fw::yamlQuoted(options->source));
    const fw::Config config = options->config.load().with(detect_only);
    if (options->output.empty()) {
      kinect3d::detect(config, std::cout, "standard output");
      return;
    }
    std::ofstream file(options->output);
    if (!file) throw std::runtime_error("cannot write '" + options->output + "'");
    kinect3d::detect(config, file, "'" + options->output + "'");
  });
}

void addCalibrate(CLI::App& app) {
  struct Options {
    std::vector<std::string> files;
    ConfigOptions config;
    kinect3d::PoseCalibrationOptions pose;
    bool no_floor = false;
    std::string plot;
  };
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(
      "calibrate",
      "The sensor's pose on the robot from a ball on known marks (docs/calibration.md); 'drag': the ball's drag; "
      "'ball-colour': its colours");
  command->require_subcommand(0, 1);
  command->add_option("--source", options->pose.source, "Depth source showing the ball on the marks");
  command->add_option("--marks", options->pose.marks_file, "The marks: where the ball is, when (marks.yaml)")
      ->check(CLI::ExistingFile);
  options->config.addTo(command);
  command->add_flag("--write", options->pose.write,
                    "Write the pose into the --config robot file (the old file is kept as a dated copy)");
  command->add_flag("--no-floor", options->no_floor, "Fit all six degrees of freedom from the marks alone");
  command->add_option("--plot", options->plot, "Also draw the set-up and the residuals as a page in this folder");
  command->callback([options, command] {
    if (!command->get_subcommands().empty()) return;  // calibrate drag or ball-colour
    if (options->pose.source.empty() || options->pose.marks_file.empty()) {
      throw CLI::ValidationError("calibrate", "give --source and --marks (or the subcommand drag)");
    }
    if (options->pose.write && options->config.robot_file.empty()) {
      throw CLI::ValidationError("calibrate", "--write needs the robot file to write into: --config robot.yaml");
    }
    options->pose.robot_file = options->config.robot_file;
    options->pose.use_floor = !options->no_floor;
    const kinect3d::PoseCalibration calibration = kinect3d::calibratePose(options->pose, options->config.load());
    kinect3d::printPoseCalibration(calibration, std::cout);
    if (!options->plot.empty()) kinect3d::writeCalibrationPlot(calibration, options->plot);
  });
  CLI::App* drag = command->add_subcommand(
      "drag", "Fit the ball's air drag and bounce restitution from recorded flights (kinect3d detect output)");
  drag->add_option("files", options->files, "kinect3d detect output files (JSON lines)")
      ->required()
      ->check(CLI::ExistingFile);
  drag->add_option("--config", options->config.robot_file, "Robot configuration file (default: the shipped defaults)")
      ->check(CLI::ExistingFile);
  drag->add_option("--set", options->config.overrides, "Override a value: --set kinect3d.grid.voxel_m=0.2")->take_all();
  drag->callback([options] { kinect3d::printBallPhysicsFit(options->files, options->config.load()); });
  CLI::App* colour = command->add_subcommand(
      "ball-colour", "Learn the match ball's colours from a recording of it in view (docs/colour.md)");
  colour->add_option("--source", options->pose.source, "Depth source with colour showing the ball, alone")->required();
  colour->add_option("--config", options->config.robot_file, "Robot configuration file (default: the shipped defaults)")
      ->check(CLI::ExistingFile);
  colour->add_option("--set", options->config.overrides, "Override a value: --set kinect3d.grid.voxel_m=0.2")
      ->take_all();
  colour->add_flag("--write", options->pose.write,
                   "Write the colours into the --config robot file (the old file is kept as a dated copy)");
  colour->callback([options] {
    if (options->pose.write && options->config.robot_file.empty()) {
      throw CLI::ValidationError("calibrate ball-colour",
                                 "--write needs the robot file to write into: --config robot.yaml");
    }
    kinect3d::calibrateBallColourInto(options->pose.source, options->config.load(), options->config.robot_file,
                                      options->pose.write);
  });
}

void addReport(CLI::App& app) {
  struct Options {
    std::string kind, out, keep, log;
    std::vector<std::string> scenes;
    kinect3d::ReportOptions report;
    kinect3d::TeamReportOptions team;
    ConfigOptions config;
  };
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand("report",
                                         "Measure detection, trajectory, fusion, calibration or the team on simulated "
                                         "scenes, or show a match log as a page");
  command
      ->add_option("kind", options->kind,
                   "detection (docs/accuracy.md), trajectory (docs/trajectory.md), fusion (docs/fusion-report.md), "
                   "calibration (docs/calibration-report.md), team (docs/team-report.md) or match (a match log's page, "
                   "docs/match-log.md)")
      ->required()
      ->check(CLI::IsMember({"detection", "trajectory", "fusion", "calibration", "team", "match"}));
  command->add_option("log", options->log, "match: the match log folder")->check(CLI::ExistingDirectory);
  command->add_option("--out", options->out, "Markdown file to write, e.g. docs/accuracy.md; match: a folder")
      ->required();
  command->add_option("--seeds", options->report.seeds, "detection and fusion: noise seeds per scene")
      ->capture_default_str();
  command->add_option("--clutter-frames", options->report.clutter_frames, "detection: frames of the clutter scene")
      ->capture_default_str();
  command->add_option("--people-seeds", options->report.people_seeds, "detection: random scenes per kind of people")
      ->capture_default_str();
  command
      ->add_option("--colour-seeds", options->report.colour_seeds,
                   "detection: random scenes per kind of people and per ball with the colour check")
      ->capture_default_str();
  command
      ->add_option("--real-data", options->report.real_data_dir,
                   "detection: the folder holding the third-party real frames, real-depth/ and realdata/ "
                   "(not in the repository; without it that part of the report is left out)")
      ->check(CLI::ExistingDirectory);
  command->add_option("--runs", options->team.runs, "team: live runs per world and network")->capture_default_str();
  command
      ->add_option("--worlds", options->team.worlds_dir,
                   "team: the folder holding the team worlds (team/, team_rest/, team5/, team_hop/, team_hop3/)")
      ->default_val("tests/data/scenes");
  command->add_option("--keep", options->keep,
                      "fusion: keep every case's input files and fused output here; calibration: every session; "
                      "team: every robot's match logs");
  command
      ->add_option("--scenes", options->scenes,
                   "fusion: only these scenes (comma-separated; default all: " + kinect3d::fusionReportScenes() +
                       "); team: only these worlds (default all: " + kinect3d::teamReportWorlds() + ")")
      ->delimiter(',');
  options->config.addTo(command, /*with_robot_file=*/false);
  command->callback([options] {
    if ((options->kind == "match") != !options->log.empty()) {
      throw CLI::ValidationError("report", "a match log folder goes with 'match', and only with it");
    }
    if (options->kind == "match") {
      kinect3d::writeMatchReport(options->log, options->out);
      return;
    }
    if (options->kind == "team") {
      options->team.defaults_dir = options->config.defaults_dir;
      options->team.keep_dir = options->keep;
      options->team.worlds = options->scenes;
      kinect3d::writeTeamReport(options->team, options->out);
      return;
    }
    const fw::Config config = options->config.load();
    if (options->kind == "calibration") {
      kinect3d::writeCalibrationReport(config, options->out, options->keep);
    } else if (options->kind == "trajectory") {
      kinect3d::writeTrajectoryReport(config, options->out);
    } else if (options->kind == "fusion") {
      kinect3d::writeFusionReport(config, options->report.seeds, options->out, options->keep, options->scenes);
    } else {
      kinect3d::writeAccuracyReport(config, options->report, options->out);
    }
  });
}

void addReplay(CLI::App& app) {
  struct Options {
    std::string log, output;
    ConfigOptions config;
  };
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(
      "replay", "Re-run detection, trajectory and fusion on a match log's inputs into a new log (docs/match-log.md)");
  command->add_option("log", options->log, "Match log folder")->required()->check(CLI::ExistingDirectory);
  command->add_option("--output", options->output, "Folder for the new log")->required();
  command
      ->add_option("--config", options->config.robot_file,
                   "Robot configuration to use instead of the one the log recorded")
      ->check(CLI::ExistingFile);
  command->add_option("--set", options->config.overrides, "Override a value: --set kinect3d.grid.voxel_m=0.2")
      ->take_all();
  command->add_option("--defaults", options->config.defaults_dir, "Folder of per-plugin defaults")
      ->capture_default_str();
  command->callback([options] {
    kinect3d::replayMatch(options->log, options->config.defaults_dir, options->config.robot_file,
                          options->config.overrides, options->output);
  });
}

void addExport(CLI::App& app) {
  auto files = std::make_shared<kinect3d::ExportFiles>();
  auto log = std::make_shared<std::string>();
  CLI::App* command =
      app.add_subcommand("export", "Write a match log's inputs as the files fuse and detect use (docs/match-log.md)");
  command->add_option("log", *log, "Match log folder")->required()->check(CLI::ExistingDirectory);
  command->add_option("--omni", files->omni, "Omni camera balls, JSON lines");
  command->add_option("--pose", files->pose, "Robot poses, JSON lines");
  command->add_option("--detections", files->detections, "The depth plugin's balls per frame, as detect writes them");
  command->add_option("--tum", files->tum, "The depth, as a TUM RGB-D folder");
  command->callback([files, log] {
    if (files->omni.empty() && files->pose.empty() && files->detections.empty() && files->tum.empty()) {
      throw CLI::ValidationError("export", "give at least one of --omni, --pose, --detections, --tum");
    }
    kinect3d::exportMatch(*log, *files);
  });
}

namespace fs = std::filesystem;

// "http://10.0.0.5:8080/?live or http://localhost:8080/?live".
std::string joined(const std::vector<std::string>& urls, const std::string& suffix) {
  std::string text;
  for (const std::string& url : urls) text += (text.empty() ? "" : " or ") + url + suffix;
  return text;
}

void addTeamKey(CLI::App& app) {
  auto out = std::make_shared<std::string>();
  CLI::App* command =
      app.add_subcommand("team-key", "Write a new random team key, for every robot's team.key_file (docs/team.md)");
  command->add_option("--out", *out, "Key file to create (it must not exist; readable by its owner only)")->required();
  command->callback([out] {
    if (fs::exists(*out)) throw std::runtime_error(*out + " exists: a team key is never overwritten");
    {
      std::ofstream file(*out);
      if (!file) throw std::runtime_error("cannot create '" + *out + "'");
      fs::permissions(*out, fs::perms::owner_read | fs::perms::owner_write);
      file << team::TeamKey::random().hex() << "\n";
      if (!file.flush()) throw std::runtime_error("cannot write '" + *out + "'");
    }
    std::cout << "wrote a team key to " << *out << ": copy it to every robot of the team" << std::endl;
  });
}

void addView(CLI::App& app) {
  struct Options {
    std::string log, live;
    ConfigOptions config;
    kinect3d::ViewServerOptions server;
  };
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(
      "view", "Serve a browser view of a match log, or of the robot live, in 3D and in time (docs/viewer.md)");
  command->add_option("log", options->log, "Match log folder, or a folder of them (the newest is shown)")
      ->check(CLI::ExistingDirectory);
  command->add_option("--live", options->live, "Run this robot's plugins here and view them as they log")
      ->check(CLI::ExistingFile);
  command->add_option("--set", options->config.overrides, "--live: override a value, as vision_host --set")->take_all();
  options->config.addTo(command, /*with_robot_file=*/false);
  command->add_option("--port", options->server.port, "TCP port (0: any free one)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  command
      ->add_option("--bind", options->server.bind,
                   "Address to listen on: 127.0.0.1, this machine only; 0.0.0.0, every interface (anyone on the "
                   "robot's network can then read the log: the viewer has no password)")
      ->capture_default_str();
  command->callback([options] {
    if (options->log.empty() == options->live.empty()) {
      throw CLI::ValidationError("view", "give a match log folder or --live robot.yaml (one of them)");
    }
    const sigset_t stop_signals = fw::blockStopSignals();
    const timespec poll{0, 100'000'000};
    if (options->live.empty()) {
      const std::string run = kinect3d::newestRun(options->log);
      kinect3d::MatchView view(run);
      const kinect3d::ViewServer server(view, options->server);
      std::cout << "serving " << run << " on " << joined(server.urls(), "") << " (Ctrl-C stops)" << std::endl;
      while (sigtimedwait(&stop_signals, nullptr, &poll) <= 0) {
      }
      return;
    }
    // Live: the robot's plugins in this process, the logger among them with the depth, and the view
    // reading its log as it grows. The browser only ever reads the log: it costs the host nothing.
    std::vector<std::string> overrides = options->config.overrides;
    overrides.push_back("logger.depth=true");
    fw::Config config = fw::Config::load(options->config.defaults_dir, options->live, overrides);
    std::vector<std::string> plugins = config.block("host").getStringList("plugins");
    if (std::find(plugins.begin(), plugins.end(), "logger") == plugins.end()) {
      plugins.push_back("logger");
      std::string list;
      for (const std::string& plugin : plugins) list += (list.empty() ? "" : ", ") + plugin;
      overrides.push_back("host.plugins=[" + list + "]");
      config = fw::Config::load(options->config.defaults_dir, options->live, overrides);
    }
    const fs::path base = config.block("logger").getString("folder");
    const std::set<std::string> before = fw::entriesOf(base.string());
    fw::Host host(config, fw::defaultPluginDir());
    host.start();
    kinect3d::MatchView view(kinect3d::newRunFolder(base.string(), before));
    const kinect3d::ViewServer server(view, options->server);
    std::cout << "serving the robot live on " << joined(server.urls(), "?live") << " (Ctrl-C stops)" << std::endl;
    while (sigtimedwait(&stop_signals, nullptr, &poll) <= 0) host.watch();
    host.stop(std::chrono::milliseconds(800));
  });
}

}  // namespace

int main(int argc, char** argv) {
  // A reader that goes away makes a write fail (and the command exit 2) rather than kill it.
  std::signal(SIGPIPE, SIG_IGN);
  CLI::App app{"Kinect3D: 3D ball perception from depth frames."};
  app.require_subcommand(1);
  addSimulate(app);
  addSimulateSession(app);
  addInfo(app);
  addSnapshot(app);
  addDetect(app);
  addFuse(app);
  addCalibrate(app);
  addReport(app);
  addReplay(app);
  addExport(app);
  addTeamKey(app);
  addView(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help prints and succeeds; every usage error exits 2, as docs/cli.md says.
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const std::exception& e) {
    fw::logError("kinect3d", e.what());
    return 2;
  }
  return 0;
}
