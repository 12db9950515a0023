// The world's one ball, from the Kinect's 3D balls, the omni camera's ground balls and the robot's
// pose: tracks kept in the field frame (BallFilter), measurements associated by Mahalanobis gates,
// a track confirmed before it becomes the world's ball and dropped after a time without support,
// static floaters refused unless a flight led there, the omni's latency against the Kinect learnt
// from balls both see rolling, and measurements up to max_delay_s late put back in time order.
// Teammates' Kinect balls and omni rays are measurements too; their world balls only a weak prior,
// the world's ball while nothing else gives one.
//
// Times: every source's stamps are moved onto the Kinect's clock (the reference) by its configured
// latency, and the omni's also by the estimated one. Each source's stamps follow the time-line rule
// (framework_api/time_line.h): a frame whose time is not finite is dropped; when the reference
// clock jumps by more than track.lost_after_s (the omni camera's, while the Kinect is silent) the
// fusion starts again on its new time line (no track would survive the gap, and no filter is
// carried across it); any other frame that far from the fusion's time (its clock and the
// reference's disagree) is dropped.
// Each is counted and said once per episode, naming the source and the stamp. The same code runs
// live (plugins/fusion) and offline (`kinect3d fuse`).
#pragma once

#include <array>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "framework_api/pose_history.h"
#include "framework_api/team_message.h"
#include "framework_api/time_line.h"
#include "framework_api/types.h"
#include "fusion/ball_filter.h"
#include "fusion/bounce_learner.h"
#include "fusion/fusion_config.h"
#include "fusion/pose_blend.h"

namespace fusion {

// Whether a teammate's observations agree with what this robot's own sensors see: a teammate whose
// localisation is off (a metre, twenty degrees) puts the ball, and the robots it sees (this one
// among them), elsewhere.
struct TeammateStanding {
  std::string name;
  bool discounted = false;                 // its balls are not used while this holds
  int examples = 0;                        // its observations judged against this robot's own (the newest are kept)
  double median_mahalanobis = 0.0;         // of those
  double median_gap_m = 0.0;               // and how far they lay from where this robot sees the same
  std::optional<double> first_observed_s;  // the time of its first observation (a ball, a ray, robots seen)
  // When it was last discounted: the median gap, and its balls' median distance from it.
  double discounted_gap_m = 0.0;
  double discounted_from_m = 0.0;
};

// The world after one source frame, at that frame's (corrected) time.
struct FusionUpdate {
  double time_s = 0.0;
  std::optional<fw::FusedBall> ball;
};

// How the omni camera's latency relative to the Kinect is learnt: from what the omni reports of one
// ball that both of this robot's sensors see, against the Kinect's ball carried on to the omni's
// corrected time, in the robot frame. Both sensors are on the robot, so the pose and its error play
// no part. (While no Kinect sees the ball, the omni's bearing of a ball at rest is read against where
// it lay while the robot stood, the pose's own turn the rate: BallFusion::learnLatencyFromTurn.)
// The omni's bearing minus the Kinect's, and its distance minus the Kinect's, are each
//   residual = -rate (L - applied) [+ scale distance]
// where rate is how fast the reading changes (the ball crossing the view, flying past or rolling
// away, the robot turning, a ball's phantom running out as it rises), L the latency and applied the
// estimate that corrected that time: a line in the rate whose slope is the time. The omni's distance
// map may be a few per cent off (a mirror's scale); that error grows with the distance, as time's
// error does with a ball rolling away, so the fit takes the scale as a second unknown and only what
// the rate says beyond it counts as time. A reading that stands still says nothing of either. A
// Kinect turned on its mount adds its turn to every bearing, which this reads as time while the
// bearing turns one way (docs/calibration.md: the alignment check says so).
class LatencyEstimator {
 public:
  // More than its two unknowns; with the priors, a few examples move it only as far as they say. (10
  // left lobs kicked away from a standing robot, with fewer readings that change beyond the
  // Kinect's noise, at the configured latency: docs/fusion.md, "Latency".)
  static constexpr int kMinExamples = 3;
  // Older examples count less, by a factor e over this many (half a minute of a ball both see at 30 Hz).
  static constexpr double kMemoryExamples = 1000.0;
  // How far the omni's distance map's scale may be off before the examples say (one sigma).
  static constexpr double kDistanceScaleSigma = 0.05;

  // One example: the omni's reading minus the Kinect's at the omni's corrected time, that
  // difference's variance, the rate at which the reading changes, and the estimate that corrected
  // that time; for a distance, the distance the Kinect's ball puts it at (0 for a bearing).
  void add(double residual, double variance, double rate, double applied_s, double distance_m = 0.0);
  // The relative latency (seconds the omni's stamps are late beyond its configured latency) with its
  // standard error, once kMinExamples were seen; before the examples it was 0 +- prior_sigma_s (the
  // configured latency, as uncertain as configured), and it stays there while no reading changes.
  struct Fit {
    double latency_s, sigma_s;
  };
  std::optional<Fit> fit(double prior_sigma_s) const;
  int examples() const { return examples_; }

 private:
  int examples_ = 0;
  // The weighted (1 / variance) least squares' normal equations in (latency, distance scale error),
  // older examples discounted: information and information times the estimate, without the priors.
  Eigen::Matrix2d information_ = Eigen::Matrix2d::Zero();
  Eigen::Vector2d weighted_ = Eigen::Vector2d::Zero();
};

class BallFusion {
 public:
  explicit BallFusion(const FusionConfig& config);

  void addPose(const fw::RobotPose& pose);
  // One frame of a source: every ball it saw at one time (possibly none), stamps on its own clock.
  // Each returns the world after that frame (for a late frame, after re-processing those after it).
  const FusionUpdate& addKinectFrame(double stamp_s, const std::vector<fw::BallObservation>& balls_R);
  // The omni image's robots (teammates and opponents) are kept to judge teammates' localisation by.
  const FusionUpdate& addOmniFrame(double stamp_s, const std::vector<fw::OmniBallObservation>& balls,
                                   const std::vector<fw::OmniRobotObservation>& robots = {});
  // A teammate's Kinect balls, omni rays and the robots its omni camera saw (plugins/team; field
  // frame, times already on the reference clock), each of its frames in turn. A message without the
  // teammate's pose is not used (its localisation error cannot be added).
  const FusionUpdate& addTeamMessage(const fw::TeamMessage& message);
  // Whether fusion.team.ignore names this teammate: its observations are never used.
  bool ignores(const std::string& teammate) const;
  // Every teammate heard, by robot id.
  const std::map<int, TeammateStanding>& teammates() const { return state_.teammates; }

  const FusionUpdate& latest() const { return state_.update; }
  // The omni camera's latency relative to the Kinect with its standard error, once learnt (from
  // fusion.omni.latency_s +- timing_sigma_s and the examples); and from how many examples.
  std::optional<LatencyEstimator::Fit> omniLatency() const;
  int omniLatencyExamples() const { return state_.latency.examples(); }
  // The pose's latency relative to the Kinect (seconds its stamps are late beyond fusion.pose.latency_s)
  // with its standard error, once learnt from a ball at rest the Kinect sees while the robot turns;
  // and from how many examples.
  std::optional<LatencyEstimator::Fit> poseLatency() const;
  int poseLatencyExamples() const { return state_.pose_latency.examples(); }
  // The ball's bounce as learnt from the bounces this robot's Kinect saw (fusion.motion.learn_bounce;
  // until it has seen one, and without learning, the configured one), and from how many.
  const MotionConfig& bounce() const { return state_.bounce.motion(); }
  int bouncesLearnt() const { return state_.bounce.bounces(); }
  // Frames that arrived more than max_delay_s behind the newest and were not used.
  int lateFramesDropped() const { return late_dropped_; }
  // Frames not used because their time was not finite, or off the fusion's time line.
  int unusableFramesDropped() const { return unusable_dropped_; }
  // How often a source's clock jumped and the fusion started again.
  int timeLineRestarts() const { return restarts_; }

 private:
  enum class Source { kKinect, kOmni, kTeammate };
  // A teammate's observation beside this robot's ball.
  struct Judgement {
    double mahalanobis = 0.0;
    double gap_m = 0.0;
    double sigma_m = 0.0;          // the judgement's resolution: one sigma, in metres, in the gap's direction
    double from_teammate_m = 0.0;  // the teammate's ball from where it believes it stands
  };
  struct Candidate;
  // A Kinect's ball, this robot's or a teammate's, in this robot's frame at its time, as the omni
  // camera's latency is learnt from it.
  struct KinectSighting {
    double time_s = 0.0;
    Eigen::Vector3d p_R = Eigen::Vector3d::Zero();
    Eigen::Matrix3d covariance_R = Eigen::Matrix3d::Zero();
    std::optional<int> teammate = std::nullopt;  // whose Kinect: none for this robot's own
    double timing_sigma_s = 0.0;                 // a teammate's: the bound of the two robots' clock offset
  };
  static constexpr std::size_t kKinectSightingsKept = 10;  // a third of a second at 30 Hz
  struct Track {
    int id = 0;
    BallFilter filter;
    int updates = 0;
    double born_s = 0.0;
    double last_support_s = 0.0;
    double last_kinect_s = -1e18;
    double last_omni_s = -1e18;
    std::map<int, double> last_teammate_s = {};  // by robot id
    double last_located_s = -1e18;               // a Kinect, this robot's or a teammate's, placed it in 3D
    bool seen_on_ground = false;                 // a lamp is only ever seen in the air
    bool omni_born = false;                      // started by an omni ball: perhaps the phantom of a ball in the air
    bool colour_confirmed = false;               // the colour image confirmed one of its Kinect balls
    bool confirmed = false;
    // The same ball as this robot's own sensors alone see it (since they last found it): teammates
    // are judged against it. The track's filter will not do: a teammate's observations in it would
    // be judged against themselves, and a mislocalised one that reached this robot's ball first
    // would pass.
    std::optional<BallFilter> own_view = std::nullopt;
    // One Kinect's balls of it, the newest kKinectSightingsKept, oldest first: they time the omni
    // camera. This robot's Kinect's; a teammate's while this robot's has not seen the ball lately.
    std::array<KinectSighting, kKinectSightingsKept> kinect_sightings = {};
    std::size_t kinect_sighting_count = 0;

    // Keeps a sighting by the rule above (one Kinect at a time: two robots' clocks differ by their
    // exchange's error, and a fit across both would read that as motion).
    void keepSighting(const KinectSighting& sighting, double within_s);

    // The air mode explains more of the data than the ground mode.
    bool flying() const { return filter.airProbability() > 0.5; }
    // The track's filter or this robot's own view says the ball is in the air (its omni camera alone
    // takes a ball hopping after a lob for one on the floor, farther out).
    bool mayFly() const { return flying() || (own_view && own_view->airProbability() > 0.5); }
    // The candidate's measurement (a teammate's: of that robot) supported it at t_s; a Kinect's also
    // located it.
    void supportedBy(const Candidate& candidate, double t_s);
  };
  // A teammate's world ball (field frame, times on this robot's clock) and where that teammate stood.
  struct TeammateWorldBall {
    int robot_id = 0;
    std::string name;
    fw::FusedBall ball;
    Eigen::Vector2d teammate_xy = Eigen::Vector2d::Zero();
    PoseConfig pose_error;
  };
  // Where the world's ball lay, from one sensor's balls while the robot stood still and the ball lay
  // at rest: a turning robot's bearings of it are timed against it (the omni's while no Kinect sees
  // the ball, the pose's by the Kinect's).
  struct RestingBall {
    int track_id = 0;  // 0: none
    Eigen::Vector2d sum_xy_F = Eigen::Vector2d::Zero();
    int count = 0;
    Eigen::Vector3d mean_F(double radius_m) const { return {sum_xy_F.x() / count, sum_xy_F.y() / count, radius_m}; }
  };
  struct State {
    std::vector<Track> tracks;
    int next_id = 1;
    int world_id = 0;          // 0: no world ball
    LatencyEstimator latency;  // the omni camera's
    RestingBall resting;       // the omni's balls of it
    LatencyEstimator pose_latency;
    RestingBall kinect_resting;            // this robot's Kinect's balls of it
    BounceLearner bounce{MotionConfig{}};  // made from config_.motion by the constructor
    std::map<int, TeammateStanding> teammates;
    std::map<int, std::deque<Judgement>> judged;            // per teammate, newest last
    std::map<int, TeammateWorldBall> teammate_world_balls;  // the newest of each teammate
    // The farthest this robot's omni camera has reported a ball, any ball: its mirror reaches at
    // least that far (0 until it has reported one). A ball rolled farther is out of its view, not lost.
    double omni_reach_m = 0.0;
    FusionUpdate update;
  };
  // A teammate's ball with what places it: the teammate's pose and how far its localisation may be off.
  struct TeammateBall {
    int robot_id = 0;
    std::string name;
    fw::BallObservation ball_F;
    fw::RobotPose pose;
    PoseConfig pose_error;
    double timing_sigma_s = 0.0;  // the bound of the two robots' clock offset
  };
  // A teammate's omni ray, as an omni ball seen from the ray's origin, bearing in the field frame.
  struct TeammateRay {
    int robot_id = 0;
    std::string name;
    fw::OmniBallObservation ball;  // bearing from the field's +y, distance where the ray meets the resting plane
    fw::RobotPose viewpoint;       // at the ray's origin, facing the field's +y
    OmniConfig omni;               // its viewpoint's height and its view's top
    PoseConfig pose_error;
    double timing_sigma_s = 0.0;
  };
  // The robots a teammate's omni camera saw in one image (at time_s), and where that teammate stood.
  struct TeammateSightings {
    int robot_id = 0;
    std::string name;
    double time_s = 0.0;
    std::vector<fw::SeenRobot> robots;
    Eigen::Vector2d teammate_xy = Eigen::Vector2d::Zero();
    PoseConfig pose_error;
  };
  struct Frame {
    Source source;
    double time_s;                   // corrected onto the reference clock
    double omni_latency_s = 0;       // the estimated omni latency that correction used
    double omni_timing_sigma_s = 0;  // and how uncertain the corrected time still is
    std::vector<fw::BallObservation> kinect;
    std::vector<fw::OmniBallObservation> omni;
    std::vector<TeammateBall> team;
    std::vector<TeammateRay> team_rays;
    std::optional<TeammateWorldBall> team_world_ball;
    // Teammates' robots seen, judged with this frame, whatever their own time: they change no ball,
    // and a frame of their own, inserted late, would have every frame after it processed again.
    std::vector<TeammateSightings> team_sightings = {};
  };

  // Teaches the latency estimator from an omni ball (at corrected time t, corrected by applied_s) on
  // the world's track, against the Kinect's bearings of that track; while no Kinect sees it, by
  // learnLatencyFromTurn.
  void learnLatency(const Track& track, const Candidate& candidate, double t, double applied_s);
  // The same from the robot's own turning, while no Kinect sees the ball: the omni bearing of a
  // ball at rest lags the pose's heading by the latency (the pose's clock the reference).
  void learnLatencyFromTurn(const Track& track, const Candidate& candidate, double applied_s);
  // Teaches the pose's latency from this robot's Kinect ball (at t) on the world's track: while the
  // robot turns, a ball at rest stays where the Kinect sees it, and the pose it is mapped by, late,
  // turns it away by the pose's rate times the latency.
  void learnPoseLatency(const Track& track, const Candidate& candidate, double t);
  // The robot's pose at t on the reference clock, by its configured latency and the learnt one.
  fw::RobotPose poseAt(double t_s) const;

  // The time-line rule for a frame of source stamped stamp_s (its own clock): true to use it.
  bool onTimeLine(Source source, double stamp_s, double time_s);
  // The frames of one arrival (one frame, or a teammate's message), in time order.
  const FusionUpdate& insert(Frame frame);
  const FusionUpdate& insert(std::vector<Frame> frames);
  // One frame's measurements into the tracks; insert then takes the world's ball from them.
  void process(const Frame& frame);
  std::vector<Candidate> candidatesOf(const Frame& frame, const fw::RobotPose& pose) const;
  void startTrack(const Candidate& candidate, double t_s);
  // The hypotheses a track (or its own view) starts from with candidate.
  std::vector<Hypothesis> initialHypotheses(const Candidate& candidate) const;
  // Every teammate in frame by its observation that best matches the ball this robot's own sensors
  // support now (none: nobody is judged); this robot at pose.
  void judgeTeammates(const Frame& frame, const std::vector<Candidate>& candidates, const fw::RobotPose& pose,
                      double t_s);
  // The teammate made an observation at t_s (its standing keeps the earliest).
  void firstObserved(int teammate, double t_s);
  // A teammate by the robots its omni camera saw: do they stand where this robot stands, where the
  // teammates not discounted believe they stand, and where its own omni camera sees robots?
  void judgeTeammateBySight(const TeammateSightings& sightings);
  // How far a teammate's ball or ray lies from this robot's ball (own's own view, its branches at
  // t_s), when this robot's own sensors support that ball well enough to judge by.
  std::optional<Judgement> judge(const Candidate& candidate, const Track& own,
                                 const std::vector<Hypothesis>& own_branches, const fw::RobotPose& pose,
                                 double t_s) const;
  // This robot's omni camera, of its own, places own's ball on the floor well enough to judge by:
  // it supported it just now, near enough that its distance error is small.
  bool omniPlaces(const Track& own, const fw::RobotPose& pose, double t_s) const;
  // This robot's own sensors place own's ball: its Kinect supported it just now, or omniPlaces.
  bool ownPlaces(const Track& own, const fw::RobotPose& pose, double t_s) const;
  // The teammate's standing after one more such judgement.
  void recordJudgement(int teammate, const Judgement& judgement);
  const std::string& nameOf(Source source) const;  // this robot's own sources
  void maintainTracks(double t_s);
  // Whether a Kinect has located the track's ball, it was last seen near the omni camera's reach, and
  // it lies farther from the robot at t_s than that camera has reported a ball.
  bool beyondOmniReach(const Track& track, double t_s) const;
  std::optional<fw::FusedBall> worldBall(double t_s) const;
  // Without a world ball of its own: the freshest world ball of a teammate that is not discounted,
  // carried on to t_s with its uncertainty grown (none older than team.prior_max_age_s).
  std::optional<fw::FusedBall> teammatePrior(double t_s) const;

  FusionConfig config_;
  PoseBlend pose_blend_;
  fw::PoseHistory poses_;  // blended (pose_blend_), on the reference clock
  // The robots this robot's omni camera saw in the last second, field frame, oldest first.
  std::deque<fw::SeenRobot> seen_robots_;
  // Teammates' robots seen since this robot's last own frame, which takes them (at most
  // kPendingSightings, the newest).
  std::vector<TeammateSightings> pending_sightings_;
  // Where each teammate (not ignored) believes it stands, by robot id, and how far that may be off.
  struct TeammatePoses {
    fw::PoseHistory poses;
    double newest_s = 0.0;
    PoseConfig error;
  };
  std::map<int, TeammatePoses> teammate_poses_;
  State state_;
  // Frames of the last max_delay_s with the state before each, to re-process after a late one.
  std::deque<std::pair<Frame, State>> recent_;
  fw::TimeLine kinect_time_line_, omni_time_line_;  // each source's own stamps
  bool reported_off_time_line_ = false;             // said once per episode
  bool teammates_heard_ = false;                    // a teammate's message came: frames are kept longer
  int late_dropped_ = 0;
  int unusable_dropped_ = 0;
  int restarts_ = 0;
};

}  // namespace fusion
