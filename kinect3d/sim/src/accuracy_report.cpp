#include "kinect3d/sim/accuracy_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "framework_api/log.h"
#include "kinect3d/config_io.h"
#include "kinect3d/kinect_disparity.h"
#include "kinect3d/sim/evaluation.h"
#include "kinect3d/sim/people.h"

namespace kinect3d {

namespace {

std::string format(const char* pattern, double value) {
  char text[64];
  std::snprintf(text, sizeof text, pattern, value);
  return text;
}

// The columns every scored table shares: frames | counted | found | reported balls | off the truth |
// median error | p95 error.
std::string scoreColumns(const sim::DetectionScore& score) {
  auto centimetres = [&](double q) {
    return score.errors_m.empty() ? std::string("-") : format("%.1f cm", fw::quantile(score.errors_m, q) * 100);
  };
  std::ostringstream columns;
  columns << score.frames << " | " << score.eligible << " | " << score.found
          << format(" (%.1f %%)", 100.0 * score.recall()) << " | " << score.reported << " | " << score.off_truth
          << " | " << centimetres(0.5) << " | " << centimetres(0.95);
  return columns.str();
}

// The detector as a robot running the scene would be configured: shipped settings, scene pose.
DetectorConfig configFor(const fw::Config& config, const sim::Scene& scene) {
  DetectorConfig detector = readDetectorConfig(config.block("kinect3d"));
  detector.ground.pose = scene.sensor_pose;
  return detector;
}

// The detector, configured so, run over the scene and scored against its truth.
sim::DetectionScore scoreScene(const fw::Config& config, const sim::Scene& scene) {
  return sim::scoreFrames(sim::runDetectorOnScene(scene, configFor(config, scene)), scene, {});
}

// The paper's Table 1: measured distance (m) and its standard deviation (m) for 2..6 m.
struct PaperRow {
  double y_m, y_std_m;
};
const PaperRow kPaperTable1[] = {{2.01, 0.00002}, {2.96, 0.00029}, {4.01, 0.00001}, {5.00, 0.00718}, {5.97, 0.00003}};

// One row for a scene whose ball hangs still: mean position, mean 3D error and spread over the
// frames that found it, against the paper's targets at that range (3 cm up to 4 m, else 6 cm;
// spread at most 2 cm).
void hungBallRow(const fw::Config& config, const std::string& scene_name, const std::string& first_columns,
                 std::ostream& md) {
  const sim::Scene scene = sim::loadScene(scene_name);
  const auto frames = sim::runDetectorOnScene(scene, configFor(config, scene));
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), square = Eigen::Vector3d::Zero();
  double error_sum = 0.0;
  int found = 0;
  for (const auto& f : frames) {
    if (f.balls.empty()) continue;
    const Eigen::Vector3d p = f.balls.front().position_m;
    sum += p;
    square += p.cwiseProduct(p);
    error_sum += (p - f.truth.ball_center_R).norm();
    ++found;
  }
  const Eigen::Vector3d mean = sum / std::max(found, 1);
  const Eigen::Vector3d std_dev = (square / std::max(found, 1) - mean.cwiseProduct(mean)).cwiseMax(0.0).cwiseSqrt();
  const double mean_error = error_sum / std::max(found, 1);
  const double range =
      frames.empty() ? 0.0 : (frames.front().truth.ball_center_R - scene.sensor_pose.T_R_S().translation()).norm();
  const double target = range <= 4.05 ? 0.03 : 0.06;
  const bool met = found > 0 && mean_error <= target && std_dev.maxCoeff() <= 0.02;
  md << "| " << first_columns << " | " << format("%.3f, ", mean.x()) << format("%.3f, ", mean.y())
     << format("%.3f m", mean.z()) << " | " << format("%.1f cm", mean_error * 100) << " | "
     << format("%.1f / ", std_dev.x() * 100) << format("%.1f / ", std_dev.y() * 100)
     << format("%.1f cm", std_dev.z() * 100) << " | " << found << "/" << frames.size() << " | "
     << format("<= %.0f cm, std <= 2 cm: ", target * 100) << (met ? "met" : "**not met**") << " |\n";
}

void table1(const fw::Config& config, std::ostream& md) {
  md << "## The paper's Table 1: ball hung 1 m above the floor, straight ahead\n\n"
        "Scenes `hung_2m` ... `hung_6m` (90 frames each, every noise effect on, a wall at 7.6 m). "
        "Error is the 3D distance between the reported and the true centre. The paper reports "
        "its measured distance y with a standard deviation in centimetres, judged by eye against "
        "the tape-measured position.\n\n"
        "| distance | paper: mean y (std) | ours: mean x, y, z | mean 3D error | std x / y / z | found | target |\n"
        "|---|---|---|---|---|---|---|\n";
  for (int d = 2; d <= 6; ++d) {
    const PaperRow& paper = kPaperTable1[d - 2];
    hungBallRow(config, "hung_" + std::to_string(d) + "m",
                std::to_string(d) + " m | " + format("%.2f m", paper.y_m) + format(" (%.2f cm)", paper.y_std_m * 100),
                md);
  }
  md << "\n";
}

void partialOcclusion(const fw::Config& config, std::ostream& md) {
  md << "## Partly hidden balls\n\n"
        "A ball hung still with half of it out of sight: behind a robot 1 m in front of it, behind a "
        "person, and cut by the image border (90 frames each, every noise effect on). The centroid of "
        "a half-seen ball lies 0.42 radii towards its visible half; the detector centres it on the "
        "outline that is the ball's own (docs/architecture.md). Targets as Table 1's at that range.\n\n"
        "| scene | what hides it | mean x, y, z | mean 3D error | std x / y / z | found | target |\n"
        "|---|---|---|---|---|---|---|\n";
  hungBallRow(config, "half_hidden_robot", "`half_hidden_robot` (3 m) | its left half, a robot", md);
  hungBallRow(config, "half_hidden_person", "`half_hidden_person` (5 m) | its left half, a person", md);
  hungBallRow(config, "cut_by_border", "`cut_by_border` (3.4 m) | its left third, the image border", md);
  md << "\n";
}

void kicks(const fw::Config& config, const ReportOptions& options, std::ostream& md) {
  const sim::EvaluationCriteria criteria;
  md << "## Kicks and shots with robots, people, goal and wall in view\n\n"
     << "Each scene run with " << options.seeds << " noise seeds. A frame counts when the ball is "
     << format("%.1f", criteria.min_range_m) << "-" << format("%.0f m", criteria.max_range_m)
     << " from the sensor, its centre at least " << format("%.2f", criteria.min_centre_inside_r)
     << " radii inside the image (the detector reports a ball cut by the border while more than half of it is "
        "in view), shows at least "
     << format("%.0f %%", criteria.min_visible_fraction * 100) << " of a whole ball's pixels and is at least "
     << format("%.1f m", criteria.min_clearance_m)
     << " from every other structure; it is found when a reported ball lies within "
     << format("%.1f m", criteria.match_m)
     << " of the truth. Targets: found in >= 95 % of counted "
        "frames, every reported ball within 0.3 m of the truth.\n\n"
        "| scene | frames | counted | found | reported balls | off the truth | median error | p95 error |\n"
        "|---|---|---|---|---|---|---|---|\n";
  sim::DetectionScore total;
  for (const std::string name :
       {"kick_away", "ground_kick", "shot_goalkeeper", "shot_goalkeeper_low", "lob_goalkeeper"}) {
    sim::DetectionScore score;
    for (int seed = 1; seed <= options.seeds; ++seed) {
      sim::Scene scene = sim::loadScene(name);
      scene.noise.seed = static_cast<std::uint64_t>(seed);
      score.add(scoreScene(config, scene));
    }
    total.add(score);
    md << "| `" << name << "` | " << scoreColumns(score) << " |\n";
  }
  md << "| **all** | " << scoreColumns(total) << " |\n\n"
     << "Found in counted frames: " << format("%.1f %%", 100.0 * total.recall())
     << (total.recall() >= 0.95 ? " (target met)" : " (**target not met**)")
     << "; reported balls off the truth: " << total.off_truth
     << (total.off_truth == 0 ? " (target met)" : " (**target not met**)") << ".\n\n";
}

// The people scenes of one seed range, a row per kind, and what they add up to.
struct PeopleScores {
  sim::DetectionScore without_ball, with_ball;
};
PeopleScores peopleScores(const fw::Config& config, int first_seed, int seeds, std::ostream* rows) {
  PeopleScores scores;
  for (const sim::CrowdBall kind : {sim::CrowdBall::kNone, sim::CrowdBall::kThrownFromHands, sim::CrowdBall::kOverAHead,
                                    sim::CrowdBall::kFromTheBorder}) {
    sim::DetectionScore score;
    for (int seed = first_seed; seed < first_seed + seeds; ++seed)
      score.add(scoreScene(config, sim::crowdScene(seed, kind)));
    (kind == sim::CrowdBall::kNone ? scores.without_ball : scores.with_ball).add(score);
    if (rows) *rows << "| `" << sim::crowdBallName(kind) << "` | " << scoreColumns(score) << " |\n";
  }
  return scores;
}

void people(const fw::Config& config, const ReportOptions& options, std::ostream& md) {
  // The detector's rules were set looking at seeds 1-120 and 1001-1020 (first at 1-20); the
  // report's rows use seeds no one looked at, so that they say what a new crowd gets.
  constexpr int kTunedFirstSeed = 1, kTunedSeeds = 20, kHeldOutFirstSeed = 201;
  const sim::EvaluationCriteria criteria;
  md << "## People\n\n"
     << "Random scenes of 5-8 articulated people round the robot (`sim::crowdScene`, kinect3d/sim/people.h): "
        "close (0.8-2 m) and cut by the view's edges, walking, reaching, arms raised or held out, a hand at the "
        "head, a referee's flag, dark clothes and hair that return little depth; the sensor's height, tilt, "
        "range (5.5-9.5 m) and noise (0.8-1.5 times the average unit's) random. "
     << options.people_seeds << " seeds per kind (" << kHeldOutFirstSeed << "-"
     << kHeldOutFirstSeed + options.people_seeds - 1
     << ": crowds no one looked at while setting the detector's rules, which were set looking at seeds up to 120 "
        "and first at "
     << kTunedFirstSeed << "-" << kTunedFirstSeed + kTunedSeeds - 1
     << ", scored below the table); frames counted as for the kicks (the ball at least "
     << format("%.1f m", criteria.min_clearance_m)
     << " from every body, so a ball in the hands or grazing a head is counted once free of it). Targets: "
        "0 balls off the truth, found in >= 95 % of counted frames.\n\n"
        "| scene | frames | counted | found | reported balls | off the truth | median error | p95 error |\n"
        "|---|---|---|---|---|---|---|---|\n";
  const PeopleScores held_out = peopleScores(config, kHeldOutFirstSeed, options.people_seeds, &md);
  const int phantoms_without_ball = held_out.without_ball.reported;
  const sim::DetectionScore& with_ball = held_out.with_ball;
  md << "\nBalls without a ball: " << phantoms_without_ball
     << (phantoms_without_ball == 0 ? " (target met)" : " (**target not met**)")
     << "; with a ball, found in counted frames: " << format("%.1f %%", 100.0 * with_ball.recall())
     << (with_ball.recall() >= 0.95 ? " (target met)" : " (**target not met**)")
     << ", balls off the truth: " << with_ball.off_truth
     << (with_ball.off_truth == 0 ? " (target met)" : " (**target not met**)") << ".\n\n";

  std::vector<double> ranges = held_out.without_ball.off_truth_ranges_m;
  ranges.insert(ranges.end(), with_ball.off_truth_ranges_m.begin(), with_ball.off_truth_ranges_m.end());
  auto within = [&](double lo, double hi) {
    return std::count_if(ranges.begin(), ranges.end(), [&](double r) { return r >= lo && r < hi; });
  };
  md << "Balls off the truth by their distance from the sensor: " << within(0, 3) << " nearer than 3 m, "
     << within(3, 4) << " at 3-4 m, " << within(4, 5) << " at 4-5 m, " << within(5, 100)
     << " beyond 5 m. Beyond 4 m a ball is under 30 pixels across and its 11 cm of relief spans two depth steps: "
        "a fist, a hand held before a body or a foot beside dark trousers then has a ball's size, outline and "
        "depth. The colour check (below) is what tells most of them apart: it rejects every phantom of its own "
        "crowds, which the rules were tuned on, but not every one of crowds like these.\n\n";

  const PeopleScores tuned = peopleScores(config, kTunedFirstSeed, kTunedSeeds, nullptr);
  md << "On the seeds the rules were first set on (" << kTunedFirstSeed << "-" << kTunedFirstSeed + kTunedSeeds - 1
     << ", the same kinds): balls without a ball " << tuned.without_ball.reported << ", with a ball found in "
     << format("%.1f %%", 100.0 * tuned.with_ball.recall()) << " of " << tuned.with_ball.eligible
     << " counted frames and " << tuned.with_ball.off_truth
     << " off the truth. The gap to the table is how much those rules learnt of their own scenes.\n\n";
}

void sensorEffects(const fw::Config& config, const ReportOptions& options, std::ostream& md) {
  md << "## What dark panels, another Kinect and speed cost\n\n"
     << "The kicks above, each with one more effect, " << options.seeds
     << " noise seeds each; frames counted as above. *Dark panels*: a classic ball's 12 black pentagons (28 % of "
        "it) return no depth. *Another Kinect*: a second projector's pattern over an ellipse of the view (a "
        "tenth of it holed in patches of 2-5 px radius, 60 clusters of false depth a frame), as when two robots "
        "face. "
        "*Faster*: the high shot at 1.4 times its speed (15 m/s), smeared over the 12 ms exposure by 18 cm.\n\n"
        "| effect | scenes | frames | counted | found | reported balls | off the truth | median error | p95 error |\n"
        "|---|---|---|---|---|---|---|---|---|\n";
  const std::vector<std::string> kicks = {"kick_away", "ground_kick", "shot_goalkeeper", "shot_goalkeeper_low",
                                          "lob_goalkeeper"};
  auto row = [&](const char* effect, const std::vector<std::string>& names, const auto& change) {
    sim::DetectionScore score;
    for (const std::string& name : names) {
      for (int seed = 1; seed <= options.seeds; ++seed) {
        sim::Scene scene = sim::loadScene(name);
        scene.noise.seed = static_cast<std::uint64_t>(seed);
        change(scene);
        score.add(scoreScene(config, scene));
      }
    }
    md << "| " << effect << " | " << (names.size() == 1 ? "`" + names.front() + "`" : std::string("the five kicks"))
       << " | " << scoreColumns(score) << " |\n";
  };
  row("dark panels", kicks, [](sim::Scene& scene) { scene.ball->dark_panels = true; });
  row("another Kinect facing", kicks, [](sim::Scene& scene) { scene.noise.interference = 1.0; });
  row("another Kinect facing, no ball", {"clutter"}, [&](sim::Scene& scene) {
    scene.noise.interference = 1.0;
    scene.duration_s = options.clutter_frames / scene.fps / 5;
  });
  row("faster: 15 m/s", {"shot_goalkeeper"}, [](sim::Scene& scene) { scene.ball->velocity_mps *= 1.4; });
  md << "\n";
}

void phantoms(const fw::Config& config, const ReportOptions& options, std::ostream& md) {
  md << "## Phantom balls\n\n"
     << "| data | frames | balls reported | per 1,000 frames | target |\n|---|---|---|---|---|\n";
  sim::Scene clutter = sim::loadScene("clutter");
  clutter.duration_s = options.clutter_frames / clutter.fps;
  const sim::DetectionScore score = scoreScene(config, clutter);
  const double per_1000 = 1000.0 * score.reported / std::max(score.frames, 1);
  md << "| `clutter` (robots driving, people walking, goal, wall, no ball) | " << score.frames << " | "
     << score.reported << " | " << format("%.2f", per_1000) << " | <= 1: " << (per_1000 <= 1.0 ? "met" : "**not met**")
     << " |\n";
  // Scenes where the space around a structure has no depth, or where structures end.
  const std::pair<const char*, const char*> structures[] = {
      {"range_edge", "a corner, a wall end and a loudspeaker on a wall at and beyond the 9.5 m range"},
      {"corners_doors", "room corner, pillar, doorway with an open door, wall end"}};
  for (const auto& [name, what] : structures) {
    const sim::Scene scene = sim::loadScene(name);
    const sim::DetectionScore s = scoreScene(config, scene);
    md << "| `" << name << "` (" << what << ") | " << s.frames << " | " << s.reported
       << " | - | 0: " << (s.reported == 0 ? "met" : "**not met**") << " |\n";
  }

  md << "\n";
}

void realFrames(const fw::Config& config, const ReportOptions& options, std::ostream& md) {
  md << "## Real frames\n\n";
  if (options.real_data_dir.empty()) {
    md << "Not run: no `--real-data` folder (third-party frames, never in the repository).\n\n";
    return;
  }
  md << "Real Kinect-class frames from public datasets, in the folders `real-depth/` and `realdata/` of the "
        "`--real-data` folder (each folder's README gives origin and licence). None shows a ball: every ball reported "
        "is a phantom. "
        "Each image is played twice as a TUM sequence (640 x 480, fx = fy = 525); the floor is searched for as a "
        "robot without a configured mounting would, or the mounting is given where it was measured.\n\n"
        "| frames | what they show | floor | frames played | floor found | balls reported | target |\n"
        "|---|---|---|---|---|---|---|\n";
  const DetectorConfig shipped = readDetectorConfig(config.block("kinect3d"));
  DetectorConfig searching = shipped;
  searching.ground.pose.reset();
  const std::string dir = options.real_data_dir + "/";
  auto row = [&](const std::string& name, const char* what, const char* floor, const std::vector<std::string>& images,
                 double cx, double cy, const DetectorConfig& detector, int units_per_m = 1000) {
    const sim::RealFramesResult r = sim::detectOnDepthImages(images, cx, cy, detector, units_per_m);
    md << "| `" << name << "` | " << what << " | " << floor << " | " << r.frames << " | "
       << (r.aligned ? "yes" : "**no**") << " | " << r.balls << " | 0: " << (r.balls == 0 ? "met" : "**not met**")
       << " |\n";
  };
  row("real-depth/tum_depth.png", "an office desk (TUM RGB-D, 1/5000 m)", "searched",
      {dir + "real-depth/tum_depth.png"}, 319.5, 239.5, searching, 5000);
  const std::string people = "realdata/pcl_single_frames/five_people_depth_mm.png";
  row(people, "five people walking down a corridor, close, one cut by the view's edge", "searched", {dir + people},
      319.5, 239.5, searching);
  const std::string office = "realdata/pcl_single_frames/office1_depth_mm.png";
  row(office, "an office, the floor in the bottom fifth of the view", "searched", {dir + office}, 320, 240, searching);
  DetectorConfig measured = shipped;
  measured.ground.pose = fw::SensorPose{0.0, 0.0, 1.38, 0.0, 0.0, 0.0};
  row(office, "the same", "measured: level, 1.38 m up", {dir + office}, 320, 240, measured);
  std::vector<std::string> grabber;
  for (const char* stamp : {"20121214T142255.814212", "20121214T142256.068683", "20121214T142256.332395"}) {
    grabber.push_back(dir + "realdata/pcl_grabber_sequences/frame_" + stamp + "_depth.tiff");
  }
  row("realdata/pcl_grabber_sequences/frame_*_depth.tiff", "a floor with a laptop and a box, 3 frames", "searched",
      grabber, 320, 240, searching);

  // The NYU frame is raw disparity, converted by the Kinect's own formula.
  BallDetector nyu_detector(searching, "kinect3d");
  Detections detections;
  nyu_detector.detect(loadRawDisparityPgm(dir + "real-depth/nyu_raw_disparity.pgm"), detections);
  const int nyu_balls = static_cast<int>(detections.balls.size());
  md << "| `real-depth/nyu_raw_disparity.pgm` | a room (NYU Depth v2), raw disparity | searched | 1 | "
     << (detections.aligned ? "yes" : "**no**") << " | " << nyu_balls
     << " | 0: " << (nyu_balls == 0 ? "met" : "**not met**") << " |\n\n";
}

// The three match balls, each learnt from a simulated calibration session in its hall's light (the
// same light, ball and camera in the session and the match scenes, the rest drawn from each seed).
struct LearntBall {
  std::string name;
  sim::ColourLook look;
  BallColourFit fit;
};

sim::CalibrationSession colourSession(const sim::ColourLook& look) {
  sim::CalibrationSession session;
  session.pose = fw::SensorPose{0.0, 0.0, 0.7, 0.0, fw::degreesToRadians(-6.0), 0.0};
  session.noise_seed = 5;
  session.colour = look;
  return session;
}

std::vector<LearntBall> learnBalls(const fw::Config& config) {
  std::vector<LearntBall> balls;
  const DetectorConfig detector = readDetectorConfig(config.block("kinect3d"));
  for (const std::string& name : sim::ColourLook::ballNames()) {
    const sim::ColourLook look = sim::ColourLook::withBall(name);
    balls.push_back({name, look, sim::learnBallColourInSession(colourSession(look), detector)});
  }
  return balls;
}

// The detector with the colour check on, with a learnt model.
DetectorConfig withColourCheck(const fw::Config& config, const sim::Scene& scene, const BallColourModel& model) {
  DetectorConfig detector = configFor(config, scene);
  detector.colour.mode = ColourCheckConfig::Mode::kOn;
  detector.colour.ball_colours = model;
  return detector;
}

// Colour off and on over the same frames (the check changes no detection, only its flag), and the
// verdicts on the true ball.
struct ColourScore {
  sim::DetectionScore off, on;
  int confirmed = 0, no_evidence = 0, rejected = 0;  // of the reported balls on the truth
  std::vector<double> check_s;                       // the colour stage's time per checked ball
  void add(const ColourScore& other) {
    off.add(other.off);
    on.add(other.on);
    confirmed += other.confirmed, no_evidence += other.no_evidence, rejected += other.rejected;
    check_s.insert(check_s.end(), other.check_s.begin(), other.check_s.end());
  }
  void add(const std::vector<sim::EvaluatedFrame>& frames, const sim::Scene& scene) {
    off.add(sim::scoreFrames(frames, scene, {}));
    on.add(sim::scoreFrames(sim::followedOnly(frames), scene, {}));
    const sim::EvaluationCriteria criteria;
    for (const sim::EvaluatedFrame& f : frames) {
      if (!f.balls.empty()) check_s.push_back(f.colour_s / f.balls.size());
      for (const fw::BallObservation& b : f.balls) {
        if (!f.truth.has_ball || (b.position_m - f.truth.ball_center_R).norm() > criteria.match_m) continue;
        confirmed += b.colour == fw::ColourVerdict::kConfirmed;
        no_evidence += b.colour == fw::ColourVerdict::kNoEvidence;
        rejected += b.colour == fw::ColourVerdict::kRejected;
      }
    }
  }
};

std::string colourColumns(const ColourScore& s) {
  std::ostringstream columns;
  columns << s.off.frames << " | " << s.off.eligible << " | " << format("%.1f %%", 100.0 * s.off.recall()) << " | "
          << format("%.1f %%", 100.0 * s.on.recall()) << " | " << s.off.off_truth << " | " << s.on.off_truth << " | "
          << s.confirmed << " / " << s.no_evidence << " / " << s.rejected;
  return columns.str();
}

void realColourFrames(const ReportOptions& options, const std::vector<LearntBall>& balls, std::ostream& md);

void colourCheck(const fw::Config& config, const ReportOptions& options, std::ostream& md) {
  md << "## The colour check\n\n"
        "Each match ball's colours are learnt as `kinect3d calibrate ball-colour` learns them, from a simulated "
        "calibration session (the ball on four marks, 4 s, in the hall's light), then the scenes are played with "
        "colour and the check on (docs/colour.md). The colours of everything but the ball (clothes of every colour, "
        "one shirt in four orange or yellow, skin, hair, walls, posters) and the light's direction and slope over "
        "the frame are drawn from each scene's seed; the report's people seeds ("
     << 1000 + 1 << "-" << 1000 + options.colour_seeds
     << ") are not those the check was tuned on (1-6, orange ball only).\n\n"
        "### The match balls learnt\n\n"
        "| ball | colours: L*, a*, b* (share) | ball's pixels explained | everything else's | ball's discs: score "
        "p10 | discs elsewhere: score p99 |\n|---|---|---|---|---|---|\n";
  const std::vector<LearntBall> balls = learnBalls(config);
  for (const LearntBall& ball : balls) {
    std::string colours;
    for (const BallColour& c : ball.fit.model) {
      colours += (colours.empty() ? "" : "; ") + format("%.0f, ", c.lab.x()) + format("%.0f, ", c.lab.y()) +
                 format("%.0f", c.lab.z()) + format(" (%.0f %%)", 100 * c.share);
    }
    md << "| " << ball.name << " | " << colours << " | " << format("%.1f %%", 100 * ball.fit.ball_explained) << " | "
       << format("%.1f %%", 100 * ball.fit.other_explained) << " | " << format("%.2f", ball.fit.ball_score_p10) << " | "
       << format("%.2f", ball.fit.other_score_p99) << " |\n";
  }
  md << "\n### Colour off and on\n\n"
        "Frames counted and found as for the kicks; *off the truth* counts reported balls farther than 0.3 m from "
        "the true ball (phantoms), with colour on only those not rejected. Both come from one run with the check "
        "on: *off* counts every reported ball, the rejected ones too, and beyond "
     << format("%.0f m", readDetectorConfig(config.block("kinect3d")).second_sight_beyond_m)
     << " a ball the colour confirms is reported from its first frame (second sight, docs/architecture.md) in both. "
        "*Verdicts* are those on the true ball: confirmed / no evidence (blurred, weak, too dark ...) / rejected. "
        "People: the four kinds of the people section, "
     << options.colour_seeds
     << " seeds each. Confusers: `colour_confusers` (ball-sized lamps, a loudspeaker, posters with a ball printed "
        "on them, a person in orange) and `lamp_in_view`.\n\n"
        "| ball | scenes | frames | counted | found: off | found: on | off the truth: off | on | verdicts |\n"
        "|---|---|---|---|---|---|---|---|---|\n";
  auto play = [&](const LearntBall& ball, sim::Scene scene, ColourScore& score, const auto& change) {
    scene.look.ball_albedo = ball.look.ball_albedo;
    scene.look.panel_albedo = ball.look.panel_albedo;
    change(scene);
    score.add(sim::runDetectorOnScene(scene, withColourCheck(config, scene, ball.fit.model)), scene);
  };
  const auto unchanged = [](sim::Scene&) {};
  const std::vector<std::string> kicks = {"kick_away", "ground_kick", "shot_goalkeeper", "shot_goalkeeper_low",
                                          "lob_goalkeeper"};
  ColourScore good_light;
  for (const LearntBall& ball : balls) {
    ColourScore people, confusers, kicked;
    for (int seed = 1001; seed <= 1000 + options.colour_seeds; ++seed) {
      for (const sim::CrowdBall kind : {sim::CrowdBall::kNone, sim::CrowdBall::kThrownFromHands,
                                        sim::CrowdBall::kOverAHead, sim::CrowdBall::kFromTheBorder}) {
        play(ball, sim::crowdScene(seed, kind), people, unchanged);
      }
    }
    for (const char* name : {"colour_confusers", "lamp_in_view"})
      play(ball, sim::loadScene(name), confusers, unchanged);
    for (const std::string& name : kicks) play(ball, sim::loadScene(name), kicked, unchanged);
    md << "| " << ball.name << " | people | " << colourColumns(people) << " |\n"
       << "| " << ball.name << " | confusers | " << colourColumns(confusers) << " |\n"
       << "| " << ball.name << " | the five kicks | " << colourColumns(kicked) << " |\n";
    for (const ColourScore* s : {&people, &confusers, &kicked}) good_light.add(*s);
  }
  const double drop = 100.0 * (good_light.off.recall() - good_light.on.recall());
  md << "| **all** | | " << colourColumns(good_light) << " |\n\n"
     << "In good light, colour on: phantoms " << good_light.on.off_truth << " of " << good_light.off.off_truth
     << (good_light.on.off_truth == 0 ? " (target 0: met)" : " (target 0: **not met**)") << "; found in "
     << good_light.on.found << " of " << good_light.on.eligible << " frames, "
     << format("%.2f %%", 100.0 * good_light.on.recall()) << ", against " << good_light.off.found << ", "
     << format("%.2f %%", 100.0 * good_light.off.recall()) << ", off: " << format("%.2f", drop) << " points less"
     << (good_light.on.recall() >= 0.95 && drop <= 1.0 ? " (target >= 95 %, within 1 point: met)"
                                                       : " (target >= 95 %, within 1 point: **not met**)")
     << ".\n\n";

  md << "### What bad light costs\n\n"
        "The orange ball learnt in each hall's own light, then the people and the kicks in that light.\n\n"
        "| light | scenes | frames | counted | found: off | found: on | off the truth: off | on | verdicts |\n"
        "|---|---|---|---|---|---|---|---|---|\n";
  const std::pair<const char*, std::function<void(sim::ColourLook&)>> lights[] = {
      {"dim hall (a third of the light)", [](sim::ColourLook& look) { look.light = 0.33; }},
      {"uneven (+-70 % over the frame)", [](sim::ColourLook& look) { look.light_gradient = 0.7; }},
      {"bright (twice the light: the ball's lit side clips)", [](sim::ColourLook& look) { look.light = 2.0; }},
      {"long exposure (40 ms: more blur)", [](sim::ColourLook& look) { look.exposure_s = 0.04; }}};
  const DetectorConfig detector = readDetectorConfig(config.block("kinect3d"));
  for (const auto& [label, change_light] : lights) {
    sim::ColourLook look = sim::ColourLook::withBall("orange");
    change_light(look);
    const LearntBall ball{"orange", look, sim::learnBallColourInSession(colourSession(look), detector)};
    ColourScore score;
    const auto in_this_light = [&](sim::Scene& scene) { scene.look = look; };
    for (int seed = 1001; seed <= 1000 + options.colour_seeds / 2; ++seed) {
      for (const sim::CrowdBall kind :
           {sim::CrowdBall::kNone, sim::CrowdBall::kOverAHead, sim::CrowdBall::kFromTheBorder}) {
        play(ball, sim::crowdScene(seed, kind), score, in_this_light);
      }
    }
    for (const std::string& name : kicks) play(ball, sim::loadScene(name), score, in_this_light);
    md << "| " << label << " | people, kicks | " << colourColumns(score) << " |\n";
  }
  md << "\n### Cost\n\n"
     << "The colour stage per checked ball (projection, colours of the disc in L*a*b*, Sobel on its patch), over "
     << good_light.check_s.size() << " frames with balls above: median "
     << format("%.0f us", 1e6 * fw::quantile(good_light.check_s, 0.5)) << ", p99 "
     << format("%.0f us", 1e6 * fw::quantile(good_light.check_s, 0.99))
     << " on the machine that wrote this report (one core).\n\n";
  realColourFrames(options, balls, md);
}

// Every place a ball could be in a real colour frame: a ball-sized sphere behind each surface point
// on a 16-pixel grid, checked against each learnt ball. Nothing there is a ball.
void realColourFrames(const ReportOptions& options, const std::vector<LearntBall>& balls, std::ostream& md) {
  if (options.real_data_dir.empty()) return;
  md << "### Real colour frames\n\n"
        "The real frames with registered colour (depth and colour from one camera: fx = fy = 525), none holding a "
        "ball. A ball-sized sphere is placed behind the surface at every 16th pixel with depth and checked against "
        "each learnt ball: nothing may be confirmed.\n\n"
        "| frames | ball | places checked | confirmed | no evidence | rejected | target "
        "|\n|---|---|---|---|---|---|---|\n";
  const std::string dir = options.real_data_dir + "/realdata/";
  struct RealColourFrame {
    std::string label, depth, colour;
    double cx, cy;
  };
  std::vector<RealColourFrame> frames = {{"pcl_single_frames/five_people", "pcl_single_frames/five_people_depth_mm.png",
                                          "pcl_single_frames/five_people_rgb.png", 319.5, 239.5},
                                         {"pcl_single_frames/office1", "pcl_single_frames/office1_depth_mm.png",
                                          "pcl_single_frames/office1_rgb.png", 320, 240}};
  for (const char* stamp : {"20121214T142255.814212", "20121214T142256.068683", "20121214T142256.332395"}) {
    const std::string base = std::string("pcl_grabber_sequences/frame_") + stamp;
    frames.push_back({base, base + "_depth.tiff", base + "_rgb.tiff", 320, 240});
  }
  for (const LearntBall& ball : balls) {
    for (const RealColourFrame& f : frames) {
      const sim::RealColourCheck r = sim::checkEverywhere(dir + f.depth, dir + f.colour, f.cx, f.cy, ball.fit.model);
      md << "| `" << f.label << "` | " << ball.name << " | " << r.places << " | " << r.confirmed << " | "
         << r.no_evidence << " | " << r.rejected << " | 0: " << (r.confirmed == 0 ? "met" : "**not met**") << " |\n";
    }
  }
  md << "\n";
}

}  // namespace

void writeAccuracyReport(const fw::Config& config, const ReportOptions& options, const std::string& out_path) {
  std::ostringstream md;
  md << "# Detection accuracy\n\n"
        "Generated by `build/bin/kinect3d report detection --out docs/accuracy.md --real-data <real frames>` "
        "(about 18 minutes on one core of the development machine; the real frames are third-party data, not in the "
        "repository: docs/cli.md). "
        "Every number below comes from that run: the simulator with every noise effect on "
        "(docs/simulator.md), the detector with the shipped defaults (config/defaults/kinect3d.yaml) "
        "and the scene's sensor pose, as a robot file would give it.\n\n";
  table1(config, md);
  partialOcclusion(config, md);
  kicks(config, options, md);
  people(config, options, md);
  sensorEffects(config, options, md);
  phantoms(config, options, md);
  realFrames(config, options, md);
  colourCheck(config, options, md);
  std::ofstream out(out_path);
  out << md.str();
  if (!out) throw std::runtime_error("cannot write '" + out_path + "'");
  fw::logInfo("report", "wrote " + out_path);
}

}  // namespace kinect3d
