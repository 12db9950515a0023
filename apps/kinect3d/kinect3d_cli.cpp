// kinect3d: the depth pipeline's command line. See docs/cli.md.
#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <set>
#include <thread>

#include "calibrate_pose.h"
#include "calibration_plot.h"
#include "calibration_report.h"
#include "cli_sources.h"
#include "detect_line.h"
#include "framework_api/config.h"
#include "framework_api/host.h"
#include "framework_api/install_layout.h"
#include "framework_api/log.h"
#include "fusion/json_lines.h"
#include "fusion_report.h"
#include "kinect3d/ball_colour_calibration.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/ball_physics_fit.h"
#include "kinect3d/config_io.h"
#include "kinect3d/depth_source.h"
#include "kinect3d/sim/accuracy_report.h"
#include "kinect3d/sim/calibration_scene.h"
#include "kinect3d/sim/field_sensors.h"
#include "kinect3d/sim/sequence_writer.h"
#include "kinect3d/sim/sim_sources.h"
#include "kinect3d/sim/trajectory_report.h"
#include "kinect3d/trajectory.h"
#include "match_report.h"
#include "match_tools.h"
#include "match_view.h"
#include "offline_fusion.h"
#include "team_packet.h"
#include "view_server.h"

namespace {

void runInfo(const std::string& uri) {
  auto source = kinect3d::cliSources().open(uri);
  kinect3d::DepthFrame frame;
  std::uint64_t frames = 0;
  double invalid_sum = 0.0, min_m = 0.0, max_m = 0.0, first_t = 0.0, last_t = 0.0;
  kinect3d::Intrinsics intrinsics;
  // A live device never ends: one second of frames is enough, two without any is a dead device.
  const bool live = source->frameCount() == 0;
  auto last_frame = std::chrono::steady_clock::now();
  for (;;) {
    const kinect3d::ReadResult result = source->read(frame);
    if (result == kinect3d::ReadResult::kEnd) break;
    if (result == kinect3d::ReadResult::kNoFrameYet) {
      if (live && std::chrono::steady_clock::now() - last_frame > std::chrono::seconds(2)) break;
      continue;  // a recording that stalls says so itself
    }
    last_frame = std::chrono::steady_clock::now();
    const kinect3d::DepthStats stats = kinect3d::computeStats(frame);
    if (frames == 0) {
      intrinsics = frame.intrinsics;
      first_t = frame.source_time_s;
      min_m = stats.min_m;
    }
    if (stats.min_m > 0.0) min_m = min_m > 0.0 ? std::min(min_m, stats.min_m) : stats.min_m;
    max_m = std::max(max_m, stats.max_m);
    invalid_sum += stats.invalid_fraction;
    last_t = frame.source_time_s;
    ++frames;
    if (live && frames >= 30) break;
  }
  if (frames == 0) throw kinect3d::DepthSourceError(uri + ": delivered no frame");
  std::printf("source:            %s\n", source->describe().c_str());
  std::printf("frames:            %llu (%llu skipped, %llu dropped)\n", static_cast<unsigned long long>(frames),
              static_cast<unsigned long long>(source->counters().skipped),
              static_cast<unsigned long long>(source->counters().dropped));
  std::printf("stale time stamps: %llu, frames without depth: %llu\n",
              static_cast<unsigned long long>(source->counters().stale_stamps),
              static_cast<unsigned long long>(source->counters().blank));
  std::printf("rate:              %.2f Hz\n",
              frames > 1 && last_t > first_t ? (frames - 1) / (last_t - first_t) : source->frameRate_hz());
  std::printf("size:              %dx%d\n", intrinsics.width, intrinsics.height);
  std::printf("intrinsics:        fx %.1f fy %.1f cx %.1f cy %.1f\n", intrinsics.fx, intrinsics.fy, intrinsics.cx,
              intrinsics.cy);
  std::printf("invalid pixels:    %.1f %%\n", 100.0 * invalid_sum / frames);
  std::printf("depth range:       %.3f - %.3f m\n", min_m, max_m);
}

// Frame `index` (0 = first) of a source, or an error naming the source when it has fewer.
kinect3d::DepthFrame readFrame(kinect3d::DepthSource& source, const std::string& uri, int index) {
  kinect3d::DepthFrame frame;
  for (int seen = 0;;) {
    const kinect3d::ReadResult result = source.read(frame);
    if (result == kinect3d::ReadResult::kEnd) {
      throw kinect3d::DepthSourceError(uri + ": has no frame " + std::to_string(index));
    }
    if (result == kinect3d::ReadResult::kFrame && seen++ == index) return frame;
  }
}

// One frame of each source (frame_numbers: one for all, or one per source), colour-mapped on one
// fixed 0-8 m scale (no data in black), side by side in one PNG, so simulated and real frames can
// be compared by eye; where a source has colour, its colour image under its depth.
void writeDepthPanels(const std::vector<std::string>& uris, const std::vector<int>& frame_numbers,
                      const std::string& out) {
  constexpr double kMaxDepth_mm = 8000.0;
  kinect3d::SourceOptions options;
  options.colour = true;
  std::vector<cv::Mat> depth_panels, colour_panels;
  bool any_colour = false;
  for (std::size_t i = 0; i < uris.size(); ++i) {
    const std::string& uri = uris[i];
    const int index = frame_numbers.empty() ? 0 : frame_numbers[frame_numbers.size() > 1 ? i : 0];
    kinect3d::DepthFrame frame = readFrame(*kinect3d::cliSources().open(uri, options), uri, index);
    cv::Mat depth(frame.height(), frame.width(), CV_16UC1, frame.depth_mm.data());
    cv::Mat scaled, coloured;
    depth.convertTo(scaled, CV_8UC1, 255.0 / kMaxDepth_mm);
    cv::applyColorMap(scaled, coloured, cv::COLORMAP_TURBO);
    coloured.setTo(cv::Scalar(0, 0, 0), depth == 0);
    cv::putText(coloured, uri.substr(uri.find_last_of('/') + 1), {10, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.7,
                cv::Scalar(255, 255, 255), 2);
    cv::Mat colour(coloured.size(), CV_8UC3, cv::Scalar(0, 0, 0));
    if (frame.colour) {
      any_colour = true;
      cv::Mat bgr;
      cv::cvtColor(cv::Mat(frame.colour->height, frame.colour->width, CV_8UC3, frame.colour->rgb.data()), bgr,
                   cv::COLOR_RGB2BGR);
      cv::resize(bgr, colour, coloured.size());
    }
    depth_panels.push_back(coloured);
    colour_panels.push_back(colour);
  }
  cv::Mat joined;
  cv::hconcat(depth_panels, joined);
  if (any_colour) {
    cv::Mat colours;
    cv::hconcat(colour_panels, colours);
    cv::vconcat(joined, colours, joined);
  }
  if (!cv::imwrite(out, joined)) throw std::runtime_error("cannot write '" + out + "'");
}

// The scene map the detector builds from the source's frames up to frame `last`, as OctoMap's .bt.
void writeSceneMap(const std::string& uri, int last, const fw::Config& config, const std::string& out) {
  kinect3d::BallDetector detector(kinect3d::readDetectorConfig(config.block("kinect3d")), "kinect3d");
  auto source = kinect3d::cliSources().open(uri);
  kinect3d::DepthFrame frame;
  kinect3d::Detections detections;
  for (int frames = 0; frames <= last;) {
    const kinect3d::ReadResult result = source->read(frame);
    if (result == kinect3d::ReadResult::kEnd)
      throw kinect3d::DepthSourceError(uri + ": has no frame " + std::to_string(last));
    if (result != kinect3d::ReadResult::kFrame) continue;
    detector.detect(frame, detections);
    ++frames;
  }
  if (detector.sceneMap() == nullptr) throw std::runtime_error(uri + ": the floor was never found, so there is no map");
  detector.sceneMap()->writeBinary(out);
  fw::logInfo("snapshot", "wrote the scene map after " + std::to_string(last + 1) + " frames of " + uri + " to " + out +
                              " (" + std::to_string(detector.sceneMap()->integrations()) + " ray integrations)");
}

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
  // With `more` over the user's --set.
  fw::Config load(const std::vector<std::string>& more = {}) const {
    std::vector<std::string> all = overrides;
    all.insert(all.end(), more.begin(), more.end());
    return fw::Config::load(defaults_dir, robot_file, all);
  }
};

void runFuse(const std::string& depth_uri, const std::string& omni_file, const std::string& pose_file,
             const fw::Config& config, const std::string& output) {
  const kinect3d::FusionRun run = kinect3d::fuseFiles(config, depth_uri, omni_file, pose_file);
  fusion::writeFusedFile(output, run.updates);
  const auto with_ball = std::count_if(run.updates.begin(), run.updates.end(),
                                       [](const fusion::FusionUpdate& update) { return update.ball.has_value(); });
  std::string latency = "not learnt";
  if (run.omni_latency_s) latency = std::to_string(std::lround(1000 * *run.omni_latency_s)) + " ms";
  fw::logInfo("fuse", std::to_string(run.updates.size()) + " updates, " + std::to_string(with_ball) +
                          " with a ball; omni latency behind the Kinect " + latency + " (from " +
                          std::to_string(run.latency_examples) + " examples)");
}

void addFuse(CLI::App& app) {
  struct Options {
    std::string depth, omni, pose, output;
    ConfigOptions config;
  };
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(
      "fuse", "Detection and fusion offline, in source-time order: one JSON line per fused update (docs/fusion.md)");
  command->add_option("--depth", options->depth, "Depth source URI (none: the omni camera alone)");
  command->add_option("--omni", options->omni, "Omni camera balls, JSON lines")->check(CLI::ExistingFile);
  command->add_option("--pose", options->pose, "Robot poses, JSON lines (none: at the field origin facing +y)")
      ->check(CLI::ExistingFile);
  command->add_option("--output", options->output, "Fused balls, JSON lines")->required();
  options->config.addTo(command);
  command->callback([options] {
    if (options->depth.empty() && options->omni.empty()) {
      throw CLI::ValidationError("fuse", "give --depth, --omni or both");
    }
    runFuse(options->depth, options->omni, options->pose, options->config.load(), options->output);
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
  command->callback([uri] { runInfo(*uri); });
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
    if (!options->png.empty()) writeDepthPanels(options->uris, options->frames, options->png);
    if (!options->bt.empty()) {
      const int last = options->frames.empty() ? 0 : options->frames.front();
      writeSceneMap(options->uris.front(), last, options->config.load(), options->bt);
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
    const fw::Config config = options->config.load(detect_only);
    if (options->output.empty()) {
      kinect3d::detect(config, std::cout, "standard output");
      return;
    }
    std::ofstream file(options->output);
    if (!file) throw std::runtime_error("cannot write '" + options->output + "'");
    kinect3d::detect(config, file, "'" + options->output + "'");
  });
}

// `calibrate drag`: the ball's drag and restitution from the flights in detect output files.
void runCalibrateDrag(const std::vector<std::string>& files, const fw::Config& config) {
  std::vector<fw::BallFrame> frames;
  for (const std::string& file : files) {
    const std::vector<fw::BallFrame> read = fusion::readDetectionsFile(file, "kinect3d");
    frames.insert(frames.end(), read.begin(), read.end());
  }
  const double radius_m = kinect3d::readTrajectoryConfig(config.block("kinect3d")).ball_radius_m;
  const kinect3d::BallPhysicsCalibration fit = kinect3d::calibrateBallPhysics(frames, radius_m);
  std::printf("%zu flights fitted (%d runs in the air too short or slow to fit), %zu bounces\n\n", fit.flights.size(),
              fit.runs_skipped, fit.bounces.size());
  std::printf("  start (s)  detections  speed (m/s)  drag (/m)          rms (m)\n");
  for (const kinect3d::FlightFit& flight : fit.flights) {
    std::printf("  %9.3f  %10d  %11.1f  %.4f +- %.4f  %.4f\n", flight.start_s - frames.front().stamp.source_time_s,
                flight.detections, flight.trajectory.velocity_mps.norm(), flight.trajectory.drag_per_m,
                flight.drag_sigma_per_m, flight.rms_m);
  }
  for (const kinect3d::BounceFit& bounce : fit.bounces) {
    std::printf("  bounce at %.3f s: restitution %.2f", bounce.t_s - frames.front().stamp.source_time_s,
                bounce.restitution);
    if (bounce.friction) std::printf(", friction %.2f", *bounce.friction);
    std::printf("\n");
  }
  std::printf(
      "\nFor the robot file (the trajectory's drag prior and the fusion's bounce):\n\nball:\n"
      "  drag_per_m: %.4f\n  drag_sigma_per_m: %.4f\n",
      fit.drag_per_m, fit.drag_sigma_per_m);
  // Each measured value with its spread, or a comment saying why there is none.
  auto print = [](const char* key, const std::optional<double>& mean, const std::optional<double>& sigma) {
    if (!mean) {
      std::printf("  # no bounce to measure %s from\n", key);
    } else if (!sigma) {
      std::printf("  %s: %.2f\n  # %s from one bounce: %s_sigma not measured\n", key, *mean, key, key);
    } else {
      std::printf("  %s: %.2f\n  %s_sigma: %.2f\n", key, *mean, key, *sigma);
    }
  };
  print("restitution", fit.restitution, fit.restitution_sigma);
  print("bounce_friction", fit.bounce_friction, fit.bounce_friction_sigma);
}

// `calibrate ball-colour`: the match ball's colours from a recording of it, written into the robot file.
void runCalibrateBallColour(const std::string& uri, const fw::Config& config, const std::string& robot_file,
                            bool write) {
  kinect3d::SourceOptions options;
  options.colour = true;
  const auto source = kinect3d::cliSources().open(uri, options);
  const kinect3d::BallColourFit fit =
      kinect3d::calibrateBallColour(*source, kinect3d::readDetectorConfig(config.block("kinect3d")));
  const std::string yaml = kinect3d::ballColoursYaml(fit.model);
  const kinect3d::ColourCheckConfig check = kinect3d::readColourCheckConfig(config.block("kinect3d"));
  std::printf("The ball seen whole in %d colour frames (%d pixels of it, %d of everything else).\n\n", fit.frames,
              fit.ball_pixels, fit.other_pixels);
  std::printf("  colour  L*     a*     b*     share  explains of everything else\n");
  for (std::size_t i = 0; i < fit.model.size(); ++i) {
    const kinect3d::BallColour& c = fit.model[i];
    std::printf("  %zu      %5.1f  %5.1f  %5.1f  %4.0f %%  %5.1f %%\n", i + 1, c.lab.x(), c.lab.y(), c.lab.z(),
                100 * c.share, 100 * fit.other_explained_by[i]);
  }
  std::printf(
      "\nSeparability: the model explains %.1f %% of the ball's pixels and %.1f %% of everything else's; the colour "
      "score of the ball's own discs is %.2f or more in 9 of 10 frames, of ball-sized discs elsewhere at most %.2f "
      "in 99 of 100 (confirmed from %.2f, rejected below %.2f).\n",
      100 * fit.ball_explained, 100 * fit.other_explained, fit.ball_score_p10, fit.other_score_p99, check.confirm_score,
      check.reject_score);
  if (fit.ball_score_p10 < check.confirm_score || fit.other_score_p99 >= check.reject_score) {
    std::printf("WARNING: the ball and the rest overlap in colour here: the check will reject or miss balls.\n");
  }
  std::printf(
      "\nFor the robot file:\n\nkinect3d:\n  colour: true\n  colour_check:\n    mode: on\n    ball_colours: %s\n",
      yaml.c_str());
  if (write) {
    const std::string backup =
        kinect3d::writeRobotFileValue(robot_file, {"kinect3d", "colour_check", "ball_colours"}, yaml);
    fw::logInfo("calibrate", "wrote kinect3d.colour_check.ball_colours into " + robot_file + " (the old file is " +
                                 backup + "); turn the check on with kinect3d.colour: true and colour_check.mode: on");
  }
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
  drag->callback([options] { runCalibrateDrag(options->files, options->config.load()); });
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
    runCalibrateBallColour(options->pose.source, options->config.load(), options->config.robot_file,
                           options->pose.write);
  });
}

void addReport(CLI::App& app) {
  struct Options {
    std::string kind, out, keep, log;
    std::vector<std::string> scenes;
    kinect3d::ReportOptions report;
    ConfigOptions config;
  };
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(
      "report", "Measure detection, trajectory or fusion on simulated scenes, or show a match log as a page");
  command
      ->add_option("kind", options->kind,
                   "detection (docs/accuracy.md), trajectory (docs/trajectory.md), fusion (docs/fusion-report.md), "
                   "calibration (docs/calibration-report.md) or match (a match log's page, docs/match-log.md)")
      ->required()
      ->check(CLI::IsMember({"detection", "trajectory", "fusion", "calibration", "match"}));
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
  command->add_option("--keep", options->keep,
                      "fusion: keep every case's input files and fused output here; calibration: every session");
  command
      ->add_option("--scenes", options->scenes,
                   "fusion: only these scenes (comma-separated; default all: " + kinect3d::fusionReportScenes() + ")")
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

// The run folder the logger of a host started after `before` writes, once it holds a readable log.
std::string newRunFolder(const fs::path& base, const std::set<std::string>& before) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    if (const std::optional<std::string> run = kinect3d::newRunIn(base.string(), before)) return *run;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  throw std::runtime_error(base.string() + ": the logger started no run there within 20 s");
}

// A match log folder as given, or in a folder of them (the logger's logs/) the newest, said aloud.
std::string newestRun(const std::string& folder) {
  if (fs::exists(fs::path(folder) / kinect3d::kMatchLogFile)) return folder;
  std::vector<std::string> runs;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    if (fs::exists(entry.path() / kinect3d::kMatchLogFile)) runs.push_back(entry.path().string());
  }
  if (runs.empty()) throw std::runtime_error(folder + ": neither a match log nor a folder of them");
  const std::string newest = *std::max_element(runs.begin(), runs.end());  // <date>_<time>_<robot>
  fw::logInfo("view", "the newest of " + std::to_string(runs.size()) + " runs in " + folder + ": " + newest);
  return newest;
}

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
      const std::string run = newestRun(options->log);
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
    const std::set<std::string> before = kinect3d::entriesOf(base.string());
    fw::Host host(config, fw::defaultPluginDir());
    host.start();
    kinect3d::MatchView view(newRunFolder(base, before));
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
