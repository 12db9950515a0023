// The team's packets (docs/team.md): a clear header saying who sent it, the team message as msgpack
// (zstd-compressed when that is smaller) and a tag that proves it was made with the team's key
// (libsodium's crypto_auth, HMAC-SHA-512-256). Beside them what a receiver needs to trust a
// teammate: a window that refuses a packet seen before, and the offset between the two robots' clocks.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <utility>
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

// The offset of a teammate's clock from this robot's, from the times its packets carry. A message it
// sent at t3 (its clock) that arrived here at t4 (this robot's) after a delay d >= 0 puts the offset
// at t3 - t4 + d: at least t3 - t4. Its echo of a message of ours, sent at t1 (ours) and arrived there
// at t2 (its), puts it at t2 - t1 - d: at most t2 - t1. Queueing only ever adds delay, so the tightest
// bounds of the last kWindow_s (each way's quickest packet) pin the offset: the estimate is their
// middle, within half their gap. NTP takes both ways from one exchange; taken apart, a quick packet
// each way is enough, where a quick exchange needs two quick packets at once.
class TeammateClock {
 public:
  static constexpr double kWindow_s = 30.0;
  // A message of the teammate's: sent at t3_s (its clock), arrived at t4_s (this robot's).
  void heard(double t3_s, double t4_s);
  // Its echo of a message of ours: sent at t1_s (this robot's clock), arrived there at t2_s (its).
  void echoed(double t1_s, double t2_s);
  // The teammate's clock minus this robot's, once there is a bound each way.
  std::optional<double> offset_s() const;
  double sigma_s() const;  // half the gap between the bounds: the offset lies within it

 private:
  struct Bound {
    double offset_s, at_s;  // at_s: when, on this robot's clock
  };
  // Adds a lower or an upper bound; those the other way that it contradicts are dropped (the clocks
  // moved against each other: a clock was set, or drifted over the window).
  void add(Bound bound, bool lower);
  // The highest lower bound and the lowest upper bound, once there is one each way.
  std::optional<std::pair<double, double>> tightest() const;
  std::deque<Bound> lower_, upper_;
  double newest_s_ = -std::numeric_limits<double>::infinity();
};

}  // namespace team
