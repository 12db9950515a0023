// `kinect3d view`'s web server (cpp-httplib): the viewer's page, the packaged JavaScript it uses
// (three.js, its orbit controls, Chart.js) and the view's data, on a fixed set of read-only routes.
// Nothing is served by file name: whatever a request path says, no file is reachable but these.
//
// It has no authentication, so it listens on this machine only unless told otherwise (--bind).
// Requests are served by kWorkers threads at a lower scheduling priority than the robot's (nice
// +10: in live mode the page never takes a core from the plugins), a client silent for
// kReadTimeout_s in the middle of a request is dropped, and a connection serves at most
// kRequestsPerConnection requests: a few slow or idle clients cannot hold every worker.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "match_view.h"

namespace kinect3d {

struct ViewServerOptions {
  std::string bind = "127.0.0.1";  // this machine only; 0.0.0.0: every interface (the robot's network)
  int port = 8080;                 // 0: any free port
};

// Listens from construction to destruction, on a thread of its own.
class ViewServer {
 public:
  static constexpr int kWorkers = 16;
  static constexpr int kReadTimeout_s = 1;
  static constexpr int kWriteTimeout_s = 5;
  static constexpr int kRequestsPerConnection = 20;

  // Throws std::runtime_error when it cannot listen or a packaged script is missing, naming it.
  ViewServer(MatchView& view, const ViewServerOptions& options);
  ~ViewServer();
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;

  int port() const { return port_; }
  // "http://<address>:<port>/" for a person to open, one per address it can be reached at.
  std::vector<std::string> urls() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  ViewServerOptions options_;
  int port_ = 0;
};

}  // namespace kinect3d
