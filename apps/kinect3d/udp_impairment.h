// A lossy robot network on loopback only, for the team tests and `kinect3d report team`: each link
// listens on one 127.0.0.N address and forwards what it gets to another, losing, delaying (so
// reordering) and duplicating packets at random, as Wi-Fi on a crowded field does. Counts what each
// link carried.
#pragma once

#include <arpa/inet.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

class UdpImpairment {
 public:
  struct Link {
    std::string listen;  // "127.0.0.41"
    std::string to;      // "127.0.0.31"
  };
  struct Faults {
    double loss = 0.2;
    double max_delay_s = 0.2;  // each packet waits uniformly up to this: they overtake each other
    double duplicate = 0.05;
  };
  struct Carried {
    std::uint64_t packets_in = 0, bytes_in = 0, packets_out = 0;
  };

  UdpImpairment(const std::vector<Link>& links, int port, Faults faults, unsigned seed = 29) : faults_(faults) {
    for (const Link& link : links) {
      const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
      const sockaddr_in local = endpoint(link.listen, port);
      if (fd < 0 || bind(fd, reinterpret_cast<const sockaddr*>(&local), sizeof local) != 0) {
        throw std::runtime_error("impairment: cannot listen on " + link.listen);
      }
      sockets_.push_back({fd, endpoint(link.to, port), link.listen, std::mt19937(seed + sockets_.size())});
    }
    thread_ = std::thread([this] { run(); });
  }
  ~UdpImpairment() {
    stop_ = true;
    thread_.join();
    for (const Socket& s : sockets_) close(s.fd);
  }
  UdpImpairment(const UdpImpairment&) = delete;
  UdpImpairment& operator=(const UdpImpairment&) = delete;

  // What the link listening on `listen` carried so far.
  Carried carried(const std::string& listen) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto found = carried_.find(listen);
    return found == carried_.end() ? Carried{} : found->second;
  }

 private:
  using Clock = std::chrono::steady_clock;
  struct Socket {
    int fd;
    sockaddr_in to;
    std::string listen;
    // Each link draws its faults from its own stream: the n-th packet of a link meets the same fate
    // in every run, however the two robots' packets interleave.
    std::mt19937 random;
  };
  struct Pending {
    Clock::time_point due;
    std::size_t link;
    std::vector<std::uint8_t> bytes;
  };

  static sockaddr_in endpoint(const std::string& address, int port) {
    sockaddr_in out{};
    out.sin_family = AF_INET;
    out.sin_port = htons(static_cast<std::uint16_t>(port));
    inet_pton(AF_INET, address.c_str(), &out.sin_addr);
    return out;
  }

  void run() {
    std::vector<pollfd> fds;
    for (const Socket& s : sockets_) fds.push_back({s.fd, POLLIN, 0});
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    while (!stop_) {
      poll(fds.data(), fds.size(), 2);
      for (std::size_t i = 0; i < sockets_.size(); ++i) {
        std::uint8_t buffer[65536];
        ssize_t n;
        while ((n = recv(sockets_[i].fd, buffer, sizeof buffer, MSG_DONTWAIT)) > 0) {
          {
            std::lock_guard<std::mutex> lock(mutex_);
            Carried& c = carried_[sockets_[i].listen];
            ++c.packets_in;
            c.bytes_in += static_cast<std::uint64_t>(n);
          }
          std::mt19937& random = sockets_[i].random;
          if (unit(random) < faults_.loss) continue;
          const int copies = unit(random) < faults_.duplicate ? 2 : 1;
          for (int copy = 0; copy < copies; ++copy) {
            const auto delay = std::chrono::duration<double>(faults_.max_delay_s * unit(random));
            pending_.push_back({Clock::now() + std::chrono::duration_cast<Clock::duration>(delay), i,
                                std::vector<std::uint8_t>(buffer, buffer + n)});
          }
        }
      }
      const Clock::time_point now = Clock::now();
      for (auto it = pending_.begin(); it != pending_.end();) {
        if (it->due > now) {
          ++it;
          continue;
        }
        const Socket& s = sockets_[it->link];
        sendto(s.fd, it->bytes.data(), it->bytes.size(), 0, reinterpret_cast<const sockaddr*>(&s.to), sizeof s.to);
        {
          std::lock_guard<std::mutex> lock(mutex_);
          ++carried_[s.listen].packets_out;
        }
        it = pending_.erase(it);
      }
    }
  }

  Faults faults_;
  std::vector<Socket> sockets_;
  std::vector<Pending> pending_;  // the thread's own
  mutable std::mutex mutex_;
  std::map<std::string, Carried> carried_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};
