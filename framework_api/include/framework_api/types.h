// Shared value types exchanged between plugins through the WorldState.
// Units: metres, seconds, radians. Frames are named in every type that holds a position.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace fw {

// Standard gravity: what every ball model here falls with.
constexpr double kGravity_mps2 = 9.81;

// Seconds since the Unix epoch on the host's wall clock: the system clock, or, while the host
// replays a match log (Host::replay), the moment the robot received the input being replayed, so a
// replay stamps what it publishes as the robot did and two replays write the same log.
double wallClockNow_s();
// Only Host::replay sets it: the replayed moment, or nullopt for the system clock again.
void setReplayedWallClock(std::optional<double> wall_time_s);

// Wraps an angle into [-pi, pi).
double wrapAngle(double a_rad);

// The larger eigenvalue of a symmetric 2x2 matrix (a covariance's long axis, squared), in closed
// form: Eigen's iterative solver for it was a third of the compile time of each file that used it.
double largestEigenvalue(const Eigen::Matrix2d& symmetric);

// The q-quantile of values by nearest rank: the value at index floor(q * n) of the sorted values
// (the last for q = 1); NaN for no values. The one rank rule of every report and health figure.
double quantile(std::vector<double> values, double q);

// When a measurement was taken by its source and when this host received it. The source clock
// may differ from the host's (a recording replays old source times); fusion uses receive time to
// judge freshness and source time to relate measurements of the same source.
struct Stamp {
  double source_time_s = 0.0;
  double receive_time_s = 0.0;

  static Stamp now() {
    const double t = wallClockNow_s();
    return {t, t};
  }
};

// The frame a position is expressed in.
//  - kSensor: optical frame, x right, y down, z forward.
//  - kRobot:  x right, y forward, z up, origin on the floor under the robot centre.
//  - kField:  origin at the centre spot, y towards the opponent goal, z up.
enum class Frame { kSensor, kRobot, kField };
const char* toString(Frame frame);

enum class BallState { kAir, kGround };
const char* toString(BallState state);

// Where the robot stands on the field (from self-localisation). theta_rad is the heading of the
// robot's +y axis measured from the field's +y axis, positive counter-clockwise (about +z).
struct RobotPose {
  double x_m = 0.0;
  double y_m = 0.0;
  double theta_rad = 0.0;
  Stamp stamp;
  // The wheels' dead reckoning at the same instant, when the localisation publishes it: a pose in
  // the odometry's own frame, which drifts over a match but moves smoothly from frame to frame
  // where the localisation's pose jitters (fusion/pose_blend.h reads how it moved between poses).
  struct Odometry {
    double x_m = 0.0;
    double y_m = 0.0;
    double theta_rad = 0.0;
  };
  std::optional<Odometry> odometry;

  // Maps a point in the robot frame to the field frame.
  Eigen::Vector3d fieldFromRobot(const Eigen::Vector3d& p_R) const;
  // The same map as a transform: a turn by theta_rad about z, then the shift to (x_m, y_m).
  Eigen::Isometry3d T_F_R() const;
};

// What the colour image said of a ball the depth found (kinect3d/colour_check.h, docs/colour.md).
enum class ColourVerdict {
  kNotChecked,  // the check is off
  kConfirmed,   // the ball's colours fill the disc and its outline is there
  kRejected,    // the disc clearly holds something else (or, when colour is required, no confirmation)
  kNoEvidence,  // the image cannot tell: the note says why
};
const char* toString(ColourVerdict verdict);
ColourVerdict colourVerdictFrom(const std::string& text);  // throws std::invalid_argument

// Why the colour image could not tell, or "none" when it could.
enum class ColourNote { kNone, kNoImage, kOutsideImage, kTooSmall, kTooDark, kOverexposed, kBlurred, kWeak, kHidden };
const char* toString(ColourNote note);
ColourNote colourNoteFrom(const std::string& text);  // throws std::invalid_argument

// One ball measurement from one source.
struct BallObservation {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance_m2 = Eigen::Matrix3d::Identity();
  Frame frame = Frame::kRobot;
  BallState state = BallState::kGround;
  std::string source;  // plugin or sensor that produced it, e.g. "kinect3d"
  Stamp stamp;
  int support_points = 0;  // depth points behind the measurement, 0 when not applicable
  // Inside space that has been occupied for seconds (a lamp, a poster, a ball on a wire): not a ball
  // in play unless a flight led there.
  bool is_static = false;
  ColourVerdict colour = ColourVerdict::kNotChecked;
  ColourNote colour_note = ColourNote::kNone;
  double colour_score = 0.0;  // 0-1: how much of a ball the colour image shows (docs/colour.md)

  // Whether trajectories and the fusion follow it: not when the colour image rejected it.
  bool followed() const { return colour != ColourVerdict::kRejected; }

  static BallObservation inRobotFrame(const Eigen::Vector3d& p_R, const Eigen::Matrix3d& cov_m2, BallState state,
                                      std::string source, Stamp stamp);
  // Same frame, state, source, static flag and colour verdict, positions within tol_m, covariances within tol_m^2 per
  // entry.
  bool isApprox(const BallObservation& other, double tol_m) const;
};

// The omni camera's ground ball: it only sees the ball on the floor, as a bearing and a distance
// in the robot frame (distance from the ground-plane projection, so wrong for a ball in the air).
struct OmniBallObservation {
  double bearing_rad = 0.0;  // from the robot's +y axis, positive towards -x (counter-clockwise)
  double distance_m = 0.0;
  double distance_sigma_m = 0.0;
  double bearing_sigma_rad = 0.0;
  std::string source;
  Stamp stamp;

  // The ground point the camera reports, in the robot frame (z = 0).
  Eigen::Vector3d groundPoint_R() const;
};

// A robot the omni camera sees (a teammate or an opponent: it cannot tell them apart): its centre on
// the floor as a bearing and a distance in the robot frame, as for a ball on the floor.
struct OmniRobotObservation {
  double bearing_rad = 0.0;  // from the robot's +y axis, positive towards -x (counter-clockwise)
  double distance_m = 0.0;
  double distance_sigma_m = 0.0;
  double bearing_sigma_rad = 0.0;

  Eigen::Vector3d groundPoint_R() const;
};

// One depth frame's balls as the detector reported them (robot frame), one stamp.
struct BallFrame {
  Stamp stamp;
  std::vector<BallObservation> balls;
  std::string source;  // the plugin that published it (a frame may hold no ball)
};

// One image of the omni camera: every ball it saw (none, the ball, orange shirts), one stamp, and the
// robots it saw (teammates judge each other's localisation by them: docs/team.md).
struct OmniFrame {
  Stamp stamp;
  std::vector<OmniBallObservation> balls;
  std::string source;  // the plugin that published it
  std::vector<OmniRobotObservation> robots = {};
};

// Where a ball in flight will land: the centre's ground point when its height comes down to
// the ball's radius, in the robot frame, with a 1-sigma radius from the fit's uncertainty.
struct Touchdown {
  Eigen::Vector2d point_m = Eigen::Vector2d::Zero();
  double time_s = 0.0;  // source clock
  double sigma_m = 0.0;
};

// Where and when the ball crosses the robot's own line (the plane y = 0 of the robot frame, where
// a goalkeeper stands).
struct LineCrossing {
  double x_m = 0.0;
  double z_m = 0.0;
  double time_s = 0.0;  // source clock
};

// A ball's estimated motion, in the robot frame, valid around time_s (source clock). In the air
// the ball falls with gravity and, when drag_per_m > 0, quadratic air drag; on the ground it rolls,
// slowing by rolling_decel_mps2 until it stops.
struct BallTrajectory {
  double time_s = 0.0;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();    // at time_s
  Eigen::Vector3d velocity_mps = Eigen::Vector3d::Zero();  // at time_s
  BallState state = BallState::kAir;
  double gravity_mps2 = kGravity_mps2;
  double drag_per_m = 0.0;
  double curve_radps = 0.0;  // sidespin's Magnus acceleration curve (z x v): + turns the flight left
  double rolling_decel_mps2 = 0.0;
  int support = 0;     // detections the current fit rests on
  double rms_m = 0.0;  // their residual to it
  std::optional<Touchdown> touchdown;
  std::optional<LineCrossing> crossing;
  std::string source;

  // Position and velocity predicted at time t (before or after time_s), by the motion model.
  Eigen::Vector3d positionAt(double t_s) const;
  Eigen::Vector3d velocityAt(double t_s) const;
  // This trajectory with its state moved to t_s (position and velocity in one propagation).
  BallTrajectory movedTo(double t_s) const;

 private:
  void propagate(double t_s, Eigen::Vector3d& p, Eigen::Vector3d& v) const;
};

// The world's ball: one estimate from every source (fusion/), kept in the field frame, where a ball's
// physics lives, and reported in the robot frame too. stamp.source_time_s is on the reference
// source's clock (the depth sensor's); other sources' times are corrected onto it.
// Where and when a ball that nothing touches crosses a goal line (the field frame's y = +-half the
// field's length), flying, bouncing or rolling: the line's x and the ball centre's height there, with
// a 1-sigma radius of (x, z) and a 1-sigma of the time from the ball's uncertainty.
struct GoalCrossing {
  int goal = 0;  // +1 the opponent's goal line (y > 0), -1 this team's own
  double x_m = 0.0;
  double z_m = 0.0;
  double time_s = 0.0;  // source clock
  double sigma_m = 0.0;
  double time_sigma_s = 0.0;
};

struct FusedBall {
  Eigen::Vector3d position_F = Eigen::Vector3d::Zero();
  Eigen::Vector3d position_R = Eigen::Vector3d::Zero();  // with the robot pose at the same time
  Eigen::Vector3d velocity_F = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance_F = Eigen::Matrix3d::Identity();  // of position_F, m^2
  // kAir while it flies or hops higher than 5 cm above rest; lower hops are a ball rolling on.
  BallState state = BallState::kGround;
  double air_probability = 0.0;      // of the motion modes, how much the air mode explains the data
  std::vector<std::string> sources;  // those that supported it during the last second, e.g. {"kinect3d", "omni"}
  double age_s = 0.0;                // since the last measurement that supported it
  Stamp stamp;
  std::optional<GoalCrossing> goal_crossing;  // while it heads for a goal line it reaches within 3 s

  // 1-sigma radius of the horizontal position (the larger axis of its error ellipse).
  double sigmaHorizontal_m() const;
};

// The colour image a depth sensor paired with a depth image (the one nearest in time): 8-bit RGB,
// row-major, with its own camera's pinhole intrinsics and where that camera sits in the depth
// camera's optical frame (same orientation; the Kinect v1's is 2.5 cm to its right).
struct ColourImage {
  int width = 0;
  int height = 0;
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  Eigen::Vector3d offset_S_m = Eigen::Vector3d::Zero();
  std::vector<std::uint8_t> rgb;  // width * height * 3
  double source_time_s = 0.0;     // on the depth image's clock
};

// One depth image as a depth plugin received it, for the match log and the viewer: uint16 millimetres
// along the optical axis (0 = no data), row-major, with the pinhole intrinsics that back-project it,
// and what else the sensor measured with it.
struct DepthImage {
  // The image sizes any depth source may claim (a camera.yaml, a match log's frame): a bad file
  // claiming more is refused before anything that size is allocated.
  static constexpr int kMinSide_px = 8;
  static constexpr int kMaxSide_px = 4096;

  int width = 0;
  int height = 0;
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  std::vector<std::uint16_t> depth_mm;
  std::uint64_t index = 0;  // the source's frame counter
  std::string source;       // the plugin that read it
  Stamp stamp;
  // Gravity in the sensor optical frame, m/s^2, from the sensor's accelerometer (Kinect v1).
  std::optional<Eigen::Vector3d> gravity_S_mps2;
  std::optional<ColourImage> colour;
};

// Something a person reading the log after the match wants to find on the timeline: a sensor lost
// or reopened, the floor found, a calibration alarm. kind is a short fixed word, message the detail.
struct Event {
  Event() = default;
  Event(std::string source, std::string kind, std::string message, Stamp stamp,
        std::optional<double> value = std::nullopt)
      : source(std::move(source)), kind(std::move(kind)), message(std::move(message)), stamp(stamp), value(value) {}

  std::string source;
  std::string kind;
  std::string message;
  Stamp stamp;
  std::optional<double> value;  // the number it is about, for tools (omni_latency: the learnt latency, s; ball_bounce:
                                // the learnt restitution)
};

// One plugin's health over the last second, published by the host once a second.
struct PluginHealth {
  std::string plugin;
  double wall_time_s = 0.0;       // when the second ended
  std::uint64_t frames = 0;       // processed steps in the second
  double rate_hz = 0.0;           // frames / the second's length
  double processing_p50_s = 0.0;  // of those frames (the plugin's own, else its step time)
  double processing_p99_s = 0.0;
  double processing_total_s = 0.0;  // summed over those frames: the plugin's share of a core in the second
  // From an input's arrival on this host to the plugin's output, for a plugin that reports it (the
  // fusion: a depth frame's arrival to its world ball's publication); NaN for the others.
  double latency_p50_s = std::numeric_limits<double>::quiet_NaN();
  double latency_p99_s = std::numeric_limits<double>::quiet_NaN();
  std::uint64_t dropped_frames = 0;  // total since start, as the plugin reported them
  std::uint64_t errors = 0;          // total since start
  std::uint64_t stuck = 0;           // total since start
};

}  // namespace fw
