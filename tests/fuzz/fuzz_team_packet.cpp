// What reaches a robot from the robot network: any bytes as a packet (refused unless signed with the
// team key), any bytes as the body of a packet that is signed (a teammate's bug: it must not
// decompress into gigabytes or read past its end), and any message that reads handed to the fusion
// (it must not crash it or make its ball not finite). The first byte chooses which.
#include <sodium.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "framework_api/team_message.h"
#include "fusion/ball_fusion.h"
#include "team_packet.h"

namespace {

const team::TeamKey& key() {
  static const team::TeamKey key = team::TeamKey::fromHex(std::string(64, 'a'), "the fuzzer's key");
  return key;
}

// The team packet's header, for team 7, robot 2, with the compressed flag as given.
std::vector<std::uint8_t> header(bool compressed) {
  std::vector<std::uint8_t> bytes{
      'K', '3', 'T', team::kWireVersion, 7, 2, compressed ? std::uint8_t{1} : std::uint8_t{0}};
  for (int i = 0; i < 8; ++i) bytes.push_back(static_cast<std::uint8_t>(i + 1));
  return bytes;
}

void toFusion(const fw::TeamMessage& message) {
  fusion::BallFusion fusion{fusion::FusionConfig{}};
  fw::RobotPose pose;
  pose.stamp.source_time_s = 1.7e9;
  fusion.addPose(pose);
  fusion.addOmniFrame(1.7e9, {});
  const fusion::FusionUpdate& update = fusion.addTeamMessage(message);
  if (update.ball && !update.ball->position_F.allFinite()) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::uint8_t mode = data[0] % 3;
  ++data;
  --size;
  if (mode == 0) {
    // Any bytes: the packet's own checks.
    const team::OpenedPacket opened = team::openPacket(data, size, key(), 7);
    if (opened.refusal == team::Refusal::kNone) std::abort();  // nobody without the key signs a packet
  } else if (mode == 1) {
    // Signed, its body any bytes, compressed or not.
    std::vector<std::uint8_t> packet = header(size > 0 && (data[0] & 1));
    packet.insert(packet.end(), data, data + size);
    const std::size_t signed_bytes = packet.size();
    packet.resize(signed_bytes + crypto_auth_BYTES);
    crypto_auth(packet.data() + signed_bytes, packet.data(), signed_bytes, key().data());
    const team::OpenedPacket opened = team::openPacket(packet.data(), packet.size(), key(), 7);
    if (opened.body.size() > team::kMaxBodyBytes) std::abort();
    if (opened.refusal == team::Refusal::kNone) {
      try {
        fw::unpackTeamMessage(reinterpret_cast<const std::uint8_t*>(opened.body.data()), opened.body.size());
      } catch (const fw::TeamMessageError&) {
      }
    }
  } else {
    // A body that reads, to the fusion.
    fw::TeamMessage message;
    try {
      message = fw::unpackTeamMessage(data, size);
    } catch (const fw::TeamMessageError&) {
      return 0;
    }
    message.robot_id = 2;
    toFusion(message);
  }
  return 0;
}
