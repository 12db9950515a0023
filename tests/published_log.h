// What a run published, read back from its match log, to compare a live run with its replay.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "demo_log.h"
#include "matchlog/match_log.h"
#include "run_command.h"

// What a run published, one line per publication of one kind, every number to the last bit, the
// wall clock left out (when the host received or published something is not what a replay repeats).
struct Published {
  std::vector<std::string> detections, trajectories, events, world_balls;
};

inline Published publishedIn(const std::string& log_folder) {
  Published published;
  const auto line = [](auto... values) {
    std::ostringstream out;
    out << std::hexfloat;
    ((out << values << ' '), ...);
    return out.str();
  };
  const auto vector = [](const Eigen::MatrixXd& m) {
    std::ostringstream out;
    out << std::hexfloat;
    for (Eigen::Index i = 0; i < m.size(); ++i) out << m(i) << ',';
    return out.str();
  };
  for (const fw::JournalEntry& entry : fw::MatchLogReader(log_folder).entries()) {
    if (const auto* frame = std::get_if<fw::BallFrame>(&entry.item)) {
      std::string balls;
      for (const fw::BallObservation& b : frame->balls) {
        balls += line(b.source, b.stamp.source_time_s, fw::toString(b.frame), fw::toString(b.state),
                      vector(b.position_m), vector(b.covariance_m2), b.support_points, b.is_static,
                      fw::toString(b.colour), fw::toString(b.colour_note), b.colour_score);
      }
      published.detections.push_back(frame->source + " " + balls);
    } else if (const auto* fit = std::get_if<fw::BallTrajectory>(&entry.item)) {
      published.trajectories.push_back(
          line(fit->source, fit->time_s, vector(fit->position_m), vector(fit->velocity_mps), fw::toString(fit->state),
               fit->drag_per_m, fit->curve_radps, fit->rolling_decel_mps2, fit->support, fit->rms_m,
               fit->touchdown ? vector(fit->touchdown->point_m) : "-", fit->touchdown ? fit->touchdown->time_s : 0.0,
               fit->crossing ? fit->crossing->time_s : 0.0));
    } else if (const auto* lost = std::get_if<fw::TrajectoryCleared>(&entry.item)) {
      published.trajectories.push_back("lost " + lost->source);
    } else if (const auto* event = std::get_if<fw::Event>(&entry.item)) {
      // What the disk and the robot network did is not what a replay repeats.
      if (event->source != "logger" && event->source != "team") {
        published.events.push_back(line(event->source, event->kind, event->message, event->stamp.source_time_s,
                                        event->value ? *event->value : 0.0));
      }
    } else if (const auto* ball = std::get_if<fw::FusedBall>(&entry.item)) {
      std::string sources;
      for (const std::string& source : ball->sources) sources += source + ",";
      published.world_balls.push_back(
          line(ball->stamp.source_time_s, vector(ball->position_F), vector(ball->position_R), vector(ball->velocity_F),
               vector(ball->covariance_F), fw::toString(ball->state), ball->air_probability, sources, ball->age_s));
    } else if (const auto* none = std::get_if<fw::FusedBallCleared>(&entry.item)) {
      published.world_balls.push_back(line("no ball", none->stamp.source_time_s));
    }
  }
  return published;
}

// `kinect3d replay` of a log into the folder out, with extra arguments; the run folder it made.
inline std::string replayInto(const std::string& log, const std::filesystem::path& out, const std::string& extra = "") {
  const auto [status, output] =
      runCommand(std::string(KINECT3D_EXE) + " replay " + log + " --output " + out.string() + " " + extra + " 2>&1");
  if (status != 0) throw std::runtime_error("kinect3d replay exited " + std::to_string(status) + ":\n" + output);
  return onlySubfolder(out);
}

// Compares two lists line by line, naming the first difference.
inline void expectSame(const std::vector<std::string>& live, const std::vector<std::string>& replayed,
                       const char* what) {
  ASSERT_EQ(live.size(), replayed.size()) << what;
  for (std::size_t i = 0; i < live.size(); ++i) ASSERT_EQ(live[i], replayed[i]) << what << " " << i;
}
