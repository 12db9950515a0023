#include "view_server.h"

#include <arpa/inet.h>
#include <httplib.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

namespace kinect3d {

extern const std::string kViewerPage;  // viewer/index.html, built in

namespace {

std::string readScript(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw std::runtime_error(path + ": cannot read it (the viewer needs Debian's libjs-three and libjs-chart.js)");
  }
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The frame number of /api/.../<n>, or nothing when it is not a number the view can hold.
std::optional<std::size_t> frameNumber(const httplib::Request& request) {
  try {
    return static_cast<std::size_t>(std::stoul(request.matches[1].str()));
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// httplib's pool of workers, each request run at a lower priority than the robot's threads.
class LowPriorityWorkers : public httplib::TaskQueue {
 public:
  explicit LowPriorityWorkers(int workers) : pool_(static_cast<std::size_t>(workers)) {}
  void enqueue(std::function<void()> request) override {
    pool_.enqueue([request = std::move(request)] {
      // Linux keeps a nice value per thread: this worker only (a no-op once set).
      setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 10);
      request();
    });
  }
  void shutdown() override { pool_.shutdown(); }

 private:
  httplib::ThreadPool pool_;
};

}  // namespace

struct ViewServer::Impl {
  std::map<std::string, std::string> scripts;
  httplib::Server server;
  std::thread listener;
  std::atomic<bool> listening_ended{false};
};

ViewServer::ViewServer(MatchView& view, const ViewServerOptions& options)
    : impl_(std::make_unique<Impl>()), options_(options) {
  impl_->scripts = {{"/three.min.js", readScript(KINECT3D_THREE_JS)},
                    {"/OrbitControls.js", readScript(KINECT3D_ORBIT_CONTROLS_JS)},
                    {"/chart.min.js", readScript(KINECT3D_CHART_JS)}};
  httplib::Server& server = impl_->server;
  server.Get("/", [](const httplib::Request&, httplib::Response& response) {
    response.set_content(kViewerPage, "text/html; charset=utf-8");
  });
  for (const auto& [route, script] : impl_->scripts) {
    server.Get(route, [&script = script](const httplib::Request&, httplib::Response& response) {
      response.set_content(script, "application/javascript");
    });
  }
  server.Get("/api/run", [&view](const httplib::Request&, httplib::Response& response) {
    response.set_content(view.run().dump(), "application/json");
  });
  server.Get(R"(/api/frame/(\d+))", [&view](const httplib::Request& request, httplib::Response& response) {
    const std::optional<std::size_t> frame = frameNumber(request);
    const std::optional<nlohmann::json> scene = frame ? view.frame(*frame) : std::nullopt;
    if (!scene) {
      response.status = 404;
      return;
    }
    response.set_content(scene->dump(), "application/json");
  });
  // A frame's image: depth (always) or colour (when the robot logged it); 404 when there is none.
  using FrameImage = std::optional<std::string> (MatchView::*)(std::size_t);
  for (const auto& [pattern, image] :
       {std::pair<const char*, FrameImage>{R"(/api/depth/(\d+)\.png)", &MatchView::depthPng},
        std::pair<const char*, FrameImage>{R"(/api/colour/(\d+)\.png)", &MatchView::colourPng}}) {
    server.Get(pattern, [&view, image = image](const httplib::Request& request, httplib::Response& response) {
      const std::optional<std::size_t> frame = frameNumber(request);
      const std::optional<std::string> png = frame ? (view.*image)(*frame) : std::nullopt;
      if (!png) {
        response.status = 404;
        return;
      }
      response.set_content(*png, "image/png");
    });
  }
  // A bad log frame (a damaged PNG) answers 500 with the reason; the server goes on.
  server.set_exception_handler([](const httplib::Request&, httplib::Response& response, std::exception_ptr error) {
    try {
      std::rethrow_exception(error);
    } catch (const std::exception& e) {
      response.set_content(std::string(e.what()) + "\n", "text/plain");
    }
    response.status = 500;
  });
  // Every other error names itself, unless a handler already said why.
  server.set_error_handler([](const httplib::Request& request, httplib::Response& response) {
    if (response.body.empty()) {
      response.set_content(std::to_string(response.status) + ": " + request.path + "\n", "text/plain");
    }
  });
  server.new_task_queue = [] { return new LowPriorityWorkers(kWorkers); };
  server.set_read_timeout(kReadTimeout_s, 0);
  server.set_write_timeout(kWriteTimeout_s, 0);
  server.set_keep_alive_max_count(kRequestsPerConnection);
  server.set_keep_alive_timeout(kReadTimeout_s);

  // Quick restarts yes (SO_REUSEADDR), but not httplib's SO_REUSEPORT: a second viewer on the same
  // port must fail, not share the port and answer every other request from another log.
  server.set_socket_options([](socket_t sock) {
    const int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  port_ = options.port == 0 ? server.bind_to_any_port(options.bind)
                            : (server.bind_to_port(options.bind, options.port) ? options.port : -1);
  if (port_ < 0) {
    throw std::runtime_error("cannot listen on " + options.bind + ":" + std::to_string(options.port) +
                             " (in use, or not an address of this machine): give another with --port N, or --port 0 "
                             "for any free one");
  }
  impl_->listener = std::thread([this] {
    impl_->server.listen_after_bind();
    impl_->listening_ended = true;
  });
  // httplib's stop() does nothing before its loop runs, and the loop would then run for ever: a
  // Ctrl-C right after the start must find it running.
  while (!server.is_running() && !impl_->listening_ended) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

ViewServer::~ViewServer() {
  impl_->server.stop();
  impl_->listener.join();
}

std::vector<std::string> ViewServer::urls() const {
  const std::string port = ":" + std::to_string(port_) + "/";
  if (options_.bind != "0.0.0.0") return {"http://" + options_.bind + port};
  // Every interface: each address another laptop may reach it by (a host name may not resolve
  // there), loopback last.
  std::vector<std::string> urls;
  ifaddrs* interfaces = nullptr;
  if (getifaddrs(&interfaces) == 0) {
    for (const ifaddrs* i = interfaces; i != nullptr; i = i->ifa_next) {
      if (i->ifa_addr == nullptr || i->ifa_addr->sa_family != AF_INET || (i->ifa_flags & IFF_LOOPBACK)) continue;
      char address[INET_ADDRSTRLEN] = {};
      inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(i->ifa_addr)->sin_addr, address, sizeof address);
      urls.push_back("http://" + std::string(address) + port);
    }
    freeifaddrs(interfaces);
  }
  urls.push_back("http://localhost" + port);
  return urls;
}

}  // namespace kinect3d
