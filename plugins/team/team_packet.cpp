#include "team_packet.h"

#include <sodium.h>
#include <zstd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace team {

namespace {

// Header: "K3T", version, team id, robot id, flags, sequence (8 bytes, little-endian).
constexpr char kMagic[3] = {'K', '3', 'T'};
constexpr std::size_t kHeaderBytes = 15;
constexpr std::size_t kTagBytes = crypto_auth_BYTES;
constexpr std::uint8_t kCompressed = 1;  // flags: the body is a zstd frame
constexpr int kZstdLevel = 3;

static_assert(TeamKey::kBytes == crypto_auth_KEYBYTES, "the team key is crypto_auth's key");

void initSodium() {
  // Thread-safe and idempotent; fails only when the system has no source of randomness.
  if (sodium_init() < 0) throw std::runtime_error("libsodium cannot start (no source of randomness)");
}

}  // namespace

TeamKey TeamKey::fromFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("team key file '" + path + "' cannot be read");
  std::stringstream text;
  text << in.rdbuf();
  std::string hex = text.str();
  hex.erase(std::remove_if(hex.begin(), hex.end(), [](unsigned char c) { return std::isspace(c); }), hex.end());
  return fromHex(hex, "team key file '" + path + "'");
}

TeamKey TeamKey::fromHex(const std::string& hex, const std::string& origin) {
  initSodium();
  TeamKey key;
  std::size_t length = 0;
  const char* end = nullptr;
  if (hex.size() != 2 * kBytes ||
      sodium_hex2bin(key.bytes_.data(), kBytes, hex.c_str(), hex.size(), nullptr, &length, &end) != 0 ||
      length != kBytes || end != hex.c_str() + hex.size()) {
    throw std::runtime_error(origin + ": expected " + std::to_string(2 * kBytes) +
                             " hex digits (a 32-byte key; kinect3d team-key writes one)");
  }
  return key;
}

TeamKey TeamKey::random() {
  initSodium();
  TeamKey key;
  crypto_auth_keygen(key.bytes_.data());
  return key;
}

std::string TeamKey::hex() const {
  char text[2 * kBytes + 1];
  sodium_bin2hex(text, sizeof text, bytes_.data(), kBytes);
  return text;
}

const char* toString(Refusal refusal) {
  switch (refusal) {
    case Refusal::kNone:
      return "none";
    case Refusal::kNotATeamPacket:
      return "not a team packet";
    case Refusal::kWireVersion:
      return "another wire version";
    case Refusal::kOtherTeam:
      return "another team";
    case Refusal::kForged:
      return "not signed with the team key";
    case Refusal::kMalformed:
      return "malformed";
    case Refusal::kReplayed:
      return "replayed";
    case Refusal::kOwn:
      return "own";
    case Refusal::kNoClock:
      return "clock not yet known";
  }
  return "?";
}

std::vector<std::uint8_t> sealPacket(const PacketHeader& header, const std::string& body, const TeamKey& key) {
  initSodium();
  std::vector<std::uint8_t> compressed(ZSTD_compressBound(body.size()));
  const std::size_t compressed_size =
      ZSTD_compress(compressed.data(), compressed.size(), body.data(), body.size(), kZstdLevel);
  const bool compress = !ZSTD_isError(compressed_size) && compressed_size < body.size();

  std::vector<std::uint8_t> packet{
      static_cast<std::uint8_t>(kMagic[0]),      static_cast<std::uint8_t>(kMagic[1]),
      static_cast<std::uint8_t>(kMagic[2]),      kWireVersion,
      static_cast<std::uint8_t>(header.team_id), static_cast<std::uint8_t>(header.robot_id),
      compress ? kCompressed : std::uint8_t{0}};
  for (int i = 0; i < 8; ++i) packet.push_back(static_cast<std::uint8_t>(header.sequence >> (8 * i)));
  if (compress) {
    packet.insert(packet.end(), compressed.begin(), compressed.begin() + static_cast<std::ptrdiff_t>(compressed_size));
  } else {
    packet.insert(packet.end(), body.begin(), body.end());
  }
  const std::size_t signed_bytes = packet.size();
  packet.resize(signed_bytes + kTagBytes);
  crypto_auth(packet.data() + signed_bytes, packet.data(), signed_bytes, key.data());
  return packet;
}

OpenedPacket openPacket(const std::uint8_t* data, std::size_t size, const TeamKey& key, int team_id) {
  initSodium();
  OpenedPacket opened;
  if (size < kHeaderBytes + kTagBytes || !std::equal(kMagic, kMagic + 3, data)) {
    opened.refusal = Refusal::kNotATeamPacket;
    opened.detail = std::to_string(size) + " bytes without the team packet's header";
    return opened;
  }
  if (data[3] != kWireVersion) {
    opened.refusal = Refusal::kWireVersion;
    opened.detail = "wire version " + std::to_string(data[3]) + ", this build reads " + std::to_string(kWireVersion);
    return opened;
  }
  opened.header.team_id = data[4];
  opened.header.robot_id = data[5];
  for (int i = 0; i < 8; ++i) opened.header.sequence |= static_cast<std::uint64_t>(data[7 + i]) << (8 * i);
  if (opened.header.team_id != team_id) {
    opened.refusal = Refusal::kOtherTeam;
    opened.detail = "team " + std::to_string(opened.header.team_id);
    return opened;
  }
  const std::size_t signed_bytes = size - kTagBytes;
  if (crypto_auth_verify(data + signed_bytes, data, signed_bytes, key.data()) != 0) {
    opened.refusal = Refusal::kForged;
    opened.detail = "robot " + std::to_string(opened.header.robot_id) + "'s tag does not match the team key";
    return opened;
  }
  const std::uint8_t* body = data + kHeaderBytes;
  const std::size_t body_size = signed_bytes - kHeaderBytes;
  if ((data[6] & kCompressed) == 0) {
    opened.body.assign(reinterpret_cast<const char*>(body), body_size);
  } else {
    opened.body.resize(kMaxBodyBytes);
    const std::size_t n = ZSTD_decompress(opened.body.data(), opened.body.size(), body, body_size);
    if (ZSTD_isError(n)) {
      opened.refusal = Refusal::kMalformed;
      opened.detail = std::string("its body does not decompress (") + ZSTD_getErrorName(n) + ")";
      opened.body.clear();
      return opened;
    }
    opened.body.resize(n);
  }
  return opened;
}

bool ReplayWindow::accept(int robot_id, std::uint64_t sequence) {
  const auto found = seen_.find(robot_id);
  if (found == seen_.end()) {
    seen_[robot_id] = {sequence, 0};
    return true;
  }
  Seen& seen = found->second;
  if (sequence > seen.newest) {
    const std::uint64_t shift = sequence - seen.newest;
    // The old newest becomes bit shift - 1; everything shifts out beyond the window.
    seen.below = shift >= kWindow ? 0 : ((seen.below << shift) | (std::uint64_t{1} << (shift - 1)));
    if (shift == kWindow) seen.below = std::uint64_t{1} << (kWindow - 1);
    seen.newest = sequence;
    return true;
  }
  const std::uint64_t back = seen.newest - sequence;  // 0: the newest itself
  if (back == 0 || back > kWindow) return false;
  const std::uint64_t bit = std::uint64_t{1} << (back - 1);
  if (seen.below & bit) return false;
  seen.below |= bit;
  return true;
}

void TeammateClock::heard(double t3_s, double t4_s) { add({t3_s - t4_s, t4_s}, true); }

void TeammateClock::echoed(double t1_s, double t2_s) { add({t2_s - t1_s, t1_s}, false); }

void TeammateClock::add(Bound bound, bool lower) {
  if (!std::isfinite(bound.offset_s) || !std::isfinite(bound.at_s)) return;
  std::deque<Bound>& same = lower ? lower_ : upper_;
  std::deque<Bound>& other = lower ? upper_ : lower_;
  const auto contradicted = [&](const Bound& b) {
    return lower ? b.offset_s < bound.offset_s : b.offset_s > bound.offset_s;
  };
  other.erase(std::remove_if(other.begin(), other.end(), contradicted), other.end());
  same.push_back(bound);
  newest_s_ = std::max(newest_s_, bound.at_s);
  for (std::deque<Bound>* way : {&lower_, &upper_}) {
    while (way->size() > 1 && way->front().at_s < newest_s_ - kWindow_s) way->pop_front();  // each keeps its newest
  }
}

std::optional<std::pair<double, double>> TeammateClock::tightest() const {
  if (lower_.empty() || upper_.empty()) return std::nullopt;
  const auto byOffset = [](const Bound& a, const Bound& b) { return a.offset_s < b.offset_s; };
  return std::make_pair(std::max_element(lower_.begin(), lower_.end(), byOffset)->offset_s,
                        std::min_element(upper_.begin(), upper_.end(), byOffset)->offset_s);
}

std::optional<double> TeammateClock::offset_s() const {
  if (const auto bounds = tightest()) return (bounds->first + bounds->second) / 2.0;
  return std::nullopt;
}

double TeammateClock::sigma_s() const {
  const auto bounds = tightest();
  return bounds ? (bounds->second - bounds->first) / 2.0 : 0.0;
}

}  // namespace team
