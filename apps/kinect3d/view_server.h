// `kinect3d view`'s web server (cpp-httplib): the viewer's page, the packaged JavaScript it uses
// (three.js, its orbit controls, Chart.js) and the view's data, on a fixed set of read-only routes.
// Nothing is served by file name: whatever a request path says, no file is reachable but these.
#pragma once

#include <memory>
#include <string>

#include "match_view.h"

namespace kinect3d {

struct ViewServerOptions {
  std::string bind = "0.0.0.0";  // every interface: the team's laptops on the robot's network
  int port = 8080;               // 0: any free port
};

// Listens from construction to destruction, on a thread of its own.
class ViewServer {
 public:
  // Throws std::runtime_error when it cannot listen or a packaged script is missing, naming it.
  ViewServer(MatchView& view, const ViewServerOptions& options);
  ~ViewServer();
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;

  int port() const { return port_; }
  // "http://<address>:<port>/" for a person to open.
  std::string url() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  ViewServerOptions options_;
  int port_ = 0;
};

}  // namespace kinect3d
