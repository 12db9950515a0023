// `kinect3d report trajectory`: the paper's estimator next to ours on simulated lobs, chips and
// shots at the goalkeeper (drag and bounces on, every sensor effect on), from the detector's output.
#include "kinect3d/sim/trajectory_report.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <tuple>

#include "framework_api/log.h"
#include "kinect3d/config_io.h"
#include "kinect3d/sim/evaluation.h"
#include "kinect3d/trajectory.h"

namespace kinect3d {

namespace {

using Clock = std::chrono::steady_clock;

// What really happened in a flight: launch, first touchdown, and the crossing of y = 0 if the
// ball crosses the robot's line before it first touches down.
struct FlightTruth {
  double launch_s = 0.0;
  double touchdown_s = 0.0;
  Eigen::Vector2d touchdown_m = Eigen::Vector2d::Zero();
  std::optional<Eigen::Vector3d> crossing_m;  // x, z, t
};

FlightTruth truthOf(const sim::Scene& scene) {
  const sim::BallMotion motion(*scene.ball, scene.physics, scene.duration_s, scene.objects);
  FlightTruth truth;
  truth.launch_s = scene.ball->launch_time_s;
  const double r = scene.physics.radius_m;
  double previous_y = motion.positionAt(truth.launch_s).y();
  for (double t = truth.launch_s + 0.01; t < scene.duration_s; t += 0.0005) {
    const Eigen::Vector3d p = motion.positionAt(t);
    if (!truth.crossing_m && previous_y > 0.0 && p.y() <= 0.0) truth.crossing_m = Eigen::Vector3d(p.x(), p.z(), t);
    previous_y = p.y();
    if (p.z() <= r + 1e-6 && motion.velocityAt(t - 0.001).z() < 0.0) {
      truth.touchdown_s = t;
      truth.touchdown_m = p.head<2>();
      return truth;
    }
  }
  truth.touchdown_s = INFINITY;
  return truth;
}

// An open field seen from a robot 0.7 m up: a robot and a person beside the play, the far goal
// out of range.
sim::Scene openField(const std::string& name) {
  sim::Scene scene = sim::loadScene("shot_goalkeeper");
  scene.name = name;
  scene.duration_s = 2.2;
  return scene;
}

// Sidespin of a curving kick: up to about 10 rev/s.
constexpr double kMaxSpin_rps = 10.0;

// Lobs and chips kicked away from the robot, and shots and chips at it (the goalkeeper's view),
// drawn at random but repeatably.
std::vector<sim::Scene> flights(int lobs, int shots) {
  std::mt19937 rng(2014);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto between = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  std::vector<sim::Scene> scenes;
  for (int i = 0; i < lobs; ++i) {
    sim::Scene scene = openField("lob_" + std::to_string(i));
    const double speed = between(6.0, 8.5), elevation = between(25.0, 50.0) * M_PI / 180.0;
    const double azimuth = between(-12.0, 12.0) * M_PI / 180.0;
    const double horizontal = speed * std::cos(elevation);
    scene.ball =
        sim::BallLaunch{{between(-0.8, 0.8), between(1.6, 2.4), scene.physics.radius_m},
                        {-horizontal * std::sin(azimuth), horizontal * std::cos(azimuth), speed * std::sin(elevation)},
                        0.2,
                        false};
    scene.noise.seed = 100 + i;
    scenes.push_back(scene);
  }
  for (int i = 0; i < shots; ++i) {
    // Aimed to cross the robot's line in flight, 0.3-1.0 m up, at 7-11 m/s: the lower of the two
    // drag-free launch angles that reach that height there.
    sim::Scene scene = openField("shot_" + std::to_string(i));
    // One draw a statement, y first: as a constructor's arguments their order was the compiler's.
    const double start_y = between(5.0, 7.0);
    const Eigen::Vector3d start(between(-1.5, 1.5), start_y, scene.physics.radius_m);
    const Eigen::Vector2d target(between(-0.9, 0.9), 0.0);
    const double height = between(0.3, 1.0), speed = between(7.0, 11.0), g = 9.81;
    const double distance = (target - start.head<2>()).norm();
    const double rise = height - start.z();
    const double a = g * distance * distance / (2.0 * speed * speed);  // tan^2 coefficient
    const double disc = distance * distance - 4.0 * a * (a + rise);
    if (disc < 0.0) continue;
    const double elevation = std::atan((distance - std::sqrt(disc)) / (2.0 * a));
    const Eigen::Vector2d heading = (target - start.head<2>()).normalized();
    scene.ball = sim::BallLaunch{start,
                                 {speed * std::cos(elevation) * heading.x(), speed * std::cos(elevation) * heading.y(),
                                  speed * std::sin(elevation)},
                                 0.2,
                                 false};
    scene.noise.seed = 200 + i;
    scenes.push_back(scene);
  }
  for (const std::string name : {"shot_goalkeeper", "lob_goalkeeper"}) {
    for (int seed = 1; seed <= 3; ++seed) {
      sim::Scene scene = sim::loadScene(name);
      scene.noise.seed = static_cast<std::uint64_t>(seed);
      scenes.push_back(scene);
    }
  }
  // Every flight's ball is a different ball: drag, restitution, bounce friction and sidespin drawn
  // across their physical ranges, so no estimator is tested on the physics it assumes.
  for (sim::Scene& scene : scenes) {
    scene.physics.drag_per_m = between(0.010, 0.030);
    scene.physics.restitution = between(0.5, 0.8);
    scene.physics.bounce_friction = between(0.1, 0.3);
    scene.physics.spin_rps = between(-kMaxSpin_rps, kMaxSpin_rps);
  }
  return scenes;
}

struct ModeResult {
  std::string label;
  std::vector<double> touchdown_after_5_m, touchdown_after_10_m, time_after_5_s, time_after_10_s;
  std::vector<double> touchdown_in_sigmas;  // every touchdown prediction's error over its sigma
  std::vector<double> crossing_m, update_us;
  int flights = 0, reached_5 = 0, reached_10 = 0, without_reset = 0;
};

// Feeds one flight's detections to a fresh estimator and scores its predictions.
void scoreFlight(const std::vector<sim::EvaluatedFrame>& frames, const sim::Scene& scene, const FlightTruth& truth,
                 const TrajectoryConfig& config, ModeResult& result) {
  auto estimator = makeTrajectoryEstimator(config);
  bool have_5 = false, have_10 = false;
  int resets_when_tracked = -1;  // resets count from the flight's first reported trajectory
  for (const sim::EvaluatedFrame& frame : frames) {
    const double t = scene.start_time_s + frame.truth.time_s;  // the source clock of the detections
    const Clock::time_point start = Clock::now();
    const std::optional<fw::BallTrajectory> trajectory = estimator->update(t, frame.balls);
    result.update_us.push_back(1e6 * std::chrono::duration<double>(Clock::now() - start).count());
    if (frame.truth.time_s < truth.launch_s) continue;
    if (frame.truth.time_s >= truth.touchdown_s) break;
    if (!trajectory || trajectory->state != fw::BallState::kAir) continue;
    if (resets_when_tracked < 0) resets_when_tracked = estimator->resets();
    if (const auto& touchdown = trajectory->touchdown) {
      const double error = (touchdown->point_m - truth.touchdown_m).norm();
      if (touchdown->sigma_m > 0.0) result.touchdown_in_sigmas.push_back(error / touchdown->sigma_m);
      const double time_error = std::abs(touchdown->time_s - (scene.start_time_s + truth.touchdown_s));
      if (!have_5 && trajectory->support >= 5) {
        have_5 = true;
        result.touchdown_after_5_m.push_back(error);
        result.time_after_5_s.push_back(time_error);
      }
      if (!have_10 && trajectory->support >= 10) {
        have_10 = true;
        result.touchdown_after_10_m.push_back(error);
        result.time_after_10_s.push_back(time_error);
      }
    }
    if (truth.crossing_m && trajectory->crossing && (*truth.crossing_m)[2] - frame.truth.time_s >= 0.3) {
      const Eigen::Vector2d predicted(trajectory->crossing->x_m, trajectory->crossing->z_m);
      result.crossing_m.push_back((predicted - truth.crossing_m->head<2>()).norm());
    }
  }
  ++result.flights;
  result.reached_5 += have_5;
  result.reached_10 += have_10;
  result.without_reset += resets_when_tracked >= 0 && estimator->resets() == resets_when_tracked;
}

std::string cell(const std::vector<double>& values, double scale, const char* unit) {
  if (values.empty()) return "-";
  char text[96];
  std::snprintf(text, sizeof text, "%.2f / %.2f %s (n = %zu)", fw::quantile(values, 0.5) * scale,
                fw::quantile(values, 0.9) * scale, unit, values.size());
  return text;
}

std::string sigmaShares(const ModeResult& r) {
  if (r.touchdown_in_sigmas.empty()) return "-";
  const auto share = [&](double k) {
    return 100.0 *
           std::count_if(r.touchdown_in_sigmas.begin(), r.touchdown_in_sigmas.end(), [&](double e) { return e <= k; }) /
           r.touchdown_in_sigmas.size();
  };
  char text[64];
  std::snprintf(text, sizeof text, "%.0f %% / %.0f %%", share(1.0), share(2.0));
  return text;
}

// A markdown table: one column per result, one row per (name, cell, target).
void table(
    std::ostream& md, const std::vector<ModeResult>& results,
    const std::vector<std::tuple<std::string, std::function<std::string(const ModeResult&)>, std::string>>& rows) {
  md << "| | ";
  for (const ModeResult& r : results) md << r.label << " | ";
  md << "target |\n|---|";
  for (std::size_t i = 0; i <= results.size(); ++i) md << "---|";
  md << "\n";
  for (const auto& [name, cellOf, target] : rows) {
    md << "| " << name << " | ";
    for (const ModeResult& r : results) md << cellOf(r) << " | ";
    md << target << " |\n";
  }
}

}  // namespace

void writeTrajectoryReport(const fw::Config& config, const std::string& out_path) {
  const fw::ConfigView block = config.block("kinect3d");
  const TrajectoryConfig shipped = readTrajectoryConfig(block);
  TrajectoryConfig paper = shipped, gravity_only = shipped;
  paper.mode = TrajectoryConfig::Mode::kPaper;
  gravity_only.mode = TrajectoryConfig::Mode::kBallistic;
  gravity_only.drag_per_m = gravity_only.drag_sigma_per_m = gravity_only.curve_sigma_radps = 0.0;
  TrajectoryConfig assumed_drag = gravity_only;
  assumed_drag.drag_per_m = 0.024;
  TrajectoryConfig estimated_drag = shipped;
  estimated_drag.mode = TrajectoryConfig::Mode::kBallistic;
  std::vector<ModeResult> results(4);
  results[0].label = "paper (baseline)";
  results[1].label = "ballistic, gravity only";
  results[2].label = "ballistic, drag assumed 0.024 /m";
  results[3].label = "ballistic, drag and spin estimated (drag prior " +
                     std::to_string(shipped.drag_per_m).substr(0, 5) + " +- " +
                     std::to_string(shipped.drag_sigma_per_m).substr(0, 5) + " /m, curve 0 +- " +
                     std::to_string(shipped.curve_sigma_radps).substr(0, 4) + " rad/s)";
  const std::vector<TrajectoryConfig> configs{paper, gravity_only, assumed_drag, estimated_drag};

  const std::vector<sim::Scene> scenes = flights(16, 12);
  for (const sim::Scene& scene : scenes) {
    DetectorConfig detector = readDetectorConfig(block);
    detector.ground.pose = scene.sensor_pose;
    const std::vector<sim::EvaluatedFrame> frames = sim::runDetectorOnScene(scene, detector);
    const FlightTruth truth = truthOf(scene);
    for (std::size_t m = 0; m < configs.size(); ++m) scoreFlight(frames, scene, truth, configs[m], results[m]);
  }

  std::ostringstream md;
  md << "# Trajectory estimation\n\n"
        "Generated by `build/bin/kinect3d report trajectory --out docs/trajectory.md`. "
     << scenes.size()
     << " simulated flights, every sensor effect on, each ball's physics drawn at random: quadratic drag "
        "0.010-0.030 /m (size 5 balls span about 0.011-0.027), restitution 0.5-0.8, bounce friction 0.1-0.3, "
        "sidespin -10 to 10 rev/s (a sideways Magnus acceleration up to 1.5 m/s^2 at 8 m/s); "
        "flights: 16 lobs and chips kicked away from the robot (6-8.5 m/s, 25-50 deg), 12 shots and "
        "chips at it (7-11 m/s, aimed to cross its line 0.3-1.0 m up), and the built-in `shot_goalkeeper` and "
        "`lob_goalkeeper` "
        "with 3 noise seeds each. Every estimator reads the same detections (shipped detector "
        "settings, the scene's sensor pose). A flight runs from the kick to its first touchdown.\n\n"
        "Cells give median / 90th percentile (n = flights or predictions counted).\n\n"
        "";
  const auto touchdown5 = [](const ModeResult& r) { return cell(r.touchdown_after_5_m, 1.0, "m"); };
  const auto touchdown10 = [](const ModeResult& r) { return cell(r.touchdown_after_10_m, 1.0, "m"); };
  const auto crossing = [](const ModeResult& r) { return cell(r.crossing_m, 1.0, "m"); };
  const auto tracked = [](const ModeResult& r) {
    return std::to_string(r.without_reset) + " of " + std::to_string(r.flights);
  };
  table(md, results,
        {{"touchdown error after 5 supporting detections", touchdown5, "median <= 0.25 m"},
         {"touchdown error after 10 supporting detections", touchdown10, "median <= 0.10 m"},
         {"time-to-touchdown error after 5", [](const ModeResult& r) { return cell(r.time_after_5_s, 1000.0, "ms"); },
          ""},
         {"time-to-touchdown error after 10", [](const ModeResult& r) { return cell(r.time_after_10_s, 1000.0, "ms"); },
          ""},
         {"line crossing error (x, z), >= 0.3 s before arrival", crossing, "median <= 0.15 m"},
         {"touchdown errors within 1 / 2 reported sigma (all predictions)", sigmaShares, "68 % / 95 %"},
         {"flights reaching 5 / 10 supporting detections",
          [](const ModeResult& r) {
            return std::to_string(r.reached_5) + " / " + std::to_string(r.reached_10) + " of " +
                   std::to_string(r.flights);
          },
          ""},
         {"flights tracked without a reset (from the first reported trajectory to touchdown)", tracked, ""},
         {"update cost (mean / 99th percentile)",
          [](const ModeResult& r) {
            double sum = 0.0;
            for (const double us : r.update_us) sum += us;
            char text[64];
            std::snprintf(text, sizeof text, "%.1f / %.1f us", sum / std::max<std::size_t>(1, r.update_us.size()),
                          fw::quantile(r.update_us, 0.99));
            return std::string(text);
          },
          "<= 20 us"}});

  md << "\nThe shipped mode is `" << (shipped.mode == TrajectoryConfig::Mode::kPaper ? "paper" : "ballistic")
     << "` with drag_per_m " << shipped.drag_per_m << " +- " << shipped.drag_sigma_per_m << " and curve_sigma_radps "
     << shipped.curve_sigma_radps
     << " (config/defaults/kinect3d.yaml). The paper predicts no times; its times come from a "
        "straight-line fit of horizontal distance over time, added so the rows can be compared. "
        "Update costs are wall-clock on the machine that ran the report, single-threaded, "
        "including the touchdown and crossing predictions.\n";

  // What spin costs: every flight that crosses the robot's line, again without spin and again with
  // the most a kick gives (10 rev/s, to either side in turn), the rest of its physics as drawn.
  std::vector<ModeResult> spin(2);
  spin[0].label = "no spin";
  spin[1].label = "10 rev/s sidespin";
  int side = 1;
  for (const sim::Scene& drawn : scenes) {
    if (!truthOf(drawn).crossing_m) continue;
    for (int k = 0; k < 2; ++k) {
      sim::Scene scene = drawn;
      scene.physics.spin_rps = k == 0 ? 0.0 : (side = -side) * kMaxSpin_rps;
      DetectorConfig detector = readDetectorConfig(block);
      detector.ground.pose = scene.sensor_pose;
      scoreFlight(sim::runDetectorOnScene(scene, detector), scene, truthOf(scene), estimated_drag, spin[k]);
    }
  }
  md << "\n## What spin costs\n\nThe " << spin[0].flights
     << " flights above that cross the robot's line (shots and chips at it), once without spin and once with "
        "10 rev/s of sidespin (1.5 m/s^2 of Magnus acceleration at 8 m/s, alternately to the left and the right), "
        "the rest of each ball's physics as drawn; the shipped estimator.\n\n";
  table(md, spin,
        {{"line crossing error (x, z), >= 0.3 s before arrival", crossing, "median <= 0.15 m"},
         {"touchdown error after 5 supporting detections", touchdown5, "median <= 0.25 m"},
         {"touchdown error after 10 supporting detections", touchdown10, "median <= 0.10 m"},
         {"touchdown errors within 1 / 2 reported sigma (all predictions)", sigmaShares, "68 % / 95 %"},
         {"flights tracked without a reset", tracked, ""}});
  std::ofstream out(out_path);
  out << md.str();
  if (!out) throw std::runtime_error("cannot write '" + out_path + "'");
  fw::logInfo("report", "wrote " + out_path);
}

}  // namespace kinect3d
