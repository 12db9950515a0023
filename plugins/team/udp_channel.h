// The team's UDP socket: multicast to the team's group on the robot network (as MSL teams share), or
// unicast to a list of teammates' addresses. Never blocks: a robot sends what it has and reads what
// has arrived, once a step.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <netinet/in.h>

namespace team {

struct UdpSettings {
  int port = 0;                    // every robot of the team receives on it
  std::string bind_address;        // this robot's address to receive on; "0.0.0.0": every interface
  std::string multicast_group;     // empty: unicast to peers
  std::string interface_address;   // multicast: the robot network's interface; empty: the system's choice
  std::vector<std::string> peers;  // unicast: "address" or "address:port" of each teammate
};

struct Datagram {
  std::vector<std::uint8_t> bytes;
  std::string from;  // "address:port"
  // When the kernel received it (seconds since the Unix epoch): not when the plugin got round to
  // reading it, up to a step later, which would skew the clock exchange by the step.
  double arrival_time_s = 0.0;
};

class UdpChannel {
 public:
  // Throws std::runtime_error naming the address and the system's reason.
  explicit UdpChannel(const UdpSettings& settings);
  ~UdpChannel();
  UdpChannel(const UdpChannel&) = delete;
  UdpChannel& operator=(const UdpChannel&) = delete;

  // To the group, or to every peer; false if any send failed (a teammate's network away is normal
  // on match day: the caller counts it and goes on).
  bool send(const std::vector<std::uint8_t>& packet);
  // One datagram that has arrived, without waiting.
  std::optional<Datagram> receive();

 private:
  int fd_ = -1;
  std::vector<sockaddr_in> destinations_;
};

}  // namespace team
