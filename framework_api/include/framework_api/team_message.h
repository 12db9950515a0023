// What one robot tells its teammates of the ball (plugins/team, docs/team.md): its pose, what its
// own sensors saw, its world ball. The same body travels in the team's packets and is kept in the
// match log, so a replay hands the fusion what the robot received.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "framework_api/types.h"

namespace fw {

// A ball seen only as a direction: an omni camera's ball, which may be anywhere along the ray from
// the mirror's viewpoint through the ground point it reports (field frame). Rays of two robots
// meet at a ball in the air.
struct BallRay {
  Eigen::Vector3d origin_F = Eigen::Vector3d::Zero();      // the mirror's viewpoint
  Eigen::Vector3d direction_F = Eigen::Vector3d::UnitY();  // unit, towards the ball
  double bearing_sigma_rad = 0.0;                          // 1-sigma about the vertical ...
  double elevation_sigma_rad = 0.0;                        // ... and up or down
  double view_top_m = 0.0;  // the highest ball centre the camera sees (its mirror's view ends there)
  double time_s = 0.0;
};

// A robot the sender's omni camera saw (a teammate or an opponent): its centre on the floor, field
// frame, the sender's pose applied, with its covariance without the pose's error (the receiver adds
// it). A teammate that sees this robot elsewhere than this robot stands is mislocalised (docs/team.md).
struct SeenRobot {
  Eigen::Vector2d position_F = Eigen::Vector2d::Zero();
  Eigen::Matrix2d covariance_m2 = Eigen::Matrix2d::Zero();
  double time_s = 0.0;
};

// The clock exchange: a robot echoes the newest message it received from each teammate (when it was
// sent and when it arrived), which bounds that teammate's clock offset from above; every message's
// own send time bounds it from below (plugins/team, TeammateClock).
struct ClockEcho {
  int robot_id = 0;           // the teammate whose message is echoed
  double their_sent_s = 0.0;  // when it sent it (its clock)
  double received_s = 0.0;    // when this robot received it (this robot's clock)
};

struct TeamMessage {
  // From the packet's header (plugins/team): who sent it, and its place in that robot's sequence.
  int team_id = 0;
  int robot_id = 0;
  std::uint64_t sequence = 0;

  std::string robot_name;
  // Every time below is on the sender's host clock as sent; the receiving team plugin moves them onto
  // the clock its own fusion works on (its Kinect's, else its omni camera's; clock_offset_s) before it
  // publishes the message.
  double sent_time_s = 0.0;
  std::optional<RobotPose> pose;  // stamp.source_time_s: when localisation placed the robot
  double pose_sigma_xy_m = 0.0;   // how far the sender's localisation may be off
  double pose_sigma_theta_rad = 0.0;
  // Its Kinect's balls (frame kField, the sender's pose applied; stamp.source_time_s when it saw them;
  // covariance without the pose's error, which the receiver adds from pose_sigma_*).
  std::vector<BallObservation> kinect_balls;
  std::vector<BallRay> omni_rays;
  std::vector<SeenRobot> robots_seen;  // by its omni camera
  std::optional<FusedBall> world_ball;
  std::optional<Touchdown> touchdown;  // of the flight its Kinect follows, field frame
  std::vector<ClockEcho> echoes;

  // Set by the receiver: the sender's clock minus this robot's fusion clock, by which the times were
  // moved, and the 1-sigma of the two hosts' offset in it (half the gap between the clock exchange's
  // bounds); and when the packet arrived (this host's clock).
  double clock_offset_s = 0.0;
  double clock_offset_sigma_s = 0.0;
  double receive_time_s = 0.0;

  // Every time of the message moved by delta_s (the sender's clock onto another), echoes' too.
  void shiftTimes(double delta_s);
};

// A message body that cannot be read: names what is wrong.
class TeamMessageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The body as msgpack (docs/team.md lists its keys): a map, so a reader skips keys it does not know.
// The header's fields (team, robot, sequence) and the receiver's are not in it. Unpacking checks
// every key's type and that every number is finite; it throws TeamMessageError otherwise.
std::string packTeamMessage(const TeamMessage& message);
TeamMessage unpackTeamMessage(const std::uint8_t* data, std::size_t size);

}  // namespace fw
