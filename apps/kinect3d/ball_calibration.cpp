#include "ball_calibration.h"

#include <cstdio>
#include <optional>

#include "calibrate_pose.h"
#include "framework_api/log.h"
#include "fusion/json_lines.h"
#include "kinect3d/ball_colour_calibration.h"
#include "kinect3d/ball_physics_fit.h"
#include "kinect3d/colour_check.h"
#include "kinect3d/config_io.h"
#include "kinect3d/sim/sim_sources.h"

namespace kinect3d {

// `calibrate drag`: the ball's drag and restitution from the flights in detect output files.
void printBallPhysicsFit(const std::vector<std::string>& files, const fw::Config& config) {
  std::vector<fw::BallFrame> frames;
  for (const std::string& file : files) {
    const std::vector<fw::BallFrame> read = fusion::readDetectionsFile(file, "kinect3d");
    frames.insert(frames.end(), read.begin(), read.end());
  }
  const double radius_m = readTrajectoryConfig(config.block("kinect3d")).ball_radius_m;
  const BallPhysicsCalibration fit = calibrateBallPhysics(frames, radius_m);
  std::printf("%zu flights fitted (%d runs in the air too short or slow to fit), %zu bounces\n\n", fit.flights.size(),
              fit.runs_skipped, fit.bounces.size());
  std::printf("  start (s)  detections  speed (m/s)  drag (/m)          rms (m)\n");
  for (const FlightFit& flight : fit.flights) {
    std::printf("  %9.3f  %10d  %11.1f  %.4f +- %.4f  %.4f\n", flight.start_s - frames.front().stamp.source_time_s,
                flight.detections, flight.trajectory.velocity_mps.norm(), flight.trajectory.drag_per_m,
                flight.drag_sigma_per_m, flight.rms_m);
  }
  for (const BounceFit& bounce : fit.bounces) {
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
void calibrateBallColourInto(const std::string& uri, const fw::Config& config, const std::string& robot_file,
                             bool write) {
  SourceOptions options;
  options.colour = true;
  const auto source = sim::sourcesWithSimulator().open(uri, options);
  const BallColourFit fit = calibrateBallColour(*source, readDetectorConfig(config.block("kinect3d")));
  const std::string yaml = ballColoursYaml(fit.model);
  const ColourCheckConfig check = readColourCheckConfig(config.block("kinect3d"));
  std::printf("The ball seen whole in %d colour frames (%d pixels of it, %d of everything else).\n\n", fit.frames,
              fit.ball_pixels, fit.other_pixels);
  std::printf("  colour  L*     a*     b*     share  explains of everything else\n");
  for (std::size_t i = 0; i < fit.model.size(); ++i) {
    const BallColour& c = fit.model[i];
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
    const std::string backup = writeRobotFileValue(robot_file, {"kinect3d", "colour_check", "ball_colours"}, yaml);
    fw::logInfo("calibrate", "wrote kinect3d.colour_check.ball_colours into " + robot_file + " (the old file is " +
                                 backup + "); turn the check on with kinect3d.colour: true and colour_check.mode: on");
  }
}

}  // namespace kinect3d
