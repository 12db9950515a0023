#include "detect_line.h"

#include <cstdio>

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

}  // namespace kinect3d
