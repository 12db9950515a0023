#include "match_report.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>

#include "chart_page.h"
#include "framework_api/config.h"
#include "framework_api/log.h"
#include "matchlog/match_log.h"
#include "recorded_truth.h"

namespace kinect3d {

extern const std::string kMatchReportPage;  // match_report/index.html, built in

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr std::size_t kMaxFlights = 12;
constexpr int kPathSamples = 40;
constexpr double kFrame_s = 1.0 / 30.0;  // the depth sensor's frame time, to find a fit's first detection
constexpr double kMaxAhead_s = 1.5;      // a predicted path is drawn this far past the last fit at most

struct Xyz {
  std::vector<double> x, y, z;
  void add(const Eigen::Vector3d& p) {
    x.push_back(p.x());
    y.push_back(p.y());
    z.push_back(p.z());
  }
  json toJson() const { return {{"x_m", x}, {"y_m", y}, {"z_m", z}}; }
};

std::string localTime(double wall_time_s) {
  const std::time_t seconds = static_cast<std::time_t>(wall_time_s);
  std::tm local{};
  localtime_r(&seconds, &local);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S", &local);
  return text;
}

// One flight: the trajectory updates between two losses of the ball, with the detections they rest on.
struct Flight {
  std::vector<fw::BallTrajectory> fits;
};

// A flight's page entry. to_run_s maps the depth sensor's clock onto seconds since the run started.
json flightJson(const Flight& flight, const std::vector<fw::BallObservation>& balls, const RecordedTruth& truth,
                const std::function<double(double)>& to_run_s) {
  const fw::BallTrajectory& last = flight.fits.back();
  // From the detections the first fit rested on (a segment keeps at most a second of them) to the
  // last fit, and on to where it predicted the ball lands.
  const double first_s = flight.fits.front().time_s - kFrame_s * (flight.fits.front().support - 1);
  double to_s = last.time_s;
  if (last.touchdown) to_s = std::min(std::max(to_s, last.touchdown->time_s), last.time_s + kMaxAhead_s);
  Xyz detections, touchdowns, path, true_path;
  for (const fw::BallObservation& ball : balls) {
    const double t = ball.stamp.source_time_s;
    if (t >= first_s - 1e-6 && t <= last.time_s + 1e-6) detections.add(ball.position_m);
  }
  for (const fw::BallTrajectory& fit : flight.fits) {
    if (!fit.touchdown) continue;
    touchdowns.add({fit.touchdown->point_m.x(), fit.touchdown->point_m.y(), fit.positionAt(fit.touchdown->time_s).z()});
  }
  for (int i = 0; i <= kPathSamples; ++i) {
    const double t = first_s + (to_s - first_s) * i / kPathSamples;
    const Eigen::Vector3d p = last.positionAt(t);
    if (p.z() < 0.0) break;  // the model knows no floor: the touchdown is where its path ends
    path.add(p);
    if (truth.known()) true_path.add(truth.ball_R(t));
  }
  char title[96];
  std::snprintf(title, sizeof title, "%s at %.1f s, %zu fits", fw::toString(last.state), to_run_s(first_s),
                flight.fits.size());
  json flight_json = {{"title", title},
                      {"detections", detections.toJson()},
                      {"touchdowns", touchdowns.toJson()},
                      {"fit", path.toJson()}};
  if (truth.known()) flight_json["truth"] = true_path.toJson();
  return flight_json;
}

}  // namespace

void writeMatchReport(const std::string& log_folder, const std::string& out_dir) {
  const fw::MatchLogReader log(log_folder);
  const std::vector<fw::JournalEntry> entries = log.entries();
  const fw::RunInfo& run = log.run();
  const double start_s = run.start_wall_time_s;
  const auto sources = log.depthSources();
  const std::string depth_source = sources.empty() ? "kinect3d" : sources.front().first;
  const RecordedTruth truth(run);

  std::map<std::string, std::vector<double>> seen;  // source -> wall times it saw a ball
  std::vector<fw::BallObservation> depth_balls;
  std::vector<double> depth_ball_t;
  Xyz fused_heights;
  std::vector<double> fused_t;
  std::vector<Flight> flights;
  bool flight_open = false;
  std::map<std::string, std::vector<fw::PluginHealth>> health;
  json events = json::array();
  double last_wall_s = start_s;
  // The depth sensor's clock against the host's, to put source times on the timeline.
  const std::optional<double> source_minus_host_s = log.clockOffset_s(depth_source);
  for (const fw::JournalEntry& entry : entries) {
    const double t = entry.wall_time_s - start_s;
    last_wall_s = std::max(last_wall_s, entry.wall_time_s);
    if (const auto* frame = std::get_if<fw::BallFrame>(&entry.item)) {
      for (const fw::BallObservation& ball : frame->balls) {
        seen[ball.source].push_back(t);
        if (ball.source != depth_source) continue;
        depth_balls.push_back(ball);
        depth_ball_t.push_back(t);
      }
    } else if (const auto* omni = std::get_if<fw::OmniFrame>(&entry.item)) {
      for (const fw::OmniBallObservation& ball : omni->balls) seen[ball.source].push_back(t);
    } else if (const auto* fused = std::get_if<fw::FusedBall>(&entry.item)) {
      seen["fused"].push_back(t);
      fused_heights.add(fused->position_F);
      fused_t.push_back(t);
    } else if (const auto* fit = std::get_if<fw::BallTrajectory>(&entry.item)) {
      if (fit->source != depth_source) continue;
      if (!flight_open) flights.emplace_back();
      flight_open = true;
      flights.back().fits.push_back(*fit);
    } else if (const auto* lost = std::get_if<fw::TrajectoryCleared>(&entry.item)) {
      if (lost->source == depth_source) flight_open = false;
    } else if (const auto* h = std::get_if<fw::PluginHealth>(&entry.item)) {
      health[h->plugin].push_back(*h);
    } else if (const auto* event = std::get_if<fw::Event>(&entry.item)) {
      events.push_back({{"t_s", t}, {"source", event->source}, {"kind", event->kind}, {"message", event->message}});
    }
  }

  json match;
  match["run"] = {{"robot", run.robot},
                  {"start", localTime(start_s)},
                  {"duration_s", last_wall_s - start_s},
                  {"software_version", run.software_version},
                  {"replayed_from", run.replayed_from},
                  {"folder", log_folder}};
  json timeline = json::array();
  for (const auto& [source, times] : seen) timeline.push_back({{"source", source}, {"t_s", times}});
  match["timeline"] = timeline;

  json height = json::array();
  std::vector<double> depth_z;
  for (const fw::BallObservation& ball : depth_balls) depth_z.push_back(ball.position_m.z());
  height.push_back({{"label", depth_source + " (robot frame)"},
                    {"colour", depth_source},
                    {"t_s", depth_ball_t},
                    {"z_m", depth_z},
                    {"line", false}});
  height.push_back({{"label", "fused (field frame)"},
                    {"colour", "fused"},
                    {"t_s", fused_t},
                    {"z_m", fused_heights.z},
                    {"line", false}});
  if (truth.known() && source_minus_host_s) {
    std::vector<double> t_s, z_m;
    for (double t = 0.0; t <= last_wall_s - start_s; t += kFrame_s) {
      t_s.push_back(t);
      z_m.push_back(truth.ball_R(start_s + t + *source_minus_host_s).z());
    }
    height.push_back({{"label", "truth"}, {"colour", "truth"}, {"t_s", t_s}, {"z_m", z_m}, {"line", true}});
  }
  match["height"] = height;

  json flights_json = json::array();
  const auto to_run_s = [&](double source_time_s) {
    return source_minus_host_s ? source_time_s - *source_minus_host_s - start_s : 0.0;
  };
  for (const Flight& flight : flights) {
    if (flights_json.size() >= kMaxFlights) break;
    if (flight.fits.size() >= 2) flights_json.push_back(flightJson(flight, depth_balls, truth, to_run_s));
  }
  match["flights"] = flights_json;

  json plugins = json::array();
  for (const auto& [plugin, seconds] : health) {
    std::uint64_t frames = 0, dropped = 0, errors = 0, stuck = 0;
    std::vector<double> p50s, t_s, p99s, latency_p50s, latency_p99s;
    double p99 = 0.0, busy_s = 0.0;
    for (const fw::PluginHealth& h : seconds) {
      frames += h.frames;
      busy_s += h.processing_total_s;
      if (!std::isnan(h.latency_p50_s)) {
        latency_p50s.push_back(h.latency_p50_s);
        latency_p99s.push_back(h.latency_p99_s);
      }
      dropped = std::max(dropped, h.dropped_frames);
      errors = std::max(errors, h.errors);
      stuck = std::max(stuck, h.stuck);
      if (h.frames == 0) continue;
      p50s.push_back(h.processing_p50_s);
      p99 = std::max(p99, h.processing_p99_s);
      t_s.push_back(h.wall_time_s - start_s);
      p99s.push_back(h.processing_p99_s);
    }
    plugins.push_back({{"plugin", plugin},
                       {"seconds", seconds.size()},
                       {"frames", frames},
                       {"rate_hz", seconds.empty() ? 0.0 : static_cast<double>(frames) / seconds.size()},
                       {"p50_s", p50s.empty() ? 0.0 : fw::quantile(p50s, 0.5)},
                       {"p99_s", p99},
                       {"core_share", seconds.empty() ? 0.0 : busy_s / seconds.size()},
                       // Over the seconds that measured it: the median second's p50 and p99, the worst p99.
                       {"latency", latency_p50s.empty() ? json()
                                                        : json{{"p50_s", fw::quantile(latency_p50s, 0.5)},
                                                               {"p99_s", fw::quantile(latency_p99s, 0.5)},
                                                               {"worst_p99_s", *std::max_element(latency_p99s.begin(),
                                                                                                 latency_p99s.end())}}},
                       {"dropped_frames", dropped},
                       {"errors", errors},
                       {"stuck", stuck},
                       {"per_second", {{"t_s", t_s}, {"p99_s", p99s}}}});
  }
  match["plugins"] = plugins;
  match["events"] = events;

  writeChartPage(out_dir, kMatchReportPage, "match_data.js", "MATCH", match.dump());
  fw::logInfo("report", "match report of " + log_folder + " in " + (fs::path(out_dir) / "index.html").string() + ": " +
                            std::to_string(flights_json.size()) + " flights, " + std::to_string(events.size()) +
                            " events");
}

}  // namespace kinect3d
