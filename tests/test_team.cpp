// The team's wire: the message body (msgpack), the packet (header, zstd, the team key's tag), the
// window that refuses replayed packets and the clock exchange between two robots.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

#define MSGPACK_NO_BOOST
#include <msgpack.hpp>

#include "framework_api/team_message.h"
#include "scoped_temp_dir.h"
#include "team_packet.h"

namespace {

fw::TeamMessage fullMessage() {
  fw::TeamMessage m;
  m.robot_name = "goalkeeper";
  m.sent_time_s = 1700000000.25;
  m.pose = fw::RobotPose{1.5, -3.25, 0.4, {1700000000.2, 0.0}, std::nullopt};
  m.pose_sigma_xy_m = 0.03;
  m.pose_sigma_theta_rad = 0.0175;
  fw::BallObservation ball;
  ball.frame = fw::Frame::kField;
  ball.position_m = {0.5, 2.0, 1.1};
  ball.covariance_m2 << 0.01, 0.002, 0.001, 0.002, 0.02, 0.003, 0.001, 0.003, 0.03;
  ball.state = fw::BallState::kAir;
  ball.stamp.source_time_s = 1700000000.21;
  ball.support_points = 140;
  ball.colour = fw::ColourVerdict::kConfirmed;
  m.kinect_balls = {ball, ball};
  m.kinect_balls[1].is_static = true;
  m.kinect_balls[1].state = fw::BallState::kGround;
  fw::BallRay ray;
  ray.origin_F = {1.5, -3.25, 0.75};
  ray.direction_F = Eigen::Vector3d(0.3, 0.9, -0.2).normalized();
  ray.bearing_sigma_rad = 0.026;
  ray.elevation_sigma_rad = 0.01;
  ray.view_top_m = 0.6;
  ray.time_s = 1700000000.22;
  m.omni_rays = {ray};
  fw::SeenRobot robot;
  robot.position_F = {-1.0, 2.5};
  robot.covariance_m2 << 0.04, 0.005, 0.005, 0.002;
  robot.time_s = 1700000000.22;
  m.robots_seen = {robot};
  fw::FusedBall world;
  world.position_F = {0.6, 2.1, 1.0};
  world.velocity_F = {0.5, 4.0, 2.0};
  world.covariance_F = Eigen::Matrix3d::Identity() * 0.004;
  world.state = fw::BallState::kAir;
  world.air_probability = 0.97;
  world.age_s = 0.03;
  world.sources = {"kinect3d", "omni"};
  world.stamp.source_time_s = 1700000000.23;
  world.goal_crossing = fw::GoalCrossing{-1, 0.4, 0.8, 1700000000.9, 0.07, 0.02};
  m.world_ball = world;
  m.touchdown = fw::Touchdown{{1.0, 5.5}, 1700000001.1, 0.12};
  m.echoes = {{2, 1699999999.9, 1700000000.1}, {4, 1700000003.0, 1700000000.2}};
  return m;
}

std::vector<std::uint8_t> bytesOf(const std::string& text) { return {text.begin(), text.end()}; }

fw::TeamMessage unpack(const std::string& body) {
  return fw::unpackTeamMessage(reinterpret_cast<const std::uint8_t*>(body.data()), body.size());
}

// The message as a msgpack map with one key replaced by `value` (or removed when value is null).
std::string withKey(const std::string& key, const msgpack::object* value) {
  const std::string body = fw::packTeamMessage(fullMessage());
  const msgpack::object_handle handle = msgpack::unpack(body.data(), body.size());
  const msgpack::object_map& map = handle.get().via.map;
  msgpack::sbuffer buffer;
  msgpack::packer<msgpack::sbuffer> pk(&buffer);
  std::uint32_t kept = 0;
  for (std::uint32_t i = 0; i < map.size; ++i) kept += (map.ptr[i].key.as<std::string>() != key || value) ? 1 : 0;
  pk.pack_map(kept);
  for (std::uint32_t i = 0; i < map.size; ++i) {
    const bool replaced = map.ptr[i].key.as<std::string>() == key;
    if (replaced && !value) continue;
    pk.pack(map.ptr[i].key);
    pk.pack(replaced ? *value : map.ptr[i].val);
  }
  return std::string(buffer.data(), buffer.size());
}

std::string errorOf(const std::string& body) {
  try {
    unpack(body);
  } catch (const fw::TeamMessageError& e) {
    return e.what();
  }
  return "";
}

TEST(TeamMessage, EveryFieldSurvivesTheWire) {
  const fw::TeamMessage sent = fullMessage();
  const fw::TeamMessage got = unpack(fw::packTeamMessage(sent));
  EXPECT_EQ(got.robot_name, "goalkeeper");
  EXPECT_DOUBLE_EQ(got.sent_time_s, sent.sent_time_s);
  ASSERT_TRUE(got.pose);
  EXPECT_DOUBLE_EQ(got.pose->y_m, -3.25);
  EXPECT_DOUBLE_EQ(got.pose->stamp.source_time_s, sent.pose->stamp.source_time_s);
  EXPECT_DOUBLE_EQ(got.pose_sigma_theta_rad, 0.0175);
  ASSERT_EQ(got.kinect_balls.size(), 2u);
  EXPECT_TRUE(got.kinect_balls[0].isApprox(sent.kinect_balls[0], 1e-12));
  EXPECT_TRUE(got.kinect_balls[1].isApprox(sent.kinect_balls[1], 1e-12));
  EXPECT_EQ(got.kinect_balls[0].support_points, 140);
  EXPECT_DOUBLE_EQ(got.kinect_balls[0].stamp.source_time_s, sent.kinect_balls[0].stamp.source_time_s);
  ASSERT_EQ(got.omni_rays.size(), 1u);
  EXPECT_TRUE(got.omni_rays[0].direction_F.isApprox(sent.omni_rays[0].direction_F, 1e-12));
  EXPECT_DOUBLE_EQ(got.omni_rays[0].elevation_sigma_rad, 0.01);
  EXPECT_DOUBLE_EQ(got.omni_rays[0].view_top_m, 0.6);
  ASSERT_EQ(got.robots_seen.size(), 1u);
  EXPECT_EQ(got.robots_seen[0].position_F, sent.robots_seen[0].position_F);
  EXPECT_EQ(got.robots_seen[0].covariance_m2, sent.robots_seen[0].covariance_m2);
  EXPECT_DOUBLE_EQ(got.robots_seen[0].time_s, 1700000000.22);
  ASSERT_TRUE(got.world_ball);
  EXPECT_TRUE(got.world_ball->velocity_F.isApprox(sent.world_ball->velocity_F));
  EXPECT_TRUE(got.world_ball->covariance_F.isApprox(sent.world_ball->covariance_F));
  EXPECT_EQ(got.world_ball->sources, sent.world_ball->sources);
  EXPECT_EQ(got.world_ball->state, fw::BallState::kAir);
  ASSERT_TRUE(got.world_ball->goal_crossing);
  EXPECT_EQ(got.world_ball->goal_crossing->goal, -1);
  EXPECT_DOUBLE_EQ(got.world_ball->goal_crossing->x_m, 0.4);
  EXPECT_DOUBLE_EQ(got.world_ball->goal_crossing->z_m, 0.8);
  EXPECT_DOUBLE_EQ(got.world_ball->goal_crossing->time_s, 1700000000.9);
  EXPECT_DOUBLE_EQ(got.world_ball->goal_crossing->sigma_m, 0.07);
  EXPECT_DOUBLE_EQ(got.world_ball->goal_crossing->time_sigma_s, 0.02);
  ASSERT_TRUE(got.touchdown);
  EXPECT_TRUE(got.touchdown->point_m.isApprox(sent.touchdown->point_m));
  ASSERT_EQ(got.echoes.size(), 2u);
  EXPECT_EQ(got.echoes[1].robot_id, 4);
  EXPECT_DOUBLE_EQ(got.echoes[1].their_sent_s, 1700000003.0);
}

TEST(TeamMessage, CarriesTheMixedTeamProtocolBallForTeammatesThatReadOnlyThat) {
  const std::string body = fw::packTeamMessage(fullMessage());
  const msgpack::object_handle handle = msgpack::unpack(body.data(), body.size());
  std::map<std::string, msgpack::object> root;
  handle.get().convert(root);
  ASSERT_EQ(root.count("ball"), 1u);
  std::map<std::string, double> ball;
  root["ball"].convert(ball);
  EXPECT_DOUBLE_EQ(ball["x"], 0.6);
  EXPECT_DOUBLE_EQ(ball["z"], 1.0);
  EXPECT_DOUBLE_EQ(ball["vy"], 4.0);
  EXPECT_NEAR(ball["confidence"], 0.97, 1e-12);  // a second's fall from the last support
}

TEST(TeamMessage, AMessageWithoutPoseOrBallsIsValid) {
  fw::TeamMessage bare;
  bare.robot_name = "defender";
  const fw::TeamMessage got = unpack(fw::packTeamMessage(bare));
  EXPECT_FALSE(got.pose);
  EXPECT_FALSE(got.world_ball);
  EXPECT_TRUE(got.kinect_balls.empty());
  // A sender from before the robots were shared leaves their key out.
  const fw::TeamMessage older = unpack(withKey("robots_seen", nullptr));
  EXPECT_TRUE(older.robots_seen.empty());
  EXPECT_EQ(older.omni_rays.size(), 1u);
}

TEST(TeamMessage, ABadBodyIsRefusedNamingTheField) {
  EXPECT_NE(errorOf("\xc1 not msgpack").find("not msgpack"), std::string::npos);
  EXPECT_NE(errorOf(withKey("sent", nullptr)).find("'sent' is missing"), std::string::npos);
  msgpack::zone zone;
  const msgpack::object text(std::string("soon"), zone);
  EXPECT_NE(errorOf(withKey("sent", &text)).find("'sent': expected a number"), std::string::npos);
  const msgpack::object infinite(std::numeric_limits<double>::infinity());
  EXPECT_NE(errorOf(withKey("sent", &infinite)).find("finite"), std::string::npos);
  const msgpack::object no_list(3);
  EXPECT_NE(errorOf(withKey("kinect_balls", &no_list)).find("'kinect_balls': expected a list"), std::string::npos);
  // Errors inside a map or a list name the path to the field.
  const msgpack::object pose_without_theta(std::map<std::string, double>{{"x", 1.0}, {"y", 2.0}}, zone);
  EXPECT_NE(errorOf(withKey("pose", &pose_without_theta)).find("'pose.theta' is missing"), std::string::npos);
  const msgpack::object list_of_numbers(std::vector<int>{1}, zone);
  EXPECT_NE(errorOf(withKey("kinect_balls", &list_of_numbers)).find("'kinect_balls[0]': expected a map"),
            std::string::npos);
  fw::TeamMessage negative = fullMessage();
  negative.kinect_balls[1].covariance_m2(0, 0) = -0.01;
  EXPECT_NE(errorOf(fw::packTeamMessage(negative)).find("'kinect_balls[1].cov': expected a covariance"),
            std::string::npos);
  fw::TeamMessage backwards = fullMessage();
  backwards.robots_seen[0].covariance_m2(1, 1) = -0.002;
  EXPECT_NE(errorOf(fw::packTeamMessage(backwards)).find("'robots_seen[0].cov': expected a covariance"),
            std::string::npos);
  fw::TeamMessage far = fullMessage();
  far.world_ball->position_F.x() = 1e9;
  EXPECT_NE(errorOf(fw::packTeamMessage(far)).find("'world_ball.p': expected a vector"), std::string::npos);
  fw::TeamMessage no_goal = fullMessage();
  no_goal.world_ball->goal_crossing->goal = 0;
  EXPECT_NE(errorOf(fw::packTeamMessage(no_goal)).find("'world_ball.goal_crossing.goal': expected -1 or 1"),
            std::string::npos);
  fw::TeamMessage careless = fullMessage();
  careless.pose_sigma_xy_m = -0.03;
  EXPECT_NE(errorOf(fw::packTeamMessage(careless)).find("'pose.sigma_xy': expected a number in"), std::string::npos);
  const std::string body = fw::packTeamMessage(fullMessage());
  EXPECT_NE(errorOf(body + "x").find("bytes after its end"), std::string::npos);
  // A list that claims four billion entries in five bytes: refused before anything is allocated.
  const std::string huge_list = "\x81\xa4name\xdd\xff\xff\xff\xff";
  EXPECT_NE(errorOf(huge_list), "");
}

TEST(TeamMessage, ShiftingTimesMovesEveryTimeButTheEchoedSendersOwn) {
  fw::TeamMessage m = fullMessage();
  m.shiftTimes(-2.0);
  const fw::TeamMessage original = fullMessage();
  EXPECT_DOUBLE_EQ(m.sent_time_s, original.sent_time_s - 2.0);
  EXPECT_DOUBLE_EQ(m.pose->stamp.source_time_s, original.pose->stamp.source_time_s - 2.0);
  EXPECT_DOUBLE_EQ(m.kinect_balls[0].stamp.source_time_s, original.kinect_balls[0].stamp.source_time_s - 2.0);
  EXPECT_DOUBLE_EQ(m.omni_rays[0].time_s, original.omni_rays[0].time_s - 2.0);
  EXPECT_DOUBLE_EQ(m.robots_seen[0].time_s, original.robots_seen[0].time_s - 2.0);
  EXPECT_DOUBLE_EQ(m.world_ball->stamp.source_time_s, original.world_ball->stamp.source_time_s - 2.0);
  EXPECT_DOUBLE_EQ(m.world_ball->goal_crossing->time_s, original.world_ball->goal_crossing->time_s - 2.0);
  EXPECT_DOUBLE_EQ(m.touchdown->time_s, original.touchdown->time_s - 2.0);
  EXPECT_DOUBLE_EQ(m.echoes[0].received_s, original.echoes[0].received_s - 2.0);
  EXPECT_DOUBLE_EQ(m.echoes[0].their_sent_s, original.echoes[0].their_sent_s);
}

const team::TeamKey& teamKey() {
  static const team::TeamKey key = team::TeamKey::random();
  return key;
}

TEST(TeamPacket, ASealedPacketOpensWithTheTeamKeyAndIsCompressedWhenThatIsSmaller) {
  const std::string body = fw::packTeamMessage(fullMessage());
  const std::vector<std::uint8_t> packet = team::sealPacket({7, 3, 123456789012345ull}, body, teamKey());
  EXPECT_LT(packet.size(), body.size() + 15 + 32) << "the body compresses";
  const team::OpenedPacket opened = team::openPacket(packet.data(), packet.size(), teamKey(), 7);
  ASSERT_EQ(opened.refusal, team::Refusal::kNone) << opened.detail;
  EXPECT_EQ(opened.header.team_id, 7);
  EXPECT_EQ(opened.header.robot_id, 3);
  EXPECT_EQ(opened.header.sequence, 123456789012345ull);
  EXPECT_EQ(opened.body, body);
  // A body that does not compress is sent as it is.
  const std::vector<std::uint8_t> tiny = team::sealPacket({7, 3, 1}, "\x80", teamKey());
  EXPECT_EQ(tiny.size(), 15u + 1u + 32u);
  EXPECT_EQ(team::openPacket(tiny.data(), tiny.size(), teamKey(), 7).body, "\x80");
}

TEST(TeamPacket, PacketsFromOutsideTheTeamOrAlteredAreRefused) {
  const std::string body = fw::packTeamMessage(fullMessage());
  const std::vector<std::uint8_t> packet = team::sealPacket({7, 3, 42}, body, teamKey());
  const auto refusal = [](const std::vector<std::uint8_t>& bytes, const team::TeamKey& key, int team_id = 7) {
    return team::openPacket(bytes.data(), bytes.size(), key, team_id).refusal;
  };
  EXPECT_EQ(refusal(packet, team::TeamKey::random()), team::Refusal::kForged) << "another team's key";
  EXPECT_EQ(refusal(packet, teamKey(), 8), team::Refusal::kOtherTeam);
  for (const std::size_t at : {std::size_t{5}, std::size_t{9}, std::size_t{20}, packet.size() - 1}) {
    std::vector<std::uint8_t> altered = packet;
    altered[at] ^= 0x01;
    EXPECT_EQ(refusal(altered, teamKey()), team::Refusal::kForged) << "byte " << at << " altered";
  }
  std::vector<std::uint8_t> newer = packet;
  newer[3] = team::kWireVersion + 1;
  EXPECT_EQ(refusal(newer, teamKey()), team::Refusal::kWireVersion);
  EXPECT_EQ(refusal({packet.begin(), packet.end() - 10}, teamKey()), team::Refusal::kForged) << "cut short";
  EXPECT_EQ(refusal({packet.begin(), packet.begin() + 20}, teamKey()), team::Refusal::kNotATeamPacket);
  EXPECT_EQ(refusal(bytesOf("GET / HTTP/1.1\r\nHost: robot\r\n\r\n"), teamKey()), team::Refusal::kNotATeamPacket);
}

TEST(TeamPacket, RandomBytesNeverOpenAndNeverCrash) {
  std::mt19937 random(29);
  for (int i = 0; i < 20000; ++i) {
    std::vector<std::uint8_t> bytes(random() % 200);
    for (auto& byte : bytes) byte = static_cast<std::uint8_t>(random());
    if (i % 2 == 0 && bytes.size() >= 15) {  // half of them with a valid header
      bytes[0] = 'K', bytes[1] = '3', bytes[2] = 'T', bytes[3] = team::kWireVersion, bytes[4] = 7;
    }
    EXPECT_NE(team::openPacket(bytes.data(), bytes.size(), teamKey(), 7).refusal, team::Refusal::kNone);
  }
}

TEST(TeamKey, IsReadFromItsFileAndABadFileIsNamed) {
  const ScopedTempDir dir;
  const std::string good = (dir.path() / "team.key").string(), bad = (dir.path() / "bad.key").string();
  const team::TeamKey key = team::TeamKey::random();
  std::ofstream(good) << key.hex() << "\n";
  EXPECT_EQ(team::TeamKey::fromFile(good).hex(), key.hex());
  std::ofstream(bad) << key.hex().substr(0, 40) << "\n";
  try {
    team::TeamKey::fromFile(bad);
    FAIL() << "a 20-byte key was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("64 hex digits"), std::string::npos) << e.what();
  }
  EXPECT_THROW(team::TeamKey::fromFile((dir.path() / "missing.key").string()), std::runtime_error);
}

TEST(ReplayWindow, TakesEachSequenceOnceInAnyOrderWithinTheWindow) {
  team::ReplayWindow window;
  EXPECT_TRUE(window.accept(2, 1000));
  EXPECT_FALSE(window.accept(2, 1000)) << "the same packet again";
  EXPECT_TRUE(window.accept(2, 1003));
  EXPECT_TRUE(window.accept(2, 1001)) << "late, not seen before";
  EXPECT_FALSE(window.accept(2, 1001));
  EXPECT_TRUE(window.accept(2, 1002));
  EXPECT_TRUE(window.accept(3, 1000)) << "each robot has its own sequence";
  EXPECT_TRUE(window.accept(2, 1003 + team::ReplayWindow::kWindow));
  EXPECT_FALSE(window.accept(2, 1003)) << "the oldest of the window, seen";
  EXPECT_FALSE(window.accept(2, 1002)) << "older than the window";
  EXPECT_TRUE(window.accept(2, 1000000));  // a jump (the teammate restarted later)
  EXPECT_FALSE(window.accept(2, 1003 + team::ReplayWindow::kWindow)) << "from before the jump, beyond the window";
  EXPECT_TRUE(window.accept(2, 999999));
}

// What robot A knew of robot B's clock each time a packet from B arrived (A's clock).
struct ClockSeen {
  double t_s, truth_s;  // B's clock minus A's then
  std::optional<double> offset_s;
  double sigma_s;
};
// A and B each send every 50 ms, B's echoing the newest of A's to have reached it; each way takes
// 1-200 ms (Wi-Fi queues, so packets overtake each other) and a fifth of the packets are lost. B's
// clock reads b_minus_a(t) ahead of A's at A's time t.
std::vector<ClockSeen> exchangeClocks(double duration_s, const std::function<double(double)>& b_minus_a,
                                      unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> delay_s(0.001, 0.2), unit(0.0, 1.0);
  struct Packet {
    double sent_s, arrives_s;                       // A's clock
    std::optional<std::pair<double, double>> echo;  // B's: A's packet it echoes, as sent and arrived
  };
  std::vector<Packet> to_b, to_a;
  std::optional<Packet> newest_at_b;
  team::TeammateClock clock_of_b;  // on robot A
  std::vector<ClockSeen> seen;
  for (int step = 0; 0.05 * step < duration_s; ++step) {
    const double t = 0.05 * step;
    if (unit(random) > 0.2) to_b.push_back({t, t + delay_s(random), std::nullopt});
    for (auto it = to_b.begin(); it != to_b.end();) {
      if (it->arrives_s > t) {
        ++it;
        continue;
      }
      if (!newest_at_b || it->sent_s > newest_at_b->sent_s) newest_at_b = *it;
      it = to_b.erase(it);
    }
    const double b_sends_s = t + 0.025;
    if (unit(random) > 0.2) {
      Packet packet{b_sends_s, b_sends_s + delay_s(random), std::nullopt};
      if (newest_at_b) packet.echo = std::make_pair(newest_at_b->sent_s, newest_at_b->arrives_s);
      to_a.push_back(packet);
    }
    // What reaches A before its next step, in the order it arrives.
    std::sort(to_a.begin(), to_a.end(), [](const Packet& a, const Packet& b) { return a.arrives_s < b.arrives_s; });
    while (!to_a.empty() && to_a.front().arrives_s <= t + 0.05) {
      const Packet& packet = to_a.front();
      if (packet.echo) clock_of_b.echoed(packet.echo->first, packet.echo->second + b_minus_a(packet.echo->second));
      clock_of_b.heard(packet.sent_s + b_minus_a(packet.sent_s), packet.arrives_s);
      seen.push_back({packet.arrives_s, b_minus_a(packet.arrives_s), clock_of_b.offset_s(), clock_of_b.sigma_s()});
      to_a.erase(to_a.begin());
    }
  }
  return seen;
}

TEST(TeammateClock, LearnsAClockASecondOffThroughDelayLossAndReorderingWithinABoundThatNarrowsFast) {
  const std::vector<ClockSeen> seen = exchangeClocks(
      30.0, [](double) { return 1.0; }, 7);
  ASSERT_GT(seen.size(), 400u);
  for (const ClockSeen& s : seen) {
    if (!s.offset_s) continue;
    EXPECT_NEAR(*s.offset_s, s.truth_s, s.sigma_s + 1e-9) << "at " << s.t_s << " s: within its own bound";
  }
  ASSERT_TRUE(seen[2].offset_s) << "known from the first echo";
  // Each way's quickest packet bounds the offset, not the quickest pair: within a second (some 16
  // packets each way) a bound of tens of milliseconds, the best of a few milliseconds.
  const auto at = [&](double t_s) {
    return *std::find_if(seen.begin(), seen.end(), [&](const ClockSeen& s) { return s.t_s >= t_s; });
  };
  EXPECT_LT(at(1.0).sigma_s, 0.025);
  EXPECT_LT(seen.back().sigma_s, 0.005);
}

TEST(TeammateClock, FollowsATeammatesClockThatIsSetDuringTheMatch) {
  // B's clock is set half a second forward, or back, ten seconds in (NTP stepping it once it reaches
  // its server): the bounds from before that the new ones contradict are dropped.
  for (const double step_s : {0.5, -0.5}) {
    const std::vector<ClockSeen> seen = exchangeClocks(
        20.0, [&](double t) { return t < 10.0 ? 1.0 : 1.0 + step_s; }, 11);
    int after = 0;
    for (const ClockSeen& s : seen) {
      if (s.t_s < 11.0) continue;
      ++after;
      ASSERT_TRUE(s.offset_s);
      EXPECT_NEAR(*s.offset_s, s.truth_s, s.sigma_s + 1e-9) << step_s << " s set, at " << s.t_s << " s";
      EXPECT_LT(s.sigma_s, 0.05) << step_s << " s set, at " << s.t_s << " s";
    }
    EXPECT_GT(after, 100);
  }
}

TEST(TeammateClock, KnowsNothingBeforeABoundEachWayAndDropsWhatNewerPacketsContradict) {
  team::TeammateClock clock;
  EXPECT_FALSE(clock.offset_s());
  clock.heard(11.1, 10.2);  // sent at 11.1 on its clock, here at 10.2: its clock is at least 0.9 ahead
  EXPECT_FALSE(clock.offset_s()) << "no bound from above yet";
  clock.echoed(10.0, 11.05);  // ours sent at 10.0 reached it at 11.05: at most 1.05 ahead
  ASSERT_TRUE(clock.offset_s());
  EXPECT_NEAR(*clock.offset_s(), (0.9 + 1.05) / 2, 1e-12);
  EXPECT_NEAR(clock.sigma_s(), (1.05 - 0.9) / 2, 1e-12);
  clock.heard(12.0, 10.96);  // a quicker one: at least 1.04
  EXPECT_NEAR(*clock.offset_s(), (1.04 + 1.05) / 2, 1e-12);
  EXPECT_NEAR(clock.sigma_s(), 0.005, 1e-12);
  // Its clock was set back by a second: its packets contradict what came before, which is dropped.
  clock.echoed(12.0, 12.06);  // at most 0.06 ahead: the lower bounds of 0.9 and 1.04 go
  EXPECT_FALSE(clock.offset_s());
  clock.heard(12.1, 12.08);  // at least 0.02
  EXPECT_NEAR(*clock.offset_s(), 0.04, 1e-12);
  clock.heard(std::nan(""), 12.2);
  EXPECT_NEAR(*clock.offset_s(), 0.04, 1e-12) << "a time that is not finite bounds nothing";
}

}  // namespace
