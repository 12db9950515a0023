// The team's packets (docs/team.md): a clear header saying who sent it, the team message as msgpack
// (zstd-compressed when that is smaller) and a tag that proves it was made with the team's key
// (libsodium's crypto_auth, HMAC-SHA-512-256). Beside them what a receiver needs to trust a
// teammate: a window that refuses a packet seen before, and the offset between the two robots' clocks.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace team {

constexpr std::uint8_t kWireVersion = 1;
// The largest body a packet may carry once decompressed: far above a real message (a few hundred
// bytes), far below what would hurt a robot.
constexpr std::size_t kMaxBodyBytes = 64 * 1024;

// The team's shared secret: 32 bytes, kept as 64 hex digits in a key file on every robot of the
// team (`kinect3d team-key --out FILE` makes one).
class TeamKey {
 public:
  static constexpr std::size_t kBytes = 32;
  // Throws std::runtime_error naming the file and what is wrong with it.
  static TeamKey fromFile(const std::string& path);
  static TeamKey fromHex(const std::string& hex, const std::string& origin);
  static TeamKey random();
  std::string hex() const;
  const unsigned char* data() const { return bytes_.data(); }

 private:
  std::array<unsigned char, kBytes> bytes_{};
};

struct PacketHeader {
  int team_id = 0;   // 0-255
  int robot_id = 0;  // 1-255
  // Strictly increasing per robot, across restarts too: it starts at the sender's start time in
  // microseconds, so a packet recorded from an earlier run is still refused as replayed.
  std::uint64_t sequence = 0;
};

// A packet ready to send: header, body, tag.
std::vector<std::uint8_t> sealPacket(const PacketHeader& header, const std::string& body, const TeamKey& key);

// Why a received packet was not used; the receiver counts each.
enum class Refusal {
  kNone,
  kNotATeamPacket,  // too short, or not our magic bytes
  kWireVersion,     // a version this build does not read
  kOtherTeam,       // another team id
  kForged,          // the tag does not match: not made with this team's key, or altered
  kMalformed,       // signed, but its body does not decompress or does not read (a bug in the sender)
  kReplayed,        // seen before, or older than the window of recent sequence numbers
  kOwn,             // this robot's own packet (multicast loops it back)
  kNoClock,         // the clock exchange with its sender has not completed: its times cannot be used yet
};
const char* toString(Refusal refusal);

struct OpenedPacket {
  Refusal refusal = Refusal::kNone;
  PacketHeader header;
  std::string body;    // decompressed msgpack, when refusal is kNone
  std::string detail;  // what was wrong, for the log
};
// Checks the header and tag (before any decompression) and returns the body.
OpenedPacket openPacket(const std::uint8_t* data, std::size_t size, const TeamKey& key, int team_id);

// Refuses a sequence number seen before per robot: the newest seen, and which of the kWindow below
// it came (packets arrive out of order on Wi-Fi). Older than the window is refused too.
class ReplayWindow {
 public:
  static constexpr std::uint64_t kWindow = 64;
  // True (and remembered) the first time robot_id's sequence is offered.
  bool accept(int robot_id, std::uint64_t sequence);

 private:
  struct Seen {
    std::uint64_t newest = 0;
    std::uint64_t below = 0;  // bit i: newest - 1 - i was seen
  };
  std::map<int, Seen> seen_;
};

// The offset of a teammate's clock from this robot's, from the NTP exchange (ClockEcho): this robot
// sent at t1 (its clock), the teammate received it at t2 and sent its reply at t3 (its clock), the
// reply arrived at t4 (this robot's clock). Each exchange gives the offset ((t2 - t1) + (t3 - t4)) / 2
// within half its round trip (t4 - t1) - (t3 - t2); the estimate is the exchange with the shortest
// round trip of the last kWindow_s, since queueing on the network only ever adds delay.
class TeammateClock {
 public:
  static constexpr double kWindow_s = 30.0;
  void addExchange(double t1, double t2, double t3, double t4);
  // The teammate's clock minus this robot's, once an exchange completed.
  std::optional<double> offset_s() const;
  double sigma_s() const;  // half the round trip of the exchange the estimate rests on
  int exchanges() const { return static_cast<int>(samples_.size()); }

 private:
  struct Sample {
    double offset_s, round_trip_s, t4;
  };
  const Sample* best() const;  // the shortest round trip; nullptr before the first
  std::deque<Sample> samples_;
};

}  // namespace team
