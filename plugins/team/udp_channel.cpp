#include "udp_channel.h"

#include <arpa/inet.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <stdexcept>

namespace team {

namespace {

in_addr parseAddress(const std::string& address, const std::string& what) {
  in_addr parsed{};
  if (inet_pton(AF_INET, address.c_str(), &parsed) != 1) {
    throw std::runtime_error(what + " '" + address + "' is not an IPv4 address");
  }
  return parsed;
}

sockaddr_in endpoint(const std::string& address, int port, const std::string& what) {
  sockaddr_in out{};
  out.sin_family = AF_INET;
  out.sin_port = htons(static_cast<std::uint16_t>(port));
  out.sin_addr = parseAddress(address, what);
  return out;
}

// "address" or "address:port".
sockaddr_in peerEndpoint(const std::string& peer, int default_port) {
  const std::size_t colon = peer.find(':');
  if (colon == std::string::npos) return endpoint(peer, default_port, "team peer");
  const std::string port_text = peer.substr(colon + 1);
  char* end = nullptr;
  const long port = std::strtol(port_text.c_str(), &end, 10);
  if (port_text.empty() || *end != '\0' || port < 1 || port > 65535) {
    throw std::runtime_error("team peer '" + peer + "': expected address or address:port (1-65535)");
  }
  return endpoint(peer.substr(0, colon), static_cast<int>(port), "team peer");
}

[[noreturn]] void systemFailure(const std::string& what) {
  throw std::runtime_error(what + ": " + std::strerror(errno));
}

}  // namespace

UdpChannel::UdpChannel(const UdpSettings& settings) {
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) systemFailure("team socket");
  try {
    const int on = 1;
    // Several processes of one machine may share the port (robots simulated side by side, a replay).
    setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
    if (setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) != 0) systemFailure("team socket: timestamps");
    const bool multicast = !settings.multicast_group.empty();
    // A multicast receiver binds the group's port on every address; a unicast one its own address.
    const sockaddr_in local =
        endpoint(multicast ? "0.0.0.0" : settings.bind_address, settings.port, "team bind_address");
    if (bind(fd_, reinterpret_cast<const sockaddr*>(&local), sizeof local) != 0) {
      systemFailure("team socket: binding " + (multicast ? std::string("0.0.0.0") : settings.bind_address) + ":" +
                    std::to_string(settings.port));
    }
    if (multicast) {
      ip_mreq membership{};
      membership.imr_multiaddr = parseAddress(settings.multicast_group, "team multicast_group");
      membership.imr_interface = settings.interface_address.empty()
                                     ? in_addr{htonl(INADDR_ANY)}
                                     : parseAddress(settings.interface_address, "team interface");
      if (setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &membership, sizeof membership) != 0) {
        systemFailure("team socket: joining " + settings.multicast_group);
      }
      if (!settings.interface_address.empty() && setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_IF, &membership.imr_interface,
                                                            sizeof membership.imr_interface) != 0) {
        systemFailure("team socket: sending from " + settings.interface_address);
      }
      const unsigned char ttl = 1;  // the robot network, never beyond its router
      setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
      destinations_.push_back(endpoint(settings.multicast_group, settings.port, "team multicast_group"));
    } else {
      for (const std::string& peer : settings.peers) destinations_.push_back(peerEndpoint(peer, settings.port));
    }
  } catch (...) {
    close(fd_);
    throw;
  }
}

UdpChannel::~UdpChannel() {
  if (fd_ >= 0) close(fd_);
}

bool UdpChannel::send(const std::vector<std::uint8_t>& packet) {
  bool all_sent = true;
  for (const sockaddr_in& to : destinations_) {
    const ssize_t sent = sendto(fd_, packet.data(), packet.size(), MSG_DONTWAIT | MSG_NOSIGNAL,
                                reinterpret_cast<const sockaddr*>(&to), sizeof to);
    all_sent = all_sent && sent == static_cast<ssize_t>(packet.size());
  }
  return all_sent;
}

std::optional<Datagram> UdpChannel::receive() {
  std::uint8_t buffer[65536];
  sockaddr_in from{};
  iovec data{buffer, sizeof buffer};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
  msghdr message{};
  message.msg_name = &from;
  message.msg_namelen = sizeof from;
  message.msg_iov = &data;
  message.msg_iovlen = 1;
  message.msg_control = control;
  message.msg_controllen = sizeof control;
  const ssize_t n = recvmsg(fd_, &message, MSG_DONTWAIT);
  if (n < 0) return std::nullopt;  // nothing waiting (or a transient error: the next step reads again)
  Datagram datagram{{buffer, buffer + n}, "", 0.0};
  for (cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr; c = CMSG_NXTHDR(&message, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
      timespec arrival{};
      std::memcpy(&arrival, CMSG_DATA(c), sizeof arrival);
      datagram.arrival_time_s = static_cast<double>(arrival.tv_sec) + 1e-9 * static_cast<double>(arrival.tv_nsec);
    }
  }
  char address[INET_ADDRSTRLEN] = "?";
  inet_ntop(AF_INET, &from.sin_addr, address, sizeof address);
  datagram.from = std::string(address) + ":" + std::to_string(ntohs(from.sin_port));
  return datagram;
}

}  // namespace team
