#include "detect_line.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "framework_api/host.h"
#include "framework_api/install_layout.h"
#include "framework_api/log.h"

namespace kinect3d {

std::string detectLine(std::uint64_t frame_index, double t_s, const std::vector<fw::BallObservation>& balls,
                       std::optional<double> process_s, const std::optional<fw::BallTrajectory>& trajectory) {
  char text[512];
  std::snprintf(text, sizeof text, "{\"frame\": %llu, \"t\": %.6f, \"balls\": [",
                static_cast<unsigned long long>(frame_index), t_s);
  std::string line = text;
  for (std::size_t i = 0; i < balls.size(); ++i) {
    const fw::BallObservation& ball = balls[i];
    std::snprintf(text, sizeof text,
                  "%s{\"x\": %.4f, \"y\": %.4f, \"z\": %.4f, \"state\": \"%s\", \"points\": %d, "
                  "\"static\": %s, \"colour\": \"%s\"}",
                  i ? ", " : "", ball.position_m.x(), ball.position_m.y(), ball.position_m.z(),
                  fw::toString(ball.state), ball.support_points, ball.is_static ? "true" : "false",
                  fw::toString(ball.colour));
    line += text;
  }
  if (process_s) {
    std::snprintf(text, sizeof text, "], \"process_ms\": %.3f, \"trajectory\": ", *process_s * 1e3);
    line += text;
  } else {
    line += "], \"process_ms\": null, \"trajectory\": ";
  }
  if (!trajectory) return line + "null}";
  const Eigen::Vector3d& p = trajectory->position_m;
  const Eigen::Vector3d& v = trajectory->velocity_mps;
  std::snprintf(text, sizeof text,
                "{\"p\": [%.4f, %.4f, %.4f], \"v\": [%.4f, %.4f, %.4f], \"state\": \"%s\", "
                "\"support\": %d, \"rms_m\": %.4f, \"touchdown\": ",
                p.x(), p.y(), p.z(), v.x(), v.y(), v.z(), fw::toString(trajectory->state), trajectory->support,
                trajectory->rms_m);
  line += text;
  if (const auto& touchdown = trajectory->touchdown) {
    std::snprintf(text, sizeof text, "{\"x\": %.4f, \"y\": %.4f, \"t\": %.6f, \"sigma_m\": %.4f}",
                  touchdown->point_m.x(), touchdown->point_m.y(), touchdown->time_s, touchdown->sigma_m);
    line += text;
  } else {
    line += "null";
  }
  line += ", \"crossing\": ";
  if (const auto& crossing = trajectory->crossing) {
    std::snprintf(text, sizeof text, "{\"x\": %.4f, \"z\": %.4f, \"t\": %.6f}", crossing->x_m, crossing->z_m,
                  crossing->time_s);
    line += text;
  } else {
    line += "null";
  }
  return line + "}}";
}

void DetectLines::add(const fw::DepthImage& image) {
  if (image.source != source_) return;
  flush();
  frame_ = Frame{image.index, image.stamp.source_time_s, {}};
}

void DetectLines::add(const fw::WorldItem& item) {
  if (const auto* image = std::get_if<fw::DepthImage>(&item)) {
    add(*image);
  } else if (const auto* frame = std::get_if<fw::BallFrame>(&item)) {
    if (frame_ && frame->source == source_) frame_->balls = frame->balls;
  } else if (const auto* fit = std::get_if<fw::BallTrajectory>(&item)) {
    if (fit->source == source_) trajectory_ = *fit;
  } else if (const auto* lost = std::get_if<fw::TrajectoryCleared>(&item)) {
    if (lost->source == source_) trajectory_.reset();
  }
}

void DetectLines::flush(std::optional<double> process_s) {
  if (!frame_) return;
  write_(detectLine(frame_->index, frame_->t_s, frame_->balls, process_s, trajectory_));
  ++frames_;
  frames_with_ball_ += !frame_->balls.empty();
  frame_.reset();
}

void detect(const fw::Config& config, std::ostream& out, const std::string& out_name) {
  const std::string plugin = "kinect3d";
  fw::Host host(config, fw::defaultPluginDir());
  host.world().openJournal(true);  // the depth images give the frame numbers
  DetectLines lines(plugin, [&](const std::string& line) {
    out << line << "\n";
    out.flush();
    if (!out) throw std::runtime_error("cannot write the detections to " + out_name + ": " + std::strerror(errno));
  });
  host.replaySource(plugin, [&] {
    std::uint64_t refused = 0;
    for (const fw::JournalEntry& entry : host.world().takeJournal(&refused)) lines.add(entry.item);
    if (refused > 0)
      throw std::runtime_error("detect: " + std::to_string(refused) + " detections did not fit the journal");
    const std::vector<double> process_s = host.world().takeProcessingTimes(plugin);
    lines.flush(process_s.empty() ? std::nullopt : std::optional<double>(process_s.back()));
  });
  for (const fw::PluginSummary& summary : host.summaries()) {
    if (summary.gave_up) throw std::runtime_error(fw::formatSummary(summary));
    if (summary.errors > 0) fw::logWarn("detect", fw::formatSummary(summary));
  }
  fw::logInfo("detect", config.block(plugin).getString("source") + ": " + std::to_string(lines.frames()) +
                            " frames, ball in " + std::to_string(lines.framesWithBall()));
}

}  // namespace kinect3d
