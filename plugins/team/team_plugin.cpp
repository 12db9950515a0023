// team: what this robot sees of the ball, shared with its teammates, and what they share, received
// (docs/team.md). On the robot network (team.source: network) each step reads the packets that
// arrived (refusing, and counting, those from outside the team, replayed or malformed), publishes
// each teammate's message into the world state with its times moved onto this host's clock, then
// sends this robot's own message: its pose with the localisation's uncertainty, its Kinect's balls
// and its omni camera's ball rays since the last message and the robots its newest omni image
// showed (field frame), its world ball and the touchdown its Kinect predicts, and the clock
// exchange's echoes. From a match log (log:<folder>, what `kinect3d replay` sets) it hands out the
// messages the robot received, and sends nothing.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <variant>
#include <vector>

#include "framework_api/host_clock.h"
#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "framework_api/pose_history.h"
#include "fusion/fusion_config.h"
#include "fusion/measurements.h"
#include "fusion/pose_blend.h"
#include "matchlog/match_log.h"
#include "replay.h"
#include "team_packet.h"
#include "udp_channel.h"

namespace {

// A teammate's newest message is echoed while it is this recent (one gone quiet is not echoed forever).
constexpr double kEchoFor_s = 2.0;
// At most this many of each kind of observation go into one message: the newest.
constexpr std::size_t kMaxObservationsPerMessage = 8;
// Refusals are summed up in the log at most this often.
constexpr double kRefusalReportEvery_s = 10.0;

class TeamNetwork {
 public:
  explicit TeamNetwork(const fw::PluginContext& context)
      : world_(*context.world),
        name_(context.config.path()),
        fusion_(fusion::readFusionConfig(context.config.block("fusion"))),
        team_id_(context.config.getInt("team_id", 0, 255)),
        robot_id_(context.config.getInt("robot_id", 1, 255)),
        robot_name_(context.robot_config->block("host").getString("robot_name")),
        key_(readKey(context.config)),
        channel_(openChannel(context.config)),
        sequence_(static_cast<std::uint64_t>(fw::wallClockNow_s() * 1e6)),
        pose_blend_(fusion_.pose.odometry_blend_s, fusion_.pose.sigma_xy_m, fusion_.pose.sigma_theta_rad) {
    fw::logInfo(name_, "robot " + std::to_string(robot_id_) + " of team " + std::to_string(team_id_) +
                           ", sharing on port " + std::to_string(context.config.getInt("port", 1, 65535)));
  }

  fw::StepResult step() {
    const auto started = std::chrono::steady_clock::now();
    receive();
    readOwnMeasurements();
    send();
    reportRefusals();
    world_.reportProcessingTime(name_,
                                std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
    return fw::StepResult::kProcessed;
  }

 private:
  static team::TeamKey readKey(const fw::ConfigView& config) {
    const std::string path = config.getString("key_file");
    if (path.empty()) {
      throw fw::ConfigError(config.originOf("key_file") + ": " + config.path() +
                            ".key_file is empty: every robot of the team needs the team's key file "
                            "(kinect3d team-key --out FILE makes one)");
    }
    try {
      return team::TeamKey::fromFile(path);
    } catch (const std::runtime_error& e) {
      throw fw::ConfigError(config.originOf("key_file") + ": " + config.path() + ".key_file: " + e.what());
    }
  }

  static team::UdpChannel openChannel(const fw::ConfigView& config) {
    team::UdpSettings settings;
    settings.port = config.getInt("port", 1, 65535);
    settings.bind_address = config.getString("bind_address");
    settings.multicast_group = config.getString("multicast_group");
    settings.interface_address = config.getString("interface");
    settings.peers = config.getStringList("peers");
    if (settings.multicast_group.empty() && settings.peers.empty()) {
      throw fw::ConfigError(config.originOf("peers") + ": " + config.path() +
                            ".peers is empty and so is multicast_group: set one, or no teammate hears this robot");
    }
    try {
      return team::UdpChannel(settings);
    } catch (const std::runtime_error& e) {
      throw fw::ConfigError(config.path() + ": " + e.what() + " (" + config.originOf("port") + ")");
    }
  }

  void receive() {
    while (std::optional<team::Datagram> datagram = channel_.receive()) {
      const double arrived_s = datagram->arrival_time_s > 0.0 ? datagram->arrival_time_s : fw::wallClockNow_s();
      team::OpenedPacket opened = team::openPacket(datagram->bytes.data(), datagram->bytes.size(), key_, team_id_);
      if (opened.refusal == team::Refusal::kNone && opened.header.robot_id == robot_id_) {
        opened.refusal = team::Refusal::kOwn;
      }
      if (opened.refusal == team::Refusal::kNone &&
          !replay_window_.accept(opened.header.robot_id, opened.header.sequence)) {
        opened.refusal = team::Refusal::kReplayed;
        opened.detail = "robot " + std::to_string(opened.header.robot_id) + "'s sequence " +
                        std::to_string(opened.header.sequence) + " came before";
      }
      fw::TeamMessage message;
      if (opened.refusal == team::Refusal::kNone) {
        try {
          message =
              fw::unpackTeamMessage(reinterpret_cast<const std::uint8_t*>(opened.body.data()), opened.body.size());
        } catch (const fw::TeamMessageError& e) {
          opened.refusal = team::Refusal::kMalformed;
          opened.detail = e.what();
        }
      }
      if (opened.refusal != team::Refusal::kNone) {
        refuse(opened.refusal, datagram->from, opened.detail);
        continue;
      }
      message.team_id = opened.header.team_id;
      message.robot_id = opened.header.robot_id;
      message.sequence = opened.header.sequence;
      accept(std::move(message), arrived_s);
    }
  }

  // A teammate's message: its send time and its echo of ours bound the offset between the clocks;
  // once there is a bound each way, its times are moved onto the clock this robot's fusion works on
  // (its Kinect's, else its omni camera's) and it is published. Moved here, once, so that a replay of
  // the log hands the fusion exactly what it had.
  void accept(fw::TeamMessage message, double received_s) {
    Teammate& mate = teammates_[message.robot_id];
    mate.last_sent_s = message.sent_time_s;
    mate.last_received_s = received_s;
    for (const fw::ClockEcho& echo : message.echoes) {
      if (echo.robot_id == robot_id_) mate.clock.echoed(echo.their_sent_s, echo.received_s);
    }
    mate.clock.heard(message.sent_time_s, received_s);
    const std::optional<double> offset_s = mate.clock.offset_s();
    if (!offset_s) {
      refuse(team::Refusal::kNoClock, message.robot_name, "the clock exchange has not completed");
      return;
    }
    const fw::HostClockOf* fusion_clock = fusionClock();
    if (fusion_clock == nullptr) {
      refuse(team::Refusal::kNoClock, message.robot_name, "this robot's own sensors have not spoken yet");
      return;
    }
    if (!mate.announced_offset_s || std::abs(*offset_s - *mate.announced_offset_s) > kOffsetChangeWorthSaying_s) {
      announce(message, *offset_s, mate.clock.sigma_s(), mate.announced_offset_s.has_value());
      mate.announced_offset_s = *offset_s;
    }
    const double shift_s = *offset_s + fusion_clock->hostMinusSource_s();
    message.shiftTimes(-shift_s);
    message.clock_offset_s = shift_s;
    message.clock_offset_sigma_s = mate.clock.sigma_s();
    message.receive_time_s = received_s;
    world_.publishTeamMessage(message);
  }
  static constexpr double kOffsetChangeWorthSaying_s = 0.05;

  void announce(const fw::TeamMessage& message, double offset_s, double sigma_s, bool again) {
    char text[200];
    std::snprintf(text, sizeof text, "%s robot %d (%s): its clock is %+.3f s from ours (+-%.3f s), corrected",
                  again ? "the clock of" : "hearing", message.robot_id, message.robot_name.c_str(), offset_s, sigma_s);
    fw::logInfo(name_, text);
    world_.publishEvent({name_, "teammate_clock", text, stampNow()});
  }

  // The clock this robot's fusion works on: its Kinect's, else its omni camera's; none before either spoke.
  const fw::HostClockOf* fusionClock() const {
    return kinect_clock_.known() ? &kinect_clock_ : (omni_clock_.known() ? &omni_clock_ : nullptr);
  }
  // Now, on the fusion's clock where there is one (so the log shows an event beside the balls).
  fw::Stamp stampNow() const {
    const double now_s = fw::wallClockNow_s();
    const fw::HostClockOf* clock = fusionClock();
    return {clock != nullptr ? clock->toSource(now_s) : now_s, now_s};
  }

  // Counted per reason; said once per reason and sender, and summed up every kRefusalReportEvery_s.
  void refuse(team::Refusal reason, const std::string& from, const std::string& detail) {
    ++refused_[reason];
    if (reason == team::Refusal::kOwn) return;  // multicast hands every robot its own packets
    if (reason != team::Refusal::kNoClock) world_.reportDroppedFrames(name_, ++dropped_);
    if (!said_.insert({reason, from}).second) return;
    const std::string message = std::string("refused a packet from ") + from + ": " + team::toString(reason) +
                                (detail.empty() ? "" : " (" + detail + ")") + "; further ones are counted";
    if (reason == team::Refusal::kNoClock) {
      fw::logInfo(name_, "waiting to use " + from + "'s messages: " + detail);
      return;
    }
    fw::logWarn(name_, message);
    world_.publishEvent({name_, "team_refused", message, stampNow()});
  }

  void reportRefusals() {
    const double now_s = fw::wallClockNow_s();
    if (now_s - last_refusal_report_s_ < kRefusalReportEvery_s || dropped_ == reported_dropped_) return;
    last_refusal_report_s_ = now_s;
    reported_dropped_ = dropped_;
    std::string counts;
    for (const auto& [reason, count] : refused_) {
      if (reason == team::Refusal::kOwn) continue;
      counts += (counts.empty() ? "" : ", ") + std::to_string(count) + " " + team::toString(reason);
    }
    fw::logWarn(name_, "packets refused since start: " + counts);
  }

  // This robot's own measurements since the last step (the fusion's inputs, in their order): each
  // Kinect ball and omni ray placed in the field with the pose at its time. Times are the fusion's:
  // each source's stamps less its configured latency (fusion.<source>.latency_s) and what the fusion
  // has learnt beyond it (fw::LearntLatencies), so that a teammate places what this robot saw where
  // the robot stood when it saw it.
  void readOwnMeasurements() {
    learnt_ = world_.learntLatencies();
    for (const fw::WorldState::Measurement& measurement : world_.measurementsSince(&cursor_)) {
      if (const auto* pose = std::get_if<fw::RobotPose>(&measurement)) {
        fw::RobotPose blended = pose_blend_.add(*pose);
        blended.stamp.source_time_s -= fusion_.pose.latency_s;
        poses_.add(blended);
        pose_clock_.add(pose->stamp);
        newest_pose_ = blended;
      } else if (const auto* frame = std::get_if<fw::BallFrame>(&measurement)) {
        if (frame->source != fusion_.kinect.source) continue;
        kinect_clock_.add(frame->stamp);
        for (const fw::BallObservation& ball : frame->balls) {
          if (ball.followed()) kinect_balls_.push_back(toField(ball));
        }
      } else if (const auto* omni = std::get_if<fw::OmniFrame>(&measurement)) {
        if (omni->source != fusion_.omni.source) continue;
        omni_clock_.add(omni->stamp);
        for (const fw::OmniBallObservation& ball : omni->balls) omni_rays_.push_back(rayOf(ball, omni->stamp));
        // The robots of its newest image only: teammates judge this robot's localisation by them.
        const double seen_s = omniSeen_s(omni->stamp.source_time_s);
        robots_seen_.clear();
        for (const fw::OmniRobotObservation& robot : omni->robots) {
          robots_seen_.push_back(fusion::seenRobot_F(robot, poseAt(seen_s), fusion_.omni, omni_clock_.toHost(seen_s)));
        }
      }
    }
    keepNewest(kinect_balls_);
    keepNewest(omni_rays_);
  }

  template <typename T>
  static void keepNewest(std::vector<T>& items) {
    if (items.size() > kMaxObservationsPerMessage) items.erase(items.begin(), items.end() - kMaxObservationsPerMessage);
  }

  // When the omni camera took the image stamped stamp_s, on its own clock, and the robot's pose at
  // t_s, by the fusion's conventions and what it learnt.
  double omniSeen_s(double stamp_s) const {
    return fusion::omniSeen_s(stamp_s, fusion_.omni, learnt_.omni_s.value_or(0.0));
  }
  fw::RobotPose poseAt(double t_s) const {
    return poses_.at(fusion::poseStampFor_s(t_s, learnt_.pose_s.value_or(0.0)));
  }

  fw::BallObservation toField(const fw::BallObservation& ball_R) const {
    const double seen_s = ball_R.stamp.source_time_s - fusion_.kinect.latency_s;
    fw::BallObservation ball = fusion::kinectBall_F(ball_R, poseAt(seen_s));
    ball.stamp.source_time_s = kinect_clock_.toHost(seen_s);
    return ball;
  }

  // The omni camera's ray through a ball it reports, placed with the pose at the image's time.
  fw::BallRay rayOf(const fw::OmniBallObservation& ball, const fw::Stamp& stamp) const {
    const double seen_s = omniSeen_s(stamp.source_time_s);
    return fusion::omniRay_F(ball, poseAt(seen_s), fusion_.omni, fusion_.motion.radius_m, omni_clock_.toHost(seen_s));
  }

  void send() {
    const double now_s = fw::wallClockNow_s();
    fw::TeamMessage message;
    message.team_id = team_id_;
    message.robot_id = robot_id_;
    message.sequence = ++sequence_;
    message.robot_name = robot_name_;
    message.sent_time_s = now_s;
    if (newest_pose_ && pose_clock_.known()) {
      message.pose = *newest_pose_;
      message.pose->stamp.source_time_s =
          pose_clock_.toHost(newest_pose_->stamp.source_time_s - learnt_.pose_s.value_or(0.0));
      message.pose_sigma_xy_m = fusion_.pose.sigma_xy_m;
      message.pose_sigma_theta_rad = fusion_.pose.sigma_theta_rad;
    }
    message.kinect_balls.swap(kinect_balls_);
    message.omni_rays.swap(omni_rays_);
    message.robots_seen.swap(robots_seen_);
    // The world ball and its goal-line crossing are on the fusion's clock (the Kinect's, else the omni
    // camera's), the touchdown on the Kinect's.
    if (std::optional<fw::FusedBall> ball = world_.fusedBall(); ball && fusionClock() != nullptr) {
      ball->stamp.source_time_s = fusionClock()->toHost(ball->stamp.source_time_s);
      if (ball->goal_crossing) ball->goal_crossing->time_s = fusionClock()->toHost(ball->goal_crossing->time_s);
      message.world_ball = ball;
    }
    if (kinect_clock_.known()) {
      if (const std::optional<fw::BallTrajectory> flight = world_.trajectory(fusion_.kinect.source);
          flight && flight->touchdown) {
        const double latency_s = fusion_.kinect.latency_s;
        const fw::RobotPose pose = poseAt(flight->time_s - latency_s);
        const Eigen::Vector3d point_F =
            pose.fieldFromRobot({flight->touchdown->point_m.x(), flight->touchdown->point_m.y(), 0.0});
        message.touchdown = fw::Touchdown{
            point_F.head<2>(), kinect_clock_.toHost(flight->touchdown->time_s - latency_s), flight->touchdown->sigma_m};
      }
    }
    for (const auto& [robot_id, mate] : teammates_) {
      if (now_s - mate.last_received_s <= kEchoFor_s) {
        message.echoes.push_back({robot_id, mate.last_sent_s, mate.last_received_s});
      }
    }
    const std::vector<std::uint8_t> packet =
        team::sealPacket({team_id_, robot_id_, message.sequence}, fw::packTeamMessage(message), key_);
    if (!channel_.send(packet) && !send_failure_said_) {
      send_failure_said_ = true;
      fw::logWarn(name_, "a team packet could not be sent to every teammate (network down?); sending goes on");
    }
  }

  struct Teammate {
    team::TeammateClock clock;
    double last_sent_s = 0.0;                  // its newest message's send time (its clock)
    double last_received_s = -1e18;            // and when it came (ours)
    std::optional<double> announced_offset_s;  // the offset last said in the log
  };

  fw::WorldState& world_;
  const std::string name_;
  const fusion::FusionConfig
      fusion_;  // the sources' names and known latencies, the localisation's and omni camera's uncertainty
  const int team_id_;
  const int robot_id_;
  const std::string robot_name_;
  const team::TeamKey key_;
  team::UdpChannel channel_;
  std::uint64_t sequence_;
  team::ReplayWindow replay_window_;
  std::map<int, Teammate> teammates_;

  std::uint64_t cursor_ = 0;      // what was read of the measurements (fw::WorldState)
  fusion::PoseBlend pose_blend_;  // the pose mapped with and sent is the one the fusion maps with
  fw::PoseHistory poses_;
  fw::LearntLatencies learnt_;  // the fusion's, as last read
  std::optional<fw::RobotPose> newest_pose_;
  fw::HostClockOf pose_clock_, kinect_clock_, omni_clock_;
  std::vector<fw::BallObservation> kinect_balls_;  // since the last message, field frame, host clock
  std::vector<fw::BallRay> omni_rays_;
  std::vector<fw::SeenRobot> robots_seen_;

  std::map<team::Refusal, std::uint64_t> refused_;
  std::set<std::pair<team::Refusal, std::string>> said_;
  std::uint64_t dropped_ = 0, reported_dropped_ = 0;
  double last_refusal_report_s_ = fw::wallClockNow_s();
  bool send_failure_said_ = false;
};

// The teammates' messages a match log recorded, handed out at the pace they came.
class RecordedTeammates {
 public:
  RecordedTeammates(const fw::PluginContext& context, const std::string& folder)
      : world_(*context.world),
        player_(context.config.path(), readMessages(context.config, folder),
                fw::ReplayClock(context.config.getBool("realtime"), &context.world->replayPace()),
                [](const fw::TeamMessage& message) { return message.receive_time_s; }) {
    fw::logInfo(context.config.path(), "playing " + std::to_string(player_.size()) + " teammates' messages from " +
                                           folder + "; sending nothing");
  }

  fw::StepResult step() {
    if (player_.finished()) return fw::StepResult::kEndOfStream;
    const std::optional<fw::TeamMessage> message = player_.next();
    if (!message) return fw::StepResult::kIdle;
    world_.publishTeamMessage(*message);
    return fw::StepResult::kProcessed;
  }

 private:
  static std::vector<fw::TeamMessage> readMessages(const fw::ConfigView& config, const std::string& folder) {
    try {
      std::vector<fw::TeamMessage> messages;
      for (const fw::JournalEntry& entry : fw::MatchLogReader(folder).entries()) {
        if (const auto* message = std::get_if<fw::TeamMessage>(&entry.item)) messages.push_back(*message);
      }
      return messages;
    } catch (const std::runtime_error& e) {
      throw fw::ConfigError(config.originOf("source") + ": " + config.path() + ".source: " + e.what());
    }
  }

  fw::WorldState& world_;
  replay::Player<fw::TeamMessage> player_;
};

class TeamPlugin : public fw::Plugin {
 public:
  explicit TeamPlugin(const fw::PluginContext& context) {
    const std::string source = context.config.getString("source");
    if (source == "network") {
      network_.emplace(context);
    } else if (source.rfind("log:", 0) == 0) {
      recorded_.emplace(context, source.substr(4));
    } else {
      throw fw::ConfigError(context.config.originOf("source") + ": " + context.config.path() + ".source = '" + source +
                            "': expected network or log:<folder>");
    }
  }

  fw::StepResult step() override { return network_ ? network_->step() : recorded_->step(); }

 private:
  std::optional<TeamNetwork> network_;
  std::optional<RecordedTeammates> recorded_;
};

}  // namespace

FW_REGISTER_PLUGIN(TeamPlugin, "team", "0.1.0")
