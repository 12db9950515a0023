#include "fusion/ball_fusion.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <iterator>
#include <limits>
#include <optional>

#include "framework_api/log.h"

#include "fusion/measurements.h"

namespace fusion {

namespace {
// What teaches the omni camera's latency: an omni ball on the world's track while a Kinect saw that
// track this recently (a phantom lies on the ball's own bearing, so in the air too): this robot's, or
// a teammate's while this robot's has not seen it (a robot without a Kinect learns too). The
// Kinect's ball is carried to the omni's time at its velocity over its frames of the last
// kLatencyRateBaseline_s. An omni bearing further off than kLatencyMaxBearingResidual_rad is a
// misassociation, not a time offset; so is a reading further off than kLatencyMaxOffset_s of its
// rate would put it (and three sigma). No omni camera's stamps are kLatencyMaxOffset_s off its
// configured latency: an estimate beyond is a Kinect turned on its mount (the alignment check's
// alarm), not time, and unused.
constexpr double kLatencyKinectWithin_s = 0.1;
constexpr double kLatencyMaxOffset_s = 0.2;
constexpr double kLatencyRateBaseline_s = 0.34;
constexpr double kLatencyMaxBearingResidual_rad = 0.2;
// A Kinect ball this far above rest, and three sigma of its height, is in the air: falling, not rolling.
constexpr double kLatencyOffTheFloor_m = 0.03;
constexpr double kLatencyOffPathChi2 = 16.0;  // four sigma, in three dimensions
constexpr double kLatencyRateSignificance = 3.0;
// The robot's turn times the omni against a ball on the floor where it lay while the robot stood,
// from that many readings, until an omni ball's distance, or the track, is further than
// kRestingSpread_m from there. The ball's speed says only that it was not kicked: from the omni
// alone its velocity is known to a metre per second or two. Standing: the pose moves the bearing
// and the distance so slowly that 0.1 s of latency would move them less than the omni's noise (a
// localisation's jitter alone turns it by 0.03-0.1 rad/s).
constexpr double kRestingSpeed_mps = 1.0;
constexpr double kStillBearingRate_radps = 0.15;
constexpr double kStillDistanceRate_mps = 0.1;
constexpr int kRestingReadings = 10;
constexpr double kRestingSpread_m = 0.3;
constexpr double kHeadingErrorSharedBy = 30.0;  // readings: a second at 30 Hz
// Learnt latency is never trusted to better than this (the omni's exposure and the examples' spread).
constexpr double kMinTimingSigma_s = 0.005;
// The world's ball moves to another confirmed track when its own has had no support this long.
constexpr double kWorldSwitchAfter_s = 0.2;
// ... unless a Kinect located it and it was last seen this far out of the omni camera's reach, and
// has since gone beyond it.
constexpr double kLeavingReachShare = 0.9;
// A source counts as supporting the world's ball if it did within this time.
constexpr double kSourceRecent_s = 1.0;
// At most this many tracks at once (the ball, shirts, posters); the oldest unconfirmed goes first.
constexpr std::size_t kMaxTracks = 8;
// A teammate is judged against a ball only while this robot's own sensors supported it this recently:
// then it is this robot's view, not the teammate's own, that it is judged against.
constexpr double kJudgeOwnSupportWithin_s = 0.1;
// A teammate's best observation this far from this robot's ball sees another object (or this robot
// does: an orange shirt), not the same ball from a wrong place: a mislocalised robot (a metre, twenty
// degrees at eight metres) is nearer. It is not judged by it.
constexpr double kMaxMislocalisation_m = 3.0;
// A teammate's Kinect ball and a ball this robot's omni camera alone holds are taken for the same
// ball when they lie this far apart along the line of sight from the camera (or this share of the
// distance, whichever is more: omni distances are uncertain, and a metre-off teammate is judged).
constexpr double kSameBallAlong_m = 1.0;
constexpr double kSameBallAlongShare = 0.3;
// This robot's omni camera places a ball on the floor well enough to judge teammates by, whoever
// else supports it, while its distance error is within this (5 cm + 5 % of the distance by default:
// 4 m). A farther ball is placed by whoever joins it.
constexpr double kOmniPlacesWithin_m = 0.25;
// A discounted teammate is trusted again once its median falls below this share of the discount's.
constexpr double kTrustAgainShare = 0.5;
// A teammate not yet judged on judge_examples of its observations is used beside this robot's own
// view once this many agree with it as well as a discounted one must to be trusted again (their
// median within kTrustAgainShare of discount_sigma). Within discount_sigma itself, a keeper a metre
// off passed on three judgements against a ball its own first balls had pulled its way.
constexpr int kFirstJudgements = 3;
// This robot's omni images are kept this long: a teammate's robots are judged against the one
// nearest in time, and never against one farther apart than this (two cameras at 30 Hz).
constexpr double kSeenRobotsKept_s = 1.0;
constexpr double kSightingsApart_s = 0.05;
// Teammates' robots seen wait for this robot's next own frame; at most this many (a second of
// four teammates' messages) wait while its own sensors are silent.
constexpr std::size_t kPendingSightings = 80;
// Beyond that the oldest go.
template <typename Sightings>
void keepNewestPending(std::vector<Sightings>& pending) {
  if (pending.size() > kPendingSightings) pending.erase(pending.begin(), pending.end() - kPendingSightings);
}
// A robot moves at most this fast (MSL robots reach 3-4 m/s; most of a match is slower): two
// sightings of it that far apart in time are that much apart.
constexpr double kRobotSpeed_mps = 3.0;
// An omni camera sees a robot's near side and puts its centre behind it (half a robot is 0.26 m).
constexpr double kRobotCentreSigma_m = 0.1;
// A robot this robot sees within this many sigmas of where a teammate believes it stands is it.
constexpr double kSameRobot_sigma = 3.0;
// A teammate's observations wait this long after its first for its first judgements (the robots it
// sees are judged within a few messages): until then a mislocalised one is not yet found out. One
// that cannot be judged so soon is used as it is after this.
constexpr double kProbation_s = 0.5;
// A teammate's ball nearer than this to it is at it (no share of its distance to scale by).
constexpr double kAtTheTeammate_m = 0.1;
// A Kinect ball (this robot's or a teammate's) that moves a track's likeliest ball by more than this
// found a ball the track had lost. The update's velocity is kept, but not its confidence in it: it
// comes from where and when the track last knew the ball, and the "when" is a guess. A lob last
// seen by the omni camera at the kick and first located by a teammate's Kinect 0.35 s later became a
// 4.6 m/s climb of a 2 m/s one, held to a third of a metre per second, as if kicked just before.
constexpr double kReacquireJump_m = 1.0;

// An omni ball's ground point's covariance: bearing and distance noise turned into the floor's x, y
// (the Jacobian of the ground point), from a camera at pose.
Eigen::Matrix3d groundCovariance(const OmniMeasurement& omni, const fw::OmniBallObservation& ball,
                                 const fw::RobotPose& pose) {
  const MeasurementMatrix R = omni.noise(omni.groundBall_F());
  const double s = std::sin(ball.bearing_rad), co = std::cos(ball.bearing_rad), d = ball.distance_m;
  Eigen::Matrix2d J;
  J << -d * co, -s, -d * s, co;
  const Eigen::Matrix2d turn = Eigen::Rotation2Dd(pose.theta_rad).toRotationMatrix();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  covariance.topLeftCorner<2, 2>() = turn * J * R * J.transpose() * turn.transpose();
  return covariance;
}

// Goal-line crossings are predicted this far ahead, the ball carried on by kGoalStep_s at a time.
constexpr double kGoalHorizon_s = 3.0;
constexpr double kGoalStep_s = 0.1;
// A ball slower than this towards a goal line is not heading for it (a ball at rest jitters).
constexpr double kMinGoalwardSpeed_mps = 0.5;

// Where now's ball, if nothing touches it, crosses the goal line it heads for (y = +-field_length_m
// / 2) within kGoalHorizon_s, carried on with the filter's own motion (flight, drag, bounces,
// rolling) step by step until it passes the line; within that step, Newton's steps find the
// crossing (the speed along y only falls, so they approach it from before). The crossing's spread
// is the ball's there, along the line and up: the position's error moved along the ball's path to
// the line; its time's, the error along y over the speed.
std::optional<fw::GoalCrossing> goalCrossing(const BallFilter& filter, const Hypothesis& now, double t_s,
                                             double field_length_m) {
  constexpr int kY = 1, kVy = 4;
  constexpr double kAtTheLine_m = 1e-3;
  const double vy = now.x[kVy];
  if (std::abs(vy) < kMinGoalwardSpeed_mps) return std::nullopt;
  const int goal = vy > 0.0 ? 1 : -1;
  const double line_y = goal * field_length_m / 2.0;
  const double to_line_m = goal * (line_y - now.x[kY]);
  // Drag, bounces and rolling only slow it: at its speed now it would arrive soonest.
  if (to_line_m <= 0.0 || to_line_m / std::abs(vy) > kGoalHorizon_s) return std::nullopt;
  Hypothesis before = now;
  double before_s = 0.0;  // after now
  for (;;) {
    if (before_s >= kGoalHorizon_s) return std::nullopt;
    const Hypothesis after = filter.untouched(before, kGoalStep_s);
    if (goal * (line_y - after.x[kY]) <= 0.0) break;
    if (goal * after.x[kVy] <= 0.0) return std::nullopt;  // stopped short of it
    before = after;
    before_s += kGoalStep_s;
  }
  double dt = 0.0;  // after before
  Hypothesis at = before;
  for (int step = 0; step < 8 && std::abs(line_y - at.x[kY]) >= kAtTheLine_m; ++step) {
    dt = std::clamp(dt + (line_y - at.x[kY]) / at.x[kVy], 0.0, kGoalStep_s);
    at = filter.untouched(before, dt);
  }
  const double vy_at = at.x[kVy];
  if (goal * vy_at <= 0.0) return std::nullopt;
  Eigen::Matrix<double, 2, 6> J = Eigen::Matrix<double, 2, 6>::Zero();  // d(x, z) = dp_(x, z) - v_(x, z) / v_y dp_y
  J(0, 0) = 1.0;
  J(0, kY) = -at.x[3] / vy_at;
  J(1, 2) = 1.0;
  J(1, kY) = -at.x[5] / vy_at;
  const Eigen::Matrix2d spread = J * at.P * J.transpose();
  // What Newton's steps left: under a millimetre once they converge, covered by one straight step.
  const double rest_s = (line_y - at.x[kY]) / vy_at;
  fw::GoalCrossing crossing;
  crossing.goal = goal;
  crossing.x_m = at.x[0] + rest_s * at.x[3];
  crossing.z_m = at.x[2] + rest_s * at.x[5];
  crossing.time_s = t_s + before_s + dt + rest_s;
  crossing.sigma_m = std::sqrt(std::max(0.0, fw::largestEigenvalue(spread)));
  crossing.time_sigma_s = std::sqrt(at.P(kY, kY)) / std::abs(vy_at);
  return crossing;
}

// The name a teammate's observations go by in the world ball's sources: "team:keeper".
std::string teammateSource(const std::string& name) { return "team:" + name; }
// And its world ball, when this robot holds it as a prior: "team:keeper:world_ball".
constexpr const char* kPriorSuffix = ":world_ball";
std::string teammatePriorSource(const std::string& name) { return teammateSource(name) + kPriorSuffix; }
// A world ball that is itself only a teammate's prior (every source one): passing it on would let
// two robots that see nothing hold each other's ball.
bool onlyAPrior(const fw::FusedBall& ball) {
  const std::string suffix = kPriorSuffix;
  return !ball.sources.empty() && std::all_of(ball.sources.begin(), ball.sources.end(), [&](const std::string& source) {
    return source.size() > suffix.size() && source.compare(source.size() - suffix.size(), suffix.size(), suffix) == 0;
  });
}
// How fast the place of a ball that nobody sees may drift from its last estimate (it may have been
// nudged or kicked): what makes a teammate's world ball a weak prior, and weaker as it ages.
constexpr double kUnseenDrift_mps = 1.0;
}  // namespace

void LatencyEstimator::add(double residual, double variance, double rate, double applied_s, double distance_m) {
  const double keep = 1.0 - 1.0 / kMemoryExamples;
  const Eigen::Vector2d row(-rate, distance_m);  // d residual / d (latency, scale)
  const double w = 1.0 / variance, y = residual - rate * applied_s;
  information_ = keep * information_ + w * row * row.transpose();
  weighted_ = keep * weighted_ + w * y * row;
  ++examples_;
}

std::optional<LatencyEstimator::Fit> LatencyEstimator::fit(double prior_sigma_s) const {
  if (examples_ < kMinExamples) return std::nullopt;
  Eigen::Matrix2d information = information_;
  information(0, 0) += 1.0 / (prior_sigma_s * prior_sigma_s);
  information(1, 1) += 1.0 / (kDistanceScaleSigma * kDistanceScaleSigma);
  const Eigen::Matrix2d covariance = information.inverse();
  return Fit{(covariance * weighted_)[0], std::sqrt(covariance(0, 0))};
}

// One ball of one frame, ready to associate: its measurement model, where it puts the ball in the
// field frame (for a new track, and to judge a teammate by) and with what covariance.
struct BallFusion::Candidate {
  Source source;
  std::unique_ptr<MeasurementModel> measurement;
  Eigen::Vector3d p_F;
  Eigen::Matrix3d covariance_F;
  bool in_air = false;
  bool is_static = false;  // an air ball in space occupied for seconds
  fw::ColourVerdict colour = fw::ColourVerdict::kNotChecked;
  const fw::OmniBallObservation* omni = nullptr;            // the omni's ball, in the frame being processed
  const fw::BallObservation* kinect = nullptr;              // this robot's Kinect's ball, in the frame being processed
  std::optional<KinectSighting> sighting = std::nullopt;    // a Kinect's ball, this robot's or a teammate's
  int teammate = 0;                                         // the teammate's robot id, for Source::kTeammate
  Eigen::Vector2d teammate_xy_F = Eigen::Vector2d::Zero();  // and where it believes it stands
  std::optional<Eigen::Vector3d> ray_origin_F = std::nullopt;  // a teammate's omni ray: its camera's viewpoint

  // A Kinect's ball, this robot's or a teammate's: the centre in 3D, not a bearing.
  bool locates() const { return omni == nullptr && !ray_origin_F; }
};

BallFusion::BallFusion(const FusionConfig& config)
    : config_(config),
      pose_blend_(config.pose.odometry_blend_s, config.pose.sigma_xy_m, config.pose.sigma_theta_rad),
      kinect_time_line_(config.track.lost_after_s),
      omni_time_line_(config.track.lost_after_s) {
  state_.bounce = BounceLearner(config.motion);
}

std::optional<LatencyEstimator::Fit> BallFusion::omniLatency() const {
  if (!config_.omni.estimate_latency) return std::nullopt;
  const std::optional<LatencyEstimator::Fit> fit = state_.latency.fit(config_.omni.timing_sigma_s);
  if (!fit || std::abs(fit->latency_s) > kLatencyMaxOffset_s) return std::nullopt;
  return fit;
}

std::optional<LatencyEstimator::Fit> BallFusion::poseLatency() const {
  if (!config_.pose.estimate_latency) return std::nullopt;
  const std::optional<LatencyEstimator::Fit> fit = state_.pose_latency.fit(config_.pose.timing_sigma_s);
  if (!fit || std::abs(fit->latency_s) > kLatencyMaxOffset_s) return std::nullopt;
  return fit;
}

fw::RobotPose BallFusion::poseAt(double t_s) const {
  // A pose stamped late shows the robot of an earlier time: the one for t is stamped that much later.
  const std::optional<LatencyEstimator::Fit> learnt = poseLatency();
  return poses_.at(poseStampFor_s(t_s, learnt ? learnt->latency_s : 0.0));
}

void BallFusion::addPose(const fw::RobotPose& pose) {
  fw::RobotPose corrected = pose_blend_.add(pose);
  corrected.stamp.source_time_s -= config_.pose.latency_s;
  poses_.add(corrected);
}

const FusionUpdate& BallFusion::addKinectFrame(double stamp_s, const std::vector<fw::BallObservation>& balls_R) {
  if (!onTimeLine(Source::kKinect, stamp_s, stamp_s - config_.kinect.latency_s)) return state_.update;
  Frame frame{Source::kKinect, stamp_s - config_.kinect.latency_s, 0.0, 0.0, balls_R, {}, {}, {}, {}};
  frame.team_sightings.swap(pending_sightings_);
  return insert(std::move(frame));
}

const FusionUpdate& BallFusion::addOmniFrame(double stamp_s, const std::vector<fw::OmniBallObservation>& balls,
                                             const std::vector<fw::OmniRobotObservation>& robots) {
  if (!onTimeLine(Source::kOmni, stamp_s, stamp_s - config_.omni.latency_s)) return state_.update;
  const std::optional<LatencyEstimator::Fit> learnt = omniLatency();
  const double learnt_s = learnt ? learnt->latency_s : 0.0;
  const double timing_sigma_s = learnt ? std::max(learnt->sigma_s, kMinTimingSigma_s) : config_.omni.timing_sigma_s;
  const double t = omniSeen_s(stamp_s, config_.omni, learnt_s);
  if (!poses_.empty()) {
    for (const fw::OmniRobotObservation& robot : robots) {
      seen_robots_.push_back(seenRobot_F(robot, poseAt(t), config_.omni, t));
    }
  }
  while (!seen_robots_.empty() && seen_robots_.front().time_s < t - kSeenRobotsKept_s) seen_robots_.pop_front();
  Frame frame{Source::kOmni, t, learnt_s, timing_sigma_s, {}, balls, {}, {}, {}};
  frame.team_sightings.swap(pending_sightings_);
  return insert(std::move(frame));
}

const FusionUpdate& BallFusion::addTeamMessage(const fw::TeamMessage& message) {
  if (!config_.team.use || !message.pose) return state_.update;
  teammates_heard_ = true;
  // Its balls by their time: one frame each (a message carries the balls of one or two Kinect frames).
  std::map<double, Frame> frames;
  const PoseConfig pose_error{0.0, message.pose_sigma_xy_m, message.pose_sigma_theta_rad};
  const auto frameAt = [&](double t) -> Frame& {
    return frames.try_emplace(t, Frame{Source::kTeammate, t, 0.0, 0.0, {}, {}, {}, {}, {}}).first->second;
  };
  for (const fw::BallObservation& ball : message.kinect_balls) {
    frameAt(ball.stamp.source_time_s)
        .team.push_back(
            {message.robot_id, message.robot_name, ball, *message.pose, pose_error, message.clock_offset_sigma_s});
  }
  const double r = config_.motion.radius_m;
  for (const fw::BallRay& ray : message.omni_rays) {
    // The ground point the teammate's camera reports: where its ray meets the plane of resting centres.
    const double drop_m = ray.origin_F.z() - r, horizontal = ray.direction_F.head<2>().norm();
    if (drop_m <= 0.0 || ray.direction_F.z() >= 0.0 || ray.view_top_m < r) continue;  // no ground point
    TeammateRay mate;
    mate.robot_id = message.robot_id;
    mate.name = message.robot_name;
    mate.omni = config_.omni;
    mate.pose_error = pose_error;
    // The teammate took its camera's configured latency off the ray's time, but what it learnt of
    // it is not known here: its times are as uncertain as this robot's omni camera's before it
    // learnt its own, and the two robots' clocks as their exchange's bound.
    mate.timing_sigma_s = std::hypot(config_.omni.timing_sigma_s, message.clock_offset_sigma_s);
    mate.ball.bearing_rad = std::atan2(-ray.direction_F.x(), ray.direction_F.y());
    mate.ball.distance_m = drop_m / -ray.direction_F.z() * horizontal;
    mate.ball.bearing_sigma_rad = ray.bearing_sigma_rad;
    const double d = mate.ball.distance_m;
    mate.ball.distance_sigma_m = std::max(ray.elevation_sigma_rad * (d * d + drop_m * drop_m) / drop_m, 1e-6);
    mate.viewpoint = fw::RobotPose{ray.origin_F.x(), ray.origin_F.y(), 0.0, {ray.time_s, ray.time_s}, std::nullopt};
    mate.omni.viewpoint_height_m = ray.origin_F.z();
    mate.omni.max_height_m = std::min(ray.view_top_m, ray.origin_F.z());
    frameAt(ray.time_s).team_rays.push_back(mate);
  }
  if (!ignores(message.robot_name)) {
    TeammatePoses& believed = teammate_poses_[message.robot_id];
    believed.poses.add(*message.pose);
    believed.newest_s = std::max(believed.newest_s, message.pose->stamp.source_time_s);
    believed.error = pose_error;
  }
  if (!message.robots_seen.empty() && !ignores(message.robot_name)) {
    // One image's robots: a message carries the newest image's.
    pending_sightings_.push_back({message.robot_id, message.robot_name, message.robots_seen.front().time_s,
                                  message.robots_seen, Eigen::Vector2d(message.pose->x_m, message.pose->y_m),
                                  pose_error});
    keepNewestPending(pending_sightings_);
  }
  if (message.world_ball && !onlyAPrior(*message.world_ball) && config_.team.prior_max_age_s > 0.0) {
    frameAt(message.world_ball->stamp.source_time_s).team_world_ball =
        TeammateWorldBall{message.robot_id, message.robot_name, *message.world_ball,
                          Eigen::Vector2d(message.pose->x_m, message.pose->y_m), pose_error};
  }
  if (ignores(message.robot_name)) {
    // Its messages still step the fusion at their times, as a discounted teammate's do: a replay
    // ignoring it differs from the run only by what it saw.
    for (auto& [t, frame] : frames) {
      frame.team.clear();
      frame.team_rays.clear();
      frame.team_world_ball.reset();
    }
  }
  std::vector<Frame> usable;
  std::optional<double> newest_s = recent_.empty() ? std::nullopt : std::optional<double>(recent_.back().first.time_s);
  for (auto& [t, frame] : frames) {
    // Its clock was moved onto the reference by the team plugin: a time far from the fusion's is a
    // clock the exchange has not caught up with yet, not a new time line.
    if (!std::isfinite(t) || (newest_s && std::abs(t - *newest_s) > config_.track.lost_after_s)) {
      ++unusable_dropped_;
      continue;
    }
    newest_s = std::max(newest_s.value_or(t), t);
    usable.push_back(std::move(frame));
  }
  return usable.empty() ? state_.update : insert(std::move(usable));
}

bool BallFusion::onTimeLine(Source source, double stamp_s, double time_s) {
  fw::TimeLine& own = source == Source::kKinect ? kinect_time_line_ : omni_time_line_;
  const fw::TimeLine::Step step = own.next(stamp_s);
  const auto what = [&] { return nameOf(source) + "'s frame stamped " + fw::stampText(stamp_s) + " s"; };
  if (step == fw::TimeLine::Step::kNotFinite) {
    if (fw::worthLogging(++unusable_dropped_)) {
      fw::logWarn("fusion", what() + ": " + own.describe(step, stamp_s) + "; dropped (" +
                                std::to_string(unusable_dropped_) + " unusable frames so far)");
    }
    return false;
  }
  const double newest_s = recent_.empty() ? time_s : recent_.back().first.time_s;
  if (std::abs(time_s - newest_s) <= config_.track.lost_after_s) {
    reported_off_time_line_ = false;
    return true;
  }
  // Far from the fusion's time. The Kinect's clock is the reference; the omni camera's leads only
  // while the Kinect is silent.
  const std::optional<double> kinect_s = kinect_time_line_.newest_s();
  const bool leads = source == Source::kKinect || !kinect_s ||
                     std::abs(*kinect_s - config_.kinect.latency_s - newest_s) > config_.track.lost_after_s;
  if (step == fw::TimeLine::Step::kJump && leads) {
    // The leading clock jumped: what the fusion holds belongs to the old time line.
    fw::logWarn("fusion", what() + ": its clock " + own.describe(step, stamp_s) + "; the fusion starts again from it");
    // The omni camera's latency is the camera's and the bounce the ball's, not the time's.
    const LatencyEstimator latency = state_.latency;
    const BounceLearner bounce = state_.bounce;
    state_ = State{};
    state_.latency = latency;
    state_.bounce = bounce;
    recent_.clear();
    ++restarts_;
    return true;
  }
  ++unusable_dropped_;
  if (!reported_off_time_line_) {
    fw::logWarn("fusion", what() + " lies " + fw::stampText(time_s - newest_s) +
                              " s from the fusion's newest frame: its clock and the reference's disagree; dropped "
                              "until they agree again");
    reported_off_time_line_ = true;
  }
  return false;
}

const FusionUpdate& BallFusion::insert(Frame frame) {
  std::vector<Frame> one;
  one.push_back(std::move(frame));
  return insert(std::move(one));
}

const FusionUpdate& BallFusion::insert(std::vector<Frame> frames) {
  // Each frame too late to use is dropped, judged against the newest frame before it, the batch's too.
  double newest = recent_.empty() ? frames.front().time_s : recent_.back().first.time_s;
  std::size_t arrived = 0;
  for (Frame& frame : frames) {
    const double max_delay_s = frame.source == Source::kTeammate ? config_.team.max_delay_s : config_.max_delay_s;
    if (frame.time_s < newest - max_delay_s) {
      ++late_dropped_;
      // The teammates' sightings it carried ride on the next frame instead, before those heard since.
      auto& carried = frame.team_sightings;
      pending_sightings_.insert(pending_sightings_.begin(), std::make_move_iterator(carried.begin()),
                                std::make_move_iterator(carried.end()));
      keepNewestPending(pending_sightings_);
      continue;
    }
    newest = std::max(newest, frame.time_s);
    if (&frame != &frames[arrived]) frames[arrived] = std::move(frame);
    ++arrived;
  }
  if (arrived == 0) return state_.update;
  frames.erase(frames.begin() + static_cast<std::ptrdiff_t>(arrived), frames.end());
  // Late frames: back to the state before the first frame after the earliest of them, then everything
  // again in order, each arrived frame after those already held at its time. One rewind for the
  // batch: a teammate's message carries frames at several times, and each rewind replays every frame
  // since.
  const auto later = std::find_if(recent_.begin(), recent_.end(), [&](const std::pair<Frame, State>& entry) {
    return entry.first.time_s > frames.front().time_s;
  });
  std::vector<Frame> replay;
  if (later != recent_.end()) {
    state_ = later->second;
    for (auto it = later; it != recent_.end(); ++it) replay.push_back(std::move(it->first));
    recent_.erase(later, recent_.end());
  }
  const auto held_end = replay.end() - replay.begin();
  replay.insert(replay.end(), std::make_move_iterator(frames.begin()), std::make_move_iterator(frames.end()));
  std::inplace_merge(replay.begin(), replay.begin() + held_end, replay.end(),
                     [](const Frame& a, const Frame& b) { return a.time_s < b.time_s; });
  for (Frame& f : replay) {
    recent_.emplace_back(std::move(f), state_);
    process(recent_.back().first);
  }
  // The world's ball after the newest frame: what is published (those after the replayed frames
  // would never be read).
  state_.update.ball = worldBall(state_.update.time_s);
  // Kept for the latest any frame may come (once teammates speak, theirs over Wi-Fi later than this robot's own).
  const double keep_s =
      teammates_heard_ ? std::max(config_.max_delay_s, config_.team.max_delay_s) : config_.max_delay_s;
  while (recent_.front().first.time_s < recent_.back().first.time_s - keep_s) recent_.pop_front();
  return state_.update;
}

std::vector<BallFusion::Candidate> BallFusion::candidatesOf(const Frame& frame, const fw::RobotPose& pose) const {
  std::vector<Candidate> candidates;
  const double r = config_.motion.radius_m;
  for (const fw::BallObservation& ball : frame.kinect) {
    Candidate c{Source::kKinect,
                std::make_unique<PositionMeasurement>(ball.position_m, ball.covariance_m2, pose, config_.pose),
                Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()};
    c.p_F = c.measurement->value();
    c.covariance_F = c.measurement->noise(c.p_F);
    c.in_air = ball.state == fw::BallState::kAir;
    c.is_static = ball.is_static && c.in_air;  // a ball lying still for seconds is still the ball
    c.colour = ball.colour;
    c.kinect = &ball;
    c.sighting = KinectSighting{frame.time_s, ball.position_m, ball.covariance_m2};
    candidates.push_back(std::move(c));
  }
  for (const TeammateBall& mate : frame.team) {
    // In the teammate's robot frame, so that its pose's error is added as for this robot's own balls.
    const Eigen::Isometry3d T_F_R = mate.pose.T_F_R();
    const Eigen::Matrix3d turn = T_F_R.linear();
    Candidate c{Source::kTeammate,
                std::make_unique<PositionMeasurement>(T_F_R.inverse() * mate.ball_F.position_m,
                                                      turn.transpose() * mate.ball_F.covariance_m2 * turn, mate.pose,
                                                      mate.pose_error, mate.timing_sigma_s),
                Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()};
    c.p_F = c.measurement->value();
    c.covariance_F = c.measurement->noise(c.p_F);
    c.in_air = mate.ball_F.state == fw::BallState::kAir;
    c.is_static = mate.ball_F.is_static && c.in_air;
    c.colour = mate.ball_F.colour;
    c.teammate = mate.robot_id;
    c.teammate_xy_F = Eigen::Vector2d(mate.pose.x_m, mate.pose.y_m);
    const Eigen::Isometry3d T_R_F = pose.T_F_R().inverse();
    c.sighting =
        KinectSighting{frame.time_s, T_R_F * c.p_F, T_R_F.linear() * c.covariance_F * T_R_F.linear().transpose(),
                       mate.robot_id, mate.timing_sigma_s};
    candidates.push_back(std::move(c));
  }
  for (const TeammateRay& mate : frame.team_rays) {
    auto omni = std::make_unique<OmniMeasurement>(mate.ball, mate.viewpoint, mate.viewpoint, mate.omni, mate.pose_error,
                                                  r, mate.timing_sigma_s);
    Candidate c{Source::kTeammate, nullptr, omni->groundBall_F(), groundCovariance(*omni, mate.ball, mate.viewpoint)};
    c.measurement = std::move(omni);
    c.teammate = mate.robot_id;
    c.teammate_xy_F = Eigen::Vector2d(mate.viewpoint.x_m, mate.viewpoint.y_m);
    c.ray_origin_F = Eigen::Vector3d(mate.viewpoint.x_m, mate.viewpoint.y_m, mate.omni.viewpoint_height_m);
    candidates.push_back(std::move(c));
  }
  for (const fw::OmniBallObservation& ball : frame.omni) {
    auto omni = std::make_unique<OmniMeasurement>(ball, pose, poseAt(frame.time_s + OmniMeasurement::kPoseRateStep_s),
                                                  config_.omni, config_.pose, r, frame.omni_timing_sigma_s);
    Candidate c{Source::kOmni, nullptr, omni->groundBall_F(), groundCovariance(*omni, ball, pose)};
    c.measurement = std::move(omni);
    c.omni = &ball;
    candidates.push_back(std::move(c));
  }
  return candidates;
}

void BallFusion::process(const Frame& frame) {
  const double t = frame.time_s;
  const fw::RobotPose pose = poseAt(t);
  State& state = state_;
  state.update = FusionUpdate{t, std::nullopt};
  if (frame.team_world_ball) {
    const TeammateWorldBall& prior = *frame.team_world_ball;
    state.teammates[prior.robot_id].name = prior.name;
    state.teammate_world_balls[prior.robot_id] = prior;
  }
  std::vector<Candidate> candidates = candidatesOf(frame, pose);
  for (const fw::OmniBallObservation& ball : frame.omni)
    state.omni_reach_m = std::max(state.omni_reach_m, ball.distance_m);

  // Gate every candidate against every track's branches at t, then pair them most likely first.
  std::vector<std::vector<Hypothesis>> branches;
  for (const Track& track : state.tracks) branches.push_back(track.filter.branchesAt(t));
  // Teammates are judged against this robot's own view first (and by the robots they see). A
  // discounted teammate's observations are not used; nor are those of a teammate not yet judged on
  // judge_examples of them whose first few (kFirstJudgements) fail, nor, before those few pass, those
  // that lie near enough to a confirmed ball this robot's own sensors place to be judged by it: this
  // robot sees the ball itself, and a mislocalised teammate would move it until it is found out.
  // (What lies farther is another object to the judge, perhaps the ball where this robot's own view
  // is an orange shirt; an unconfirmed ball may be the phantom of a ball in the air, which the
  // teammate's Kinect places.)
  for (const Candidate& candidate : candidates) {
    if (candidate.source == Source::kTeammate) firstObserved(candidate.teammate, t);
  }
  for (const TeammateSightings& sightings : frame.team_sightings) firstObserved(sightings.robot_id, sightings.time_s);
  judgeTeammates(frame, candidates, pose, t);
  for (const TeammateSightings& sightings : frame.team_sightings) judgeTeammateBySight(sightings);
  std::vector<Eigen::Vector2d> own_placed_F;
  for (const Track& track : state.tracks) {
    if (track.confirmed && ownPlaces(track, pose, t)) own_placed_F.push_back(track.own_view->best().x.head<2>());
  }
  std::vector<bool> withheld(candidates.size(), false);
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    if (candidates[c].source != Source::kTeammate) continue;
    const TeammateStanding& standing = state.teammates[candidates[c].teammate];
    const bool unproven = standing.examples < config_.team.judge_examples &&
                          (standing.examples < kFirstJudgements ||
                           standing.median_mahalanobis > kTrustAgainShare * config_.team.discount_sigma);
    const bool judgeable = std::any_of(own_placed_F.begin(), own_placed_F.end(), [&](const Eigen::Vector2d& placed_F) {
      return (candidates[c].p_F.head<2>() - placed_F).norm() <= kMaxMislocalisation_m;
    });
    const bool suspect = unproven && standing.examples >= kFirstJudgements;
    const bool on_probation = standing.examples < kFirstJudgements && t - *standing.first_observed_s < kProbation_s;
    withheld[c] = standing.discounted || suspect || on_probation || (judgeable && unproven);
  }
  struct Pair {
    double log_likelihood;
    std::size_t candidate, track;
  };
  std::vector<Pair> pairs;
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    for (std::size_t k = 0; k < state.tracks.size(); ++k) {
      const Track& track = state.tracks[k];
      // A ball the colour image rejected is not followed; a static floater only continues a confirmed flight.
      if (candidates[c].colour == fw::ColourVerdict::kRejected || withheld[c]) continue;
      if (candidates[c].is_static && !(track.confirmed && track.flying())) continue;
      const MeasurementFit fit = BallFilter::fit(branches[k], *candidates[c].measurement);
      if (fit.mahalanobis <= config_.track.gate_sigma) pairs.push_back({fit.log_likelihood, c, k});
    }
  }
  std::sort(pairs.begin(), pairs.end(),
            [](const Pair& a, const Pair& b) { return a.log_likelihood > b.log_likelihood; });
  std::vector<bool> candidate_used(candidates.size(), false), track_used(state.tracks.size(), false);
  for (const Pair& pair : pairs) {
    if (candidate_used[pair.candidate] || track_used[pair.track]) continue;
    candidate_used[pair.candidate] = track_used[pair.track] = true;
    const Candidate& c = candidates[pair.candidate];
    Track& track = state.tracks[pair.track];
    track.colour_confirmed |= c.colour == fw::ColourVerdict::kConfirmed;
    if (c.source == Source::kOmni && track.id == state.world_id) learnLatency(track, c, t, frame.omni_latency_s);
    if (c.kinect && track.id == state.world_id) learnPoseLatency(track, c, t);
    if (c.sighting) track.keepSighting(*c.sighting, kLatencyKinectWithin_s);
    const Eigen::Vector3d before_F = BallFilter::likeliest(branches[pair.track]).x.head<3>();
    track.filter.update(branches[pair.track], t, *c.measurement);
    // The world's ball seen by this robot's Kinect teaches the bounce; every track bounces on with it.
    if (c.kinect && track.id == state.world_id && config_.motion.learn_bounce && state.bounce.add(track.id, t, c.p_F)) {
      for (Track& each : state.tracks) {
        each.filter.useBounceOf(state.bounce.motion());
        if (each.own_view) each.own_view->useBounceOf(state.bounce.motion());
      }
    }
    if (c.source != Source::kTeammate) {
      const bool own_lost = t - std::max(track.last_kinect_s, track.last_omni_s) > kSourceRecent_s;
      if (!track.own_view || own_lost) {
        track.own_view = BallFilter(state.bounce.motion(), t, initialHypotheses(c));
      } else {
        track.own_view->update(track.own_view->branchesAt(t), t, *c.measurement);
      }
    }
    const bool reacquired = c.locates() && (track.filter.best().x.head<3>() - before_F).norm() > kReacquireJump_m;
    if (reacquired) track.filter.forgetVelocity(config_.track.initial_speed_sigma_mps);
    ++track.updates;
    track.supportedBy(c, t);
    if (track.filter.best().mode == fw::BallState::kGround) track.seen_on_ground = true;
  }
  // The omni camera looked all round and did not see these balls: where it should have, the
  // ball is less likely (a ball gone from its view after a kick has most likely flown above it).
  if (frame.source == Source::kOmni) {
    const OmniConfig& omni = config_.omni;
    const auto seen_probability = [&omni](const Hypothesis& h) {
      return omni.detection_probability * omniVisibleProbability(h, omni);
    };
    for (std::size_t k = 0; k < state.tracks.size(); ++k) {
      if (track_used[k]) continue;
      state.tracks[k].filter.notSeen(t, seen_probability);
      if (state.tracks[k].own_view) state.tracks[k].own_view->notSeen(t, seen_probability);
    }
  }
  // What no track took starts one, but a ball the colour image rejected, a static floater (the match
  // log has both verdicts in its ball rows) and a withheld teammate's (a discounted one's event says so).
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    if (candidate_used[c] || candidates[c].colour == fw::ColourVerdict::kRejected || candidates[c].is_static ||
        withheld[c]) {
      continue;
    }
    startTrack(candidates[c], t);
  }
  maintainTracks(t);
}

bool BallFusion::ignores(const std::string& teammate) const {
  const std::vector<std::string>& ignored = config_.team.ignore;
  return std::find(ignored.begin(), ignored.end(), teammate) != ignored.end();
}

const std::string& BallFusion::nameOf(Source source) const {
  return source == Source::kKinect ? config_.kinect.source : config_.omni.source;
}

void BallFusion::Track::supportedBy(const Candidate& candidate, double t_s) {
  last_support_s = t_s;
  if (candidate.locates()) last_located_s = t_s;
  switch (candidate.source) {
    case Source::kKinect:
      last_kinect_s = t_s;
      break;
    case Source::kOmni:
      last_omni_s = t_s;
      break;
    case Source::kTeammate:
      last_teammate_s[candidate.teammate] = t_s;
      break;
  }
}

void BallFusion::Track::keepSighting(const KinectSighting& sighting, double within_s) {
  if (kinect_sighting_count > 0) {
    const KinectSighting& newest = kinect_sightings[kinect_sighting_count - 1];
    const bool same_kinect = newest.teammate == sighting.teammate;
    const bool displaces = !sighting.teammate || sighting.time_s - newest.time_s >= within_s;
    if (!same_kinect && !displaces) return;
    if (!same_kinect) kinect_sighting_count = 0;
  }
  if (kinect_sighting_count == kinect_sightings.size()) {
    std::rotate(kinect_sightings.begin(), kinect_sightings.begin() + 1, kinect_sightings.end());  // the oldest goes
    --kinect_sighting_count;
  }
  kinect_sightings[kinect_sighting_count++] = sighting;
}

void BallFusion::judgeTeammates(const Frame& frame, const std::vector<Candidate>& candidates, const fw::RobotPose& pose,
                                double t_s) {
  State& state = state_;
  for (const TeammateBall& mate : frame.team) state.teammates[mate.robot_id].name = mate.name;
  for (const TeammateRay& mate : frame.team_rays) state.teammates[mate.robot_id].name = mate.name;
  // Each teammate by the one of its observations that best matches this robot's own ball: the
  // confirmed track its own sensors support now (the world's ball when they do), as they alone see
  // it (its own view: whoever else supports the track, no teammate is judged against itself or
  // against another), and of the teammate's observations the closest (its others may be other
  // objects: orange shirts, a second ball).
  const auto ownSupport_s = [](const Track& track) { return std::max(track.last_kinect_s, track.last_omni_s); };
  const Track* own = nullptr;
  for (const Track& track : state.tracks) {
    if (!track.confirmed || t_s - ownSupport_s(track) > kJudgeOwnSupportWithin_s) continue;
    const bool better =
        !own || track.id == state.world_id || (own->id != state.world_id && ownSupport_s(track) > ownSupport_s(*own));
    if (better) own = &track;
  }
  if (own == nullptr) return;
  const std::vector<Hypothesis> own_branches = own->own_view->branchesAt(t_s);
  std::map<int, Judgement> closest;
  for (const Candidate& candidate : candidates) {
    if (candidate.source != Source::kTeammate) continue;
    std::optional<Judgement> judged = judge(candidate, *own, own_branches, pose, t_s);
    if (judged) judged->from_teammate_m = (candidate.p_F.head<2>() - candidate.teammate_xy_F).norm();
    const auto found = closest.find(candidate.teammate);
    if (judged && (found == closest.end() || judged->mahalanobis < found->second.mahalanobis)) {
      closest[candidate.teammate] = *judged;
    }
  }
  for (const auto& [teammate, judgement] : closest) recordJudgement(teammate, judgement);
}

std::optional<BallFusion::Judgement> BallFusion::judge(const Candidate& candidate, const Track& own,
                                                       const std::vector<Hypothesis>& own_branches,
                                                       const fw::RobotPose& pose, double t_s) const {
  // Only against what this robot's own sensors place: its Kinect's ball; the world's ball on the
  // floor, which its omni camera holds (a teammate's ray); or the ball its omni camera holds where the
  // teammate's Kinect ball is (on the floor, or in the air: then by its bearing).
  const bool own_kinect = t_s - own.last_kinect_s <= kJudgeOwnSupportWithin_s;
  const bool own_omni = t_s - own.last_omni_s <= kJudgeOwnSupportWithin_s;
  if (!own_kinect && !own_omni) return std::nullopt;
  const Hypothesis& best =
      *std::max_element(own_branches.begin(), own_branches.end(),
                        [](const Hypothesis& a, const Hypothesis& b) { return a.weight < b.weight; });
  const Eigen::Vector3d own_F = best.x.head<3>();
  // How far, in bearing seen from `from`, `seen` lies off this robot's ball, in sigmas given the
  // variance of its own bearing; and how far that puts this robot's ball off the line of sight.
  const auto byBearing = [&](const Eigen::Vector2d& from, const Eigen::Vector2d& seen,
                             double seen_variance_rad2) -> std::optional<Judgement> {
    const Eigen::Vector2d to_seen = seen - from, to_own = own_F.head<2>() - from;
    const double d = std::max(to_own.norm(), 0.1);
    const double residual = fw::wrapAngle(std::atan2(to_seen.y(), to_seen.x()) - std::atan2(to_own.y(), to_own.x()));
    const Eigen::Vector2d across(-to_own.y() / d, to_own.x() / d);
    const double variance = seen_variance_rad2 + across.dot(best.P.topLeftCorner<2, 2>() * across) / (d * d);
    const double gap_m = d * std::abs(std::sin(residual));
    if (gap_m > kMaxMislocalisation_m) return std::nullopt;
    return Judgement{std::abs(residual) / std::sqrt(variance), gap_m, d * std::sqrt(variance)};
  };
  if (candidate.ray_origin_F) {
    // An omni ray by its bearing alone (a ball in the air lies on the bearing of its phantom). A ray
    // does not say whether the ball is in the air: against a ball this robot's omni camera alone holds,
    // only the world's on the floor (another may be an orange shirt, or a phantom).
    if (!own_kinect && (own.id != state_.world_id || own.mayFly())) return std::nullopt;
    return byBearing(candidate.ray_origin_F->head<2>(), candidate.p_F.head<2>(),
                     candidate.measurement->noise(candidate.p_F)(0, 0));
  }
  const Eigen::Vector2d camera(pose.x_m, pose.y_m);
  const Eigen::Vector2d to_seen = candidate.p_F.head<2>() - camera;
  const double d = std::max(to_seen.norm(), 0.1);
  if (!own_kinect) {
    // This robot's omni camera holds the teammate's ball, if it is the same ball, where the teammate
    // puts it along the line of sight, and in the same mode: both on the floor, or both in the air
    // (then by its bearing, all the omni camera gives of a ball in the air). A ball on the floor
    // while the teammate's flies is another object, an orange shirt, or a phantom: it says nothing
    // of the teammate; so is one elsewhere along the line of sight, unless the omni camera places
    // the ball on the floor near enough to know: there is one ball, and a teammate that puts it
    // where this robot sees none is off (its localisation, or its eyes).
    const double own_m = (own_F.head<2>() - camera).norm();
    if (own.mayFly() != candidate.in_air || candidate.p_F.z() > config_.omni.max_height_m ||
        (std::abs(own_m - d) > std::max(kSameBallAlong_m, kSameBallAlongShare * d) && !omniPlaces(own, pose, t_s))) {
      return std::nullopt;
    }
  }
  if (own_kinect || !candidate.in_air) {
    // A Kinect ball on the floor plane only: a robot's localisation errs there, while a Kinect far
    // away puts a ball on the floor a little high.
    const Eigen::Vector2d gap = (candidate.p_F - own_F).head<2>();
    if (gap.norm() > kMaxMislocalisation_m) return std::nullopt;
    const Eigen::Matrix2d S = best.P.topLeftCorner<2, 2>() + candidate.covariance_F.topLeftCorner<2, 2>();
    const double mahalanobis = std::sqrt(gap.dot(S.ldlt().solve(gap)));
    const double sigma_m = gap.norm() > 1e-6 ? gap.norm() / mahalanobis : std::sqrt(S.trace() / 2.0);
    return Judgement{mahalanobis, gap.norm(), sigma_m};
  }
  // A ball in the air to this robot's omni camera: the teammate's Kinect ball by its bearing from
  // this robot's camera, which lies on this robot's ray to the ball.
  const Eigen::Vector2d across(-to_seen.y() / d, to_seen.x() / d);
  const double sigma_b = config_.omni.bearing_sigma_rad;
  return byBearing(camera, candidate.p_F.head<2>(),
                   sigma_b * sigma_b + across.dot(candidate.covariance_F.topLeftCorner<2, 2>() * across) / (d * d));
}

void BallFusion::firstObserved(int teammate, double t_s) {
  std::optional<double>& first_s = state_.teammates[teammate].first_observed_s;
  if (!first_s || t_s < *first_s) first_s = t_s;
}

void BallFusion::judgeTeammateBySight(const TeammateSightings& sightings) {
  const double t_s = sightings.time_s;
  state_.teammates[sightings.robot_id].name = sightings.name;
  // Where robots stand, as this robot knows it: itself; its teammates not discounted, where they
  // believe they stand; and the robots its omni camera saw in its image nearest in time (each place
  // with its variance, the pose errors included).
  struct Place {
    Eigen::Vector2d xy_F;
    Eigen::Matrix2d covariance_m2;
  };
  const fw::RobotPose own_pose = poseAt(t_s);
  const Eigen::Vector2d own_xy(own_pose.x_m, own_pose.y_m);
  const auto poseVariance_m2 = [](const PoseConfig& error, double distance_m) {
    return error.sigma_xy_m * error.sigma_xy_m + std::pow(distance_m * error.sigma_theta_rad, 2);
  };
  std::vector<Place> places{{own_xy, poseVariance_m2(config_.pose, 0.0) * Eigen::Matrix2d::Identity()}};
  for (const auto& [robot_id, believed] : teammate_poses_) {
    const auto standing = state_.teammates.find(robot_id);
    const bool discounted = standing != state_.teammates.end() && standing->second.discounted;
    if (robot_id == sightings.robot_id || discounted ||
        t_s - believed.newest_s > fw::PoseHistory::kMaxExtrapolation_s) {
      continue;
    }
    const fw::RobotPose pose = believed.poses.at(t_s);
    places.push_back(
        {Eigen::Vector2d(pose.x_m, pose.y_m), poseVariance_m2(believed.error, 0.0) * Eigen::Matrix2d::Identity()});
  }
  double nearest_image_s = std::numeric_limits<double>::infinity();
  for (const fw::SeenRobot& seen : seen_robots_) {
    if (std::abs(seen.time_s - t_s) < std::abs(nearest_image_s - t_s)) nearest_image_s = seen.time_s;
  }
  if (std::abs(nearest_image_s - t_s) <= kSightingsApart_s) {
    for (const fw::SeenRobot& seen : seen_robots_) {
      if (seen.time_s != nearest_image_s) continue;
      const double moved_m = kRobotSpeed_mps * std::abs(seen.time_s - t_s);
      const double variance_m2 = poseVariance_m2(config_.pose, (seen.position_F - own_xy).norm()) +
                                 kRobotCentreSigma_m * kRobotCentreSigma_m + moved_m * moved_m;
      const Place place{seen.position_F, seen.covariance_m2 + variance_m2 * Eigen::Matrix2d::Identity()};
      // A robot seen where a teammate believes it stands is that teammate, placed better by its belief.
      const bool known = std::any_of(places.begin(), places.end(), [&](const Place& other) {
        const Eigen::Vector2d gap = place.xy_F - other.xy_F;
        return gap.dot((place.covariance_m2 + other.covariance_m2).ldlt().solve(gap)) <=
               kSameRobot_sigma * kSameRobot_sigma;
      });
      if (!known) places.push_back(place);
    }
  }
  // Each place by the teammate's sighting nearest to it (a robot it saw farther off is another
  // robot, or none it saw); the teammate by the place it agrees with best: a robot it did not see
  // and an opponent it saw beside it make places it disagrees with however well it is localised.
  std::optional<Judgement> best;
  for (const Place& place : places) {
    const fw::SeenRobot* nearest = nullptr;
    for (const fw::SeenRobot& seen : sightings.robots) {
      if (!nearest || (seen.position_F - place.xy_F).norm() < (nearest->position_F - place.xy_F).norm()) {
        nearest = &seen;
      }
    }
    const Eigen::Vector2d gap = nearest->position_F - place.xy_F;
    if (gap.norm() > kMaxMislocalisation_m) continue;
    const double from_teammate_m = (nearest->position_F - sightings.teammate_xy).norm();
    const Eigen::Matrix2d S =
        place.covariance_m2 + nearest->covariance_m2 +
        (poseVariance_m2(sightings.pose_error, from_teammate_m) + kRobotCentreSigma_m * kRobotCentreSigma_m) *
            Eigen::Matrix2d::Identity();
    const double mahalanobis = std::sqrt(gap.dot(S.ldlt().solve(gap)));
    const double sigma_m = gap.norm() > 1e-6 ? gap.norm() / mahalanobis : std::sqrt(S.trace() / 2.0);
    if (!best || mahalanobis < best->mahalanobis) best = Judgement{mahalanobis, gap.norm(), sigma_m, from_teammate_m};
  }
  if (best) recordJudgement(sightings.robot_id, *best);
}

bool BallFusion::omniPlaces(const Track& own, const fw::RobotPose& pose, double t_s) const {
  if (t_s - own.last_omni_s > kJudgeOwnSupportWithin_s || own.mayFly()) return false;
  const double distance_m = (own.own_view->best().x.head<2>() - Eigen::Vector2d(pose.x_m, pose.y_m)).norm();
  return config_.omni.distance_sigma_m + config_.omni.distance_sigma_fraction * distance_m <= kOmniPlacesWithin_m;
}

bool BallFusion::ownPlaces(const Track& own, const fw::RobotPose& pose, double t_s) const {
  return t_s - own.last_kinect_s <= kJudgeOwnSupportWithin_s || omniPlaces(own, pose, t_s);
}

void BallFusion::recordJudgement(int teammate, const Judgement& judgement) {
  std::deque<Judgement>& judged = state_.judged[teammate];
  judged.push_back(judgement);
  if (judged.size() > static_cast<std::size_t>(config_.team.judge_examples)) judged.pop_front();
  std::vector<double> distances, gaps_m, sigmas_m, from_teammate_m;
  for (const Judgement& j : judged) {
    distances.push_back(j.mahalanobis);
    gaps_m.push_back(j.gap_m);
    sigmas_m.push_back(j.sigma_m);
    from_teammate_m.push_back(j.from_teammate_m);
  }
  TeammateStanding& standing = state_.teammates[teammate];
  standing.examples = static_cast<int>(judged.size());
  standing.median_mahalanobis = fw::quantile(distances, 0.5);
  standing.median_gap_m = fw::quantile(gaps_m, 0.5);
  if (standing.examples < config_.team.judge_examples) return;
  const double median_sigma_m = fw::quantile(sigmas_m, 0.5),
               median_from_teammate_m = fw::quantile(from_teammate_m, 0.5);
  if (!standing.discounted && standing.median_mahalanobis > config_.team.discount_sigma) {
    standing.discounted = true;
    standing.discounted_gap_m = standing.median_gap_m;
    standing.discounted_from_m = median_from_teammate_m;
  }
  // Trusted again only by observations that would show the error it was discounted for. A turned
  // teammate's error grows with the ball's distance from it (20 degrees: 1.7 m at 5 m, 0.2 m at
  // 0.6 m), so that error is taken to shrink with the distance; a shifted one's would not.
  const double error_now_m =
      standing.discounted_gap_m *
      std::min(1.0, median_from_teammate_m / std::max(standing.discounted_from_m, kAtTheTeammate_m));
  if (standing.discounted && standing.median_mahalanobis < kTrustAgainShare * config_.team.discount_sigma &&
      error_now_m >= config_.team.discount_sigma * median_sigma_m) {
    standing.discounted = false;
  }
}

void BallFusion::learnLatency(const Track& track, const Candidate& candidate, double t, double applied_s) {
  // The Kinect's ball at t: its newest, carried on at its velocity over its frames of the baseline
  // (up to a third of a second: the longer, the less of the Kinect's noise is in the rate).
  // No Kinect on the ball lately: the robot's own turns are what times the omni then.
  if (track.kinect_sighting_count == 0 ||
      t - track.kinect_sightings[track.kinect_sighting_count - 1].time_s >= kLatencyKinectWithin_s) {
    learnLatencyFromTurn(track, candidate, applied_s);
    return;
  }
  const auto seen_end = track.kinect_sightings.begin() + track.kinect_sighting_count;
  const KinectSighting& newest = *(seen_end - 1);
  // In the air it falls, on the floor it lies there: the velocity is taken over the sightings of
  // the baseline since the ball last left the floor or came down (a kick inside the baseline would
  // make it the average of rest and flight, and the carried ball lag behind).
  const double radius_m = config_.motion.radius_m;
  const auto flying = [radius_m](const KinectSighting& k) {
    return k.p_R.z() - radius_m > std::max(kLatencyOffTheFloor_m, 3.0 * std::sqrt(k.covariance_R(2, 2)));
  };
  auto first = seen_end - 1;
  while (first != track.kinect_sightings.begin() && newest.time_s - (first - 1)->time_s <= kLatencyRateBaseline_s &&
         flying(*(first - 1)) == flying(newest)) {
    --first;
  }
  const bool in_air = flying(newest);
  const Eigen::Vector3d gravity = in_air ? Eigen::Vector3d(0.0, 0.0, -fw::kGravity_mps2) : Eigen::Vector3d::Zero();
  // Nor over a kick, a bounce off a robot or a touch: a sighting off the path from the first to the
  // newest (a line, a parabola in the air) beyond its noise starts the baseline afresh.
  for (auto k = first + 1; k < seen_end - 1; ++k) {
    const double s = (k->time_s - first->time_s) / (newest.time_s - first->time_s);
    const double from_first_s = k->time_s - first->time_s, to_newest_s = newest.time_s - k->time_s;
    const Eigen::Vector3d on_path =
        first->p_R + s * (newest.p_R - first->p_R) - 0.5 * from_first_s * to_newest_s * gravity;
    const Eigen::Matrix3d spread =
        k->covariance_R + (1.0 - s) * (1.0 - s) * first->covariance_R + s * s * newest.covariance_R;
    const Eigen::Vector3d off = k->p_R - on_path;
    if (off.dot(spread.ldlt().solve(off)) > kLatencyOffPathChi2) first = k;
  }
  // A least-squares line (a parabola in the air) through the sightings of the baseline: where the
  // ball was at the newest's time and how fast it went, its noise the sightings' over their spread.
  const int n = static_cast<int>(seen_end - first);
  if (n < 2) return;
  double mean_tau = 0.0;
  for (auto k = first; k != seen_end; ++k) mean_tau += (k->time_s - newest.time_s) / n;
  double spread_s2 = 0.0;
  Eigen::Vector3d mean_p = Eigen::Vector3d::Zero(), v_newest = Eigen::Vector3d::Zero();
  Eigen::Matrix3d noise = Eigen::Matrix3d::Zero();
  for (auto k = first; k != seen_end; ++k) {
    const double tau = k->time_s - newest.time_s;
    mean_p += (k->p_R - 0.5 * tau * tau * gravity) / n;
    noise += k->covariance_R / n;
  }
  for (auto k = first; k != seen_end; ++k) {
    const double tau = k->time_s - newest.time_s;
    spread_s2 += (tau - mean_tau) * (tau - mean_tau);
    v_newest += (tau - mean_tau) * (k->p_R - 0.5 * tau * tau * gravity - mean_p);
  }
  v_newest /= spread_s2;
  const Eigen::Vector3d p_newest = mean_p - mean_tau * v_newest;
  const double ahead_s = t - newest.time_s;
  Eigen::Vector3d p_R = p_newest + ahead_s * v_newest + 0.5 * ahead_s * ahead_s * gravity;
  Eigen::Vector3d v_R = v_newest + ahead_s * gravity;
  const Eigen::Matrix3d carried_covariance =
      (1.0 / n + (ahead_s - mean_tau) * (ahead_s - mean_tau) / spread_s2) * noise;
  const Eigen::Matrix3d velocity_covariance = noise / spread_s2;

  // On the floor the omni reports the ball where it lies, whatever the Kinect's height noise says
  // (through a phantom's slope, 8 m of distance per metre of height, it would swamp the distance).
  if (!in_air) {
    p_R.z() = radius_m;
    v_R.z() = 0.0;
  }
  const Eigen::Vector2d predicted = omniView_R(p_R, config_.omni, radius_m);
  Eigen::Matrix<double, 2, 3> J = omniViewJacobian_R(p_R, config_.omni, radius_m);
  if (!in_air) J.col(2).setZero();
  const Eigen::Vector2d rate = J * v_R;
  const fw::OmniBallObservation& omni = *candidate.omni;
  const Eigen::Vector2d residual(fw::wrapAngle(omni.bearing_rad - predicted[0]), omni.distance_m - predicted[1]);
  const Eigen::Vector2d omni_sigma(omniBearingSigma_rad(omni, config_.omni),
                                   omniDistanceSigma_m(omni, config_.omni, omni.distance_m));
  // The omni's view of the carried ball tau seconds before t (at tau 0: predicted).
  const auto carriedBefore = [&](double tau_s) {
    const double from_newest_s = ahead_s - tau_s;
    Eigen::Vector3d p = p_newest + from_newest_s * v_newest + 0.5 * from_newest_s * from_newest_s * gravity;
    if (!in_air) p.z() = radius_m;
    return p;
  };
  const auto viewBefore = [&](double tau_s) { return omniView_R(carriedBefore(tau_s), config_.omni, radius_m); };
  // The offsets the estimate so far leaves plausible (three sigma round it, beside the one that
  // corrected t): a reading whose view turns back within them could be off either way.
  const std::optional<LatencyEstimator::Fit> so_far = state_.latency.fit(config_.omni.timing_sigma_s);
  const double offset_window_s = so_far ? std::abs(so_far->latency_s - applied_s) + 3.0 * so_far->sigma_s
                                        : std::abs(applied_s) + 3.0 * config_.omni.timing_sigma_s;
  for (int i = 0; i < 2; ++i) {
    // A teammate's ball is on this robot's clock to within their exchange's bound: its time's error
    // moves the reading as the ball does.
    const double clock_error = rate[i] * newest.timing_sigma_s;
    const double variance = omni_sigma[i] * omni_sigma[i] + J.row(i) * carried_covariance * J.row(i).transpose() +
                            clock_error * clock_error;
    if ((i == 0 && std::abs(residual[i]) > kLatencyMaxBearingResidual_rad) ||
        std::abs(residual[i]) > kLatencyMaxOffset_s * std::abs(rate[i]) + 3.0 * std::sqrt(variance)) {
      continue;
    }
    // A rate within three sigma of its own noise is mostly the Kinect's noise (a bearing that stands
    // still, a phantom's distance at 8-46 m per metre of the Kinect's height), and that noise is in
    // the residual too, which the fit would read as time: 60-95 ms learnt too late for a ball rolled
    // straight away (docs/fusion.md, "Time"). Such a reading is not used.
    const double rate_sigma = std::sqrt(J.row(i) * velocity_covariance * J.row(i).transpose());
    if (std::abs(rate[i]) < kLatencyRateSignificance * rate_sigma) continue;
    const auto change_over = [&](double tau_s) {
      const double change = predicted[i] - viewBefore(tau_s)[i];
      return i == 0 ? fw::wrapAngle(change) : change;
    };
    const auto change_if_seen = [&](double tau_s) {
      return omniCanSee(carriedBefore(tau_s), config_.omni) ? change_over(tau_s)
                                                            : std::numeric_limits<double>::quiet_NaN();
    };
    // Passed by reference: a std::function holding the lambdas themselves would take them on the heap.
    if (omniOffsetIsAmbiguous(std::cref(change_if_seen), residual[i], rate[i], offset_window_s)) continue;
    const double secant = omniSecantRate(std::cref(change_over), residual[i], rate[i], kLatencyMaxOffset_s);
    state_.latency.add(residual[i], variance, secant, applied_s, i == 1 ? predicted[1] : 0.0);
  }
}

void BallFusion::learnLatencyFromTurn(const Track& track, const Candidate& candidate, double applied_s) {
  // The ball must lie still, as its track says and as the omni's balls agree.
  RestingBall& resting = state_.resting;
  const Hypothesis& best = track.filter.best();
  const Eigen::Vector3d& ground_F = candidate.p_F;  // an omni ball's: where it lies if on the floor
  const MeasurementModel& omni = *candidate.measurement;
  const double radius_m = config_.motion.radius_m;
  const bool at_rest = best.mode == fw::BallState::kGround && best.x.tail<3>().norm() < kRestingSpeed_mps;
  // A turn moves the ball's bearing, not its distance: a distance off the reference's is another
  // place, and so is a track that moved away from it.
  if (!at_rest || resting.track_id != track.id ||
      (resting.count > 0 && (std::abs(omni.value()[1] - omni.predict(resting.mean_F(radius_m))[1]) > kRestingSpread_m ||
                             (best.x.head<2>() - resting.mean_F(radius_m).head<2>()).norm() > kRestingSpread_m))) {
    resting = RestingBall{};
    if (!at_rest) return;
    resting.track_id = track.id;
  }
  const MeasurementVector rate = omni.ownMotionRate(ground_F);
  // Standing still, the robot sees the ball where it lies whatever the latency: that is the reference.
  if (std::abs(rate[0]) < kStillBearingRate_radps && std::abs(rate[1]) < kStillDistanceRate_mps) {
    resting.sum_xy_F += ground_F.head<2>();
    ++resting.count;
    return;
  }
  if (resting.count < kRestingReadings) return;
  // Turning, the bearing lags the turn: the residual against the reference is -rate (L - applied).
  const Eigen::Vector3d reference_F = resting.mean_F(radius_m);
  const MeasurementVector turn_rate = omni.ownMotionRate(reference_F);
  const double residual = fw::wrapAngle(omni.value()[0] - omni.predict(reference_F)[0]);
  // The omni's noise, the reference's mean's, and the pose's heading error since the reference was
  // taken: up to the localisation's whole error, and slow, so that the readings of a second share
  // it; counted once in each of them as if each were alone, it made the estimate three times surer
  // than it was.
  const double omni_sigma = omniBearingSigma_rad(*candidate.omni, config_.omni);
  const double variance = omni_sigma * omni_sigma * (1.0 + 1.0 / resting.count) +
                          kHeadingErrorSharedBy * std::pow(config_.pose.sigma_theta_rad, 2);
  if (std::abs(residual) > kLatencyMaxOffset_s * std::abs(turn_rate[0]) + 3.0 * std::sqrt(variance)) return;
  state_.latency.add(residual, variance, turn_rate[0], applied_s);
}

void BallFusion::learnPoseLatency(const Track& track, const Candidate& candidate, double t) {
  RestingBall& resting = state_.kinect_resting;
  const Hypothesis& best = track.filter.best();
  const double radius_m = config_.motion.radius_m;
  const Eigen::Vector3d& ball_R = candidate.kinect->position_m;
  const auto bearing_R = [](const Eigen::Vector3d& p_R) { return std::atan2(-p_R.x(), p_R.y()); };
  // The pose at t and a step later, looked up once: how the pose alone moves a ball in the robot's view.
  constexpr double kStep_s = OmniMeasurement::kPoseRateStep_s;
  const Eigen::Isometry3d T_R_F = poseAt(t).T_F_R().inverse(), T_R_F_later = poseAt(t + kStep_s).T_F_R().inverse();
  const bool at_rest = best.mode == fw::BallState::kGround && best.x.tail<3>().norm() < kRestingSpeed_mps &&
                       candidate.kinect->state == fw::BallState::kGround;
  // A turn moves the ball's bearing, not its distance: a distance off the reference's is another
  // place, and so is a track that moved away from it.
  if (!at_rest || resting.track_id != track.id ||
      (resting.count > 0 &&
       (std::abs(ball_R.head<2>().norm() - (T_R_F * resting.mean_F(radius_m)).head<2>().norm()) > kRestingSpread_m ||
        (best.x.head<2>() - resting.mean_F(radius_m).head<2>()).norm() > kRestingSpread_m))) {
    resting = RestingBall{};
    if (!at_rest) return;
    resting.track_id = track.id;
  }
  // How fast the pose alone turns and moves a ball lying at p_F in the robot's view.
  const auto poseRates = [&](const Eigen::Vector3d& p_F) {
    const Eigen::Vector3d now_R = T_R_F * p_F, later_R = T_R_F_later * p_F;
    return Eigen::Vector2d(fw::wrapAngle(bearing_R(later_R) - bearing_R(now_R)) / kStep_s,
                           (later_R.head<2>().norm() - now_R.head<2>().norm()) / kStep_s);
  };
  const Eigen::Vector2d still = poseRates(candidate.p_F);
  // Standing still, the pose maps the ball to where it lies whatever the latency: that is the reference.
  if (std::abs(still[0]) < kStillBearingRate_radps && std::abs(still[1]) < kStillDistanceRate_mps) {
    resting.sum_xy_F += candidate.p_F.head<2>();
    ++resting.count;
    return;
  }
  if (resting.count < kRestingReadings) return;
  // Turning, a late pose is one from before: the reference's bearing predicted through it lags the
  // Kinect's by the pose's rate times (L - applied). The estimator reads residual = -rate (L - applied).
  const Eigen::Vector3d reference_F = resting.mean_F(radius_m);
  const double turn_rate = poseRates(reference_F)[0];
  const double residual = fw::wrapAngle(bearing_R(ball_R) - bearing_R(T_R_F * reference_F));
  // The Kinect's bearing noise, the reference's mean's, and the pose's heading error since the
  // reference, shared by a second of readings (learnLatencyFromTurn).
  const double rho2 = std::max(ball_R.head<2>().squaredNorm(), 1e-6);
  const Eigen::Vector2d d_bearing(-ball_R.y() / rho2, ball_R.x() / rho2);
  const double kinect_variance = d_bearing.dot(candidate.kinect->covariance_m2.topLeftCorner<2, 2>() * d_bearing);
  const double variance =
      kinect_variance * (1.0 + 1.0 / resting.count) + kHeadingErrorSharedBy * std::pow(config_.pose.sigma_theta_rad, 2);
  if (std::abs(residual) > kLatencyMaxOffset_s * std::abs(turn_rate) + 3.0 * std::sqrt(variance)) return;
  const std::optional<LatencyEstimator::Fit> applied = poseLatency();
  state_.pose_latency.add(residual, variance, -turn_rate, applied ? applied->latency_s : 0.0);
}

std::vector<Hypothesis> BallFusion::initialHypotheses(const Candidate& candidate) const {
  Hypothesis h;
  h.x.head<3>() = candidate.p_F;
  h.P.setZero();
  h.P.topLeftCorner<3, 3>() = candidate.covariance_F;
  h.P.bottomRightCorner<3, 3>() = std::pow(config_.track.initial_speed_sigma_mps, 2) * Eigen::Matrix3d::Identity();
  if (candidate.in_air) {
    h.mode = fw::BallState::kAir;
    return {h};
  }
  // On the floor by its looks; a ball just kicked looks the same for a frame.
  h.weight = 0.9;
  Hypothesis kicked = h;
  kicked.mode = fw::BallState::kAir;
  kicked.weight = 0.1;
  return {h, kicked};
}

void BallFusion::startTrack(const Candidate& candidate, double t_s) {
  if (state_.tracks.size() >= kMaxTracks) {
    const auto oldest_tentative =
        std::find_if(state_.tracks.begin(), state_.tracks.end(), [](const Track& track) { return !track.confirmed; });
    if (oldest_tentative == state_.tracks.end()) return;  // eight confirmed balls: no room for a ninth
    state_.tracks.erase(oldest_tentative);
  }
  Track track{state_.next_id++, BallFilter(state_.bounce.motion(), t_s, initialHypotheses(candidate))};
  if (candidate.source != Source::kTeammate) track.own_view = track.filter;
  track.updates = 1;
  track.born_s = t_s;
  track.supportedBy(candidate, t_s);
  track.seen_on_ground = !candidate.in_air;
  track.omni_born = candidate.source == Source::kOmni || candidate.ray_origin_F.has_value();
  track.colour_confirmed = candidate.colour == fw::ColourVerdict::kConfirmed;
  state_.tracks.push_back(std::move(track));
}

void BallFusion::maintainTracks(double t_s) {
  const TrackConfig& config = config_.track;
  auto& tracks = state_.tracks;
  tracks.erase(std::remove_if(tracks.begin(), tracks.end(),
                              [&](const Track& track) {
                                return t_s - track.last_support_s > config.lost_after_s ||
                                       (!track.confirmed && t_s - track.born_s > config.confirm_window_s);
                              }),
               tracks.end());
  // While a confirmed ball flies, new omni tracks are most likely its phantoms: they wait.
  const bool ball_in_air =
      std::any_of(tracks.begin(), tracks.end(), [](const Track& track) { return track.confirmed && track.flying(); });
  for (Track& track : tracks) {
    if (track.confirmed || track.updates < config.confirm_updates) continue;
    if (track.omni_born && ball_in_air) continue;
    // Born in the air, a track must fly: its speed, less one sigma, above the minimum.
    const Hypothesis& best = track.filter.best();
    const double speed_sigma = std::sqrt(best.P.bottomRightCorner<3, 3>().trace());
    // A ball the colour image confirmed is the ball wherever it is, flying or not.
    track.confirmed = track.colour_confirmed || track.seen_on_ground ||
                      best.x.tail<3>().norm() - speed_sigma > config.min_flight_speed_mps;
  }
  // The world's ball is kept while it is supported, and while it flies (a flight above the omni's
  // view and out of the Kinect's is carried, not swapped for another ball) or, once a Kinect has
  // located it, has rolled beyond the omni camera's reach, until a Kinect, this robot's or a
  // teammate's, locates another confirmed ball: then the ball was lost, not hidden. Otherwise, on the
  // ground without support for kWorldSwitchAfter_s it gives way to a confirmed track supported since
  // (for a robot with only its omni camera, a flight it placed too far gives way to where the camera
  // sees the ball), and it is dropped when lost.
  const auto world =
      std::find_if(tracks.begin(), tracks.end(), [&](const Track& track) { return track.id == state_.world_id; });
  if (world != tracks.end() && t_s - world->last_support_s <= kWorldSwitchAfter_s) return;
  const bool carried = world != tracks.end() && (world->flying() || beyondOmniReach(*world, t_s));
  const auto locatedSince = [&](const Track& track) {
    return track.confirmed && track.last_located_s > world->last_support_s;
  };
  if (carried && std::none_of(tracks.begin(), tracks.end(), locatedSince)) return;
  const Track* chosen = world != tracks.end() ? &*world : nullptr;
  for (const Track& track : tracks) {
    if (!track.confirmed || (carried && !locatedSince(track))) continue;
    if (!chosen || track.last_support_s > chosen->last_support_s ||
        (track.last_support_s == chosen->last_support_s && track.updates > chosen->updates)) {
      chosen = &track;
    }
  }
  state_.world_id = chosen ? chosen->id : 0;
}

bool BallFusion::beyondOmniReach(const Track& track, double t_s) const {
  if (state_.omni_reach_m <= 0.0 || track.last_located_s < track.born_s) return false;
  const auto distance_m = [&](const BallFilter& filter) {
    const fw::RobotPose pose = poseAt(filter.time());
    return (filter.best().x.head<2>() - Eigen::Vector2d(pose.x_m, pose.y_m)).norm();
  };
  // Last seen near the edge: a ball that drifts out on a stale track's prediction while another
  // track takes its measurements has not left the view.
  if (distance_m(track.filter) < kLeavingReachShare * state_.omni_reach_m) return false;
  BallFilter filter = track.filter;
  filter.predict(t_s);
  return distance_m(filter) > state_.omni_reach_m;
}

std::optional<fw::FusedBall> BallFusion::worldBall(double t_s) const {
  const auto world = std::find_if(state_.tracks.begin(), state_.tracks.end(),
                                  [&](const Track& track) { return track.id == state_.world_id; });
  if (world == state_.tracks.end()) return teammatePrior(t_s);
  BallFilter filter = world->filter;
  filter.predict(t_s);
  const Hypothesis& best = filter.best();
  fw::FusedBall ball;
  ball.position_F = best.x.head<3>();
  ball.velocity_F = best.x.tail<3>();
  ball.covariance_F = best.P.topLeftCorner<3, 3>();
  ball.position_R = poseAt(t_s).T_F_R().inverse() * ball.position_F;
  ball.state = filter.hopsNoticeably(best) ? fw::BallState::kAir : fw::BallState::kGround;
  ball.air_probability = filter.airProbability();
  if (t_s - world->last_kinect_s <= kSourceRecent_s) ball.sources.push_back(config_.kinect.source);
  if (t_s - world->last_omni_s <= kSourceRecent_s) ball.sources.push_back(config_.omni.source);
  for (const auto& [robot_id, last_s] : world->last_teammate_s) {
    if (t_s - last_s <= kSourceRecent_s) ball.sources.push_back(teammateSource(state_.teammates.at(robot_id).name));
  }
  ball.age_s = t_s - world->last_support_s;
  ball.stamp.source_time_s = t_s;
  ball.goal_crossing = goalCrossing(filter, best, t_s, config_.field_length_m);
  return ball;
}

std::optional<fw::FusedBall> BallFusion::teammatePrior(double t_s) const {
  const TeammateWorldBall* freshest = nullptr;
  double freshest_age_s = config_.team.prior_max_age_s;
  for (const auto& [robot_id, prior] : state_.teammate_world_balls) {
    if (state_.teammates.at(robot_id).discounted) continue;
    const double age_s = prior.ball.age_s + std::abs(t_s - prior.ball.stamp.source_time_s);
    if (age_s <= freshest_age_s) {
      freshest = &prior;
      freshest_age_s = age_s;
    }
  }
  if (freshest == nullptr) return std::nullopt;
  fw::FusedBall ball = freshest->ball;
  // On along its velocity (a ball in the air falls, and stops falling at the floor).
  const double dt_s = t_s - ball.stamp.source_time_s;
  ball.position_F += dt_s * ball.velocity_F;
  if (ball.state == fw::BallState::kAir) {
    ball.position_F.z() -= 0.5 * fw::kGravity_mps2 * dt_s * dt_s;
    ball.velocity_F.z() -= fw::kGravity_mps2 * dt_s;
  }
  if (ball.position_F.z() < config_.motion.radius_m) {
    ball.position_F.z() = config_.motion.radius_m;
    ball.velocity_F.z() = 0.0;
  }
  // Its uncertainty, with the teammate's localisation error (turning grows with the distance) and
  // the drift of a ball nobody has seen for its age.
  const PoseConfig& pose = freshest->pose_error;
  const double range_m = (ball.position_F.head<2>() - freshest->teammate_xy).norm();
  const double drift_m = kUnseenDrift_mps * freshest_age_s;
  ball.covariance_F.topLeftCorner<2, 2>() +=
      (pose.sigma_xy_m * pose.sigma_xy_m + std::pow(range_m * pose.sigma_theta_rad, 2) + drift_m * drift_m) *
      Eigen::Matrix2d::Identity();
  ball.covariance_F(2, 2) += drift_m * drift_m;
  ball.position_R = poseAt(t_s).T_F_R().inverse() * ball.position_F;
  ball.sources = {teammatePriorSource(freshest->name)};
  ball.age_s = freshest_age_s;
  ball.stamp.source_time_s = t_s;
  return ball;
}

}  // namespace fusion
