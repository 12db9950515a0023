// console: prints what the world state holds (each source's newest ball, its trajectory, and the
// world's fused ball with the sources behind it), a line per change, at a fixed rate. It is how a
// person sees what the robot believes, and the visible end of the demo.
#include <cstdio>
#include <optional>
#include <string>

#include "framework_api/plugin.h"

namespace {

std::string formatPosition(const Eigen::Vector3d& p) {
  char text[96];
  std::snprintf(text, sizeof text, "(%+.2f, %+.2f, %+.2f) m", p.x(), p.y(), p.z());
  return text;
}

// ", lands at (+0.31, +6.20) m in 0.42 s (+-0.05 m)" and/or ", crosses y = 0 at x +0.20 z +0.95 in 0.30 s".
std::string describe(const fw::BallTrajectory& trajectory) {
  char text[160];
  std::string result;
  if (const auto& touchdown = trajectory.touchdown) {
    std::snprintf(text, sizeof text, ", lands at (%+.2f, %+.2f) m in %.2f s (+-%.2f m)", touchdown->point_m.x(),
                  touchdown->point_m.y(), touchdown->time_s - trajectory.time_s, touchdown->sigma_m);
    result += text;
  }
  if (const auto& crossing = trajectory.crossing) {
    std::snprintf(text, sizeof text, ", crosses y = 0 at x %+.2f z %+.2f in %.2f s", crossing->x_m, crossing->z_m,
                  crossing->time_s - trajectory.time_s);
    result += text;
  }
  return result;
}

// " world: air, field (+1.20, +3.40, +0.95) m, robot (...) m, 5.1 m/s +-0.04 m, from kinect3d+omni"
// and ", crosses the own goal line at x -0.40 z +0.60 (+-0.08 m) in 0.52 s (+-0.03 s)".
std::string describe(const fw::FusedBall& ball) {
  std::string sources;
  for (const std::string& source : ball.sources) sources += (sources.empty() ? "" : "+") + source;
  char text[96];
  std::snprintf(text, sizeof text, ", %.1f m/s +-%.2f m, from ", ball.velocity_F.norm(), ball.sigmaHorizontal_m());
  std::string crossing;
  if (const auto& c = ball.goal_crossing) {
    char more[128];
    std::snprintf(more, sizeof more, ", crosses the %s goal line at x %+.2f z %+.2f (+-%.2f m) in %.2f s (+-%.2f s)",
                  c->goal > 0 ? "opponent's" : "own", c->x_m, c->z_m, c->sigma_m, c->time_s - ball.stamp.source_time_s,
                  c->time_sigma_s);
    crossing = more;
  }
  return " world: " + std::string(fw::toString(ball.state)) + ", field " + formatPosition(ball.position_F) +
         ", robot " + formatPosition(ball.position_R) + text + sources + crossing;
}

class Console : public fw::Plugin {
 public:
  explicit Console(const fw::PluginContext& context)
      : world_(*context.world), max_age_s_(context.config.getDouble("max_age_s", 0.0, 60.0)) {}

  fw::StepResult step() override {
    const std::uint64_t version = world_.version();
    if (version == last_version_) return fw::StepResult::kIdle;
    last_version_ = version;
    const double now_s = fw::wallClockNow_s();
    std::string line;
    for (const std::string& source : world_.ballSources()) {
      // A source's ball while its newest frame has one: not the last one it saw, once it lost it.
      const std::optional<fw::BallFrame> newest = world_.newestBallFrame(source);
      if (!newest || newest->balls.empty() || now_s - newest->stamp.receive_time_s > max_age_s_) continue;
      const fw::BallObservation& ball = newest->balls.front();
      line += " " + source + ": " + fw::toString(ball.state) + " " + formatPosition(ball.position_m);
      if (const auto trajectory = world_.trajectory(source)) line += describe(*trajectory);
    }
    if (const auto fused = world_.fusedBall(); fused && now_s - fused->stamp.receive_time_s <= max_age_s_) {
      line += describe(*fused);
    }
    if (line.empty()) return fw::StepResult::kIdle;
    std::printf("[console] ball%s\n", line.c_str());
    std::fflush(stdout);
    return fw::StepResult::kProcessed;
  }

 private:
  fw::WorldState& world_;
  const double max_age_s_;
  std::uint64_t last_version_ = 0;
};

}  // namespace

FW_REGISTER_PLUGIN(Console, "console", "1.0.0")
