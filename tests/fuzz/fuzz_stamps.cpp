// The pipeline's stages that sort, wait, pace or interpolate by time, fed stamps of every kind:
// jumps forwards and backwards by any amount, repeats, NaN and infinities, from each source in any
// order. A stage may drop a frame, never crash, hang (libFuzzer's -timeout), or publish a ball that
// is not finite. Each record is 1 byte (which source) + 8 bytes (its stamp, a raw double) + 3 bytes
// (where the ball is).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "framework_api/replay_clock.h"
#include "fusion/alignment_check.h"
#include "fusion/ball_fusion.h"
#include "kinect3d/trajectory.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const fusion::FusionConfig config;
  fusion::BallFusion fusion(config);
  fusion::AlignmentCheck alignment(config, Eigen::Vector2d::Zero());
  kinect3d::TrajectoryConfig ballistic, paper;
  paper.mode = kinect3d::TrajectoryConfig::Mode::kPaper;
  const std::unique_ptr<kinect3d::TrajectoryEstimator> trajectories[] = {kinect3d::makeTrajectoryEstimator(ballistic),
                                                                         kinect3d::makeTrajectoryEstimator(paper)};
  fw::ReplayClock pacing(/*realtime=*/false);
  constexpr std::size_t kRecord = 12;
  for (std::size_t at = 0; at + kRecord <= size; at += kRecord) {
    const std::uint8_t source = data[at];
    double stamp_s = 0.0;
    std::memcpy(&stamp_s, data + at + 1, sizeof stamp_s);
    const Eigen::Vector3d p_R(data[at + 9] / 32.0 - 4.0, data[at + 10] / 32.0, data[at + 11] / 64.0);
    pacing.waitFor(stamp_s);
    switch (source % 3) {
      case 0: {
        const fw::BallState state = p_R.z() > 0.2 ? fw::BallState::kAir : fw::BallState::kGround;
        const std::vector<fw::BallObservation> balls{fw::BallObservation::inRobotFrame(
            p_R, 1e-4 * Eigen::Matrix3d::Identity(), state, "kinect3d", fw::Stamp{stamp_s, stamp_s})};
        fusion.addKinectFrame(stamp_s, balls);
        alignment.addKinectFrame(stamp_s, balls);
        for (const auto& trajectory : trajectories) {
          const auto flight = trajectory->update(stamp_s, balls);
          if (flight && std::isfinite(flight->time_s) && !flight->position_m.allFinite()) std::abort();
        }
        break;
      }
      case 1: {
        fw::OmniBallObservation ball;
        ball.source = "omni";
        ball.bearing_rad = p_R.x();
        ball.distance_m = p_R.y() + 0.2;
        ball.stamp = {stamp_s, stamp_s};
        fusion.addOmniFrame(stamp_s, {ball});
        alignment.addOmniFrame(stamp_s, {ball});
        break;
      }
      default:
        fusion.addPose(fw::RobotPose{p_R.x(), p_R.y(), p_R.z(), {stamp_s, stamp_s}, std::nullopt});
        break;
    }
    const std::optional<fw::FusedBall>& ball = fusion.latest().ball;
    if (ball && !(ball->position_F.allFinite() && ball->position_R.allFinite())) std::abort();
    alignment.takeAlarm();
  }
  return 0;
}
