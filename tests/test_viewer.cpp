// `kinect3d view` as a person uses it: the server started on the demo's match log, the page opened in
// headless Chromium (WebGL through SwiftShader) and read back from its DOM and a screenshot; every
// path outside the viewer's routes refused; the live view of a running robot.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sqlite3.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "demo_log.h"
#include "framework_api/config.h"
#include "framework_api/world_state.h"
#include "host_process.h"
#include "matchlog/match_log.h"
#include "run_command.h"
#include "scoped_temp_dir.h"
#include "small_depth_image.h"

namespace {

namespace fs = std::filesystem;

// `kinect3d view <args>` in the background on any free port of 127.0.0.1, stopped with SIGTERM.
class ServedView {
 public:
  explicit ServedView(const std::vector<std::string>& view_args) {
    std::vector<std::string> args = {KINECT3D_EXE, "view"};
    args.insert(args.end(), view_args.begin(), view_args.end());
    args.insert(args.end(), {"--port", "0", "--bind", "127.0.0.1"});
    std::vector<char*> argv;
    for (std::string& arg : args) argv.push_back(arg.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, output_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
    if (posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), environ) != 0) throw std::runtime_error("spawn");
    posix_spawn_file_actions_destroy(&actions);
    // It prints its address once it listens.
    const std::regex address(R"(http://127\.0\.0\.1:(\d+)/)");
    for (int i = 0; i < 300 && port_ == 0; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      std::ifstream in(output_);
      std::stringstream text;
      text << in.rdbuf();
      std::smatch match;
      const std::string printed = text.str();
      if (std::regex_search(printed, match, address)) port_ = std::stoi(match[1].str());
    }
    if (port_ == 0) throw std::runtime_error("kinect3d view printed no address");
  }
  ~ServedView() {
    if (pid_ > 0) stop();
  }
  // SIGTERM; its exit status.
  int stop() {
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = 0;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  std::string url(const std::string& path = "/") const { return "http://127.0.0.1:" + std::to_string(port_) + path; }
  int port() const { return port_; }

 private:
  ScopedTempDir dir_;
  std::string output_ = (dir_.path() / "out.txt").string();
  pid_t pid_ = 0;
  int port_ = 0;
};

// One GET with the path sent exactly as written (no client normalises it): the whole response.
// A connection to the viewer on 127.0.0.1:port; -1 when it cannot connect.
int connectTo(int port) {
  const int sock = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(sock, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    close(sock);
    return -1;
  }
  return sock;
}

// GET path; what came back within the time limit (the whole response unless the server stalled).
std::string rawGet(int port, const std::string& path, int limit_s = 60) {
  const int sock = connectTo(port);
  if (sock < 0) throw std::runtime_error("cannot connect to port " + std::to_string(port));
  const timeval limit{limit_s, 0};
  setsockopt(sock, SOL_SOCKET, SO_RCVTIMEO, &limit, sizeof limit);
  const std::string request = "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
  if (send(sock, request.data(), request.size(), 0) != static_cast<ssize_t>(request.size())) {
    close(sock);
    throw std::runtime_error("cannot send the request");
  }
  std::string response;
  char buffer[4096];
  for (ssize_t n; (n = recv(sock, buffer, sizeof buffer, 0)) > 0;) response.append(buffer, static_cast<std::size_t>(n));
  close(sock);
  return response;
}

// The value of data-<name> on the page's status element.
std::string statusValue(const std::string& dom, const std::string& name) {
  std::smatch match;
  if (!std::regex_search(dom, match, std::regex("data-" + name + "=\"([^\"]*)\""))) return "";
  return match[1].str();
}

class ViewedDemo : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new ScopedTempDir;
    runDemo(dir_->path().string());
    folder_ = onlySubfolder(dir_->path());
  }
  static void TearDownTestSuite() { delete dir_; }
  static ScopedTempDir* dir_;
  static std::string folder_;
};
ScopedTempDir* ViewedDemo::dir_ = nullptr;
std::string ViewedDemo::folder_;

TEST_F(ViewedDemo, ThePageShowsTheLobInThreeDimensionsAndInTime) {
  const fw::MatchLogReader log(folder_);
  const auto entries = log.entries();
  const auto frames = log.depthFrameStamps("kinect3d");
  ASSERT_GT(frames.size(), 60u);
  // The moment of the lob's highest detection, in the page's time (seconds from the first frame).
  std::size_t kinect_balls = 0, fused = itemsOf<fw::FusedBall>(entries).size();
  double apex_z = 0.0, apex_s = 0.0;
  for (const fw::BallFrame& frame : itemsOf<fw::BallFrame>(entries)) {
    for (const fw::BallObservation& ball : frame.balls) {
      ++kinect_balls;
      if (ball.position_m.z() > apex_z) {
        apex_z = ball.position_m.z();
        apex_s = ball.stamp.source_time_s - frames.front().source_time_s;
      }
    }
  }
  ASSERT_GT(apex_z, 0.8);

  ServedView view({folder_});
  const std::string page = "'" + view.url("/?t=" + std::to_string(apex_s)) + "'";
  const std::string chromium =
      "chromium --headless --no-sandbox --disable-gpu --use-gl=swiftshader --enable-unsafe-swiftshader "
      "--window-size=1280,1100 --virtual-time-budget=10000 ";
  const auto [status, dom] = runCommand(chromium + "--dump-dom " + page + " 2>/dev/null");
  ASSERT_EQ(status, 0);
  ASSERT_EQ(statusValue(dom, "ready"), "yes") << dom.substr(0, 2000);
  EXPECT_NE(dom.find("Kinect3D view: demo"), std::string::npos);
  // The slider holds every depth frame; the height timeline every Kinect ball, fused ball and a true
  // height per frame (the log comes from the simulator).
  EXPECT_EQ(statusValue(dom, "frames"), std::to_string(frames.size()));
  EXPECT_EQ(statusValue(dom, "height-points"), std::to_string(kinect_balls + fused + frames.size()));
  EXPECT_EQ(statusValue(dom, "charts"), "4");
  // At the apex: the Kinect's ball, the fused one, the truth, the prediction, and the ball's mask.
  EXPECT_EQ(statusValue(dom, "kinect"), "1");
  EXPECT_EQ(statusValue(dom, "fused"), "1");
  EXPECT_EQ(statusValue(dom, "truth"), "1");
  EXPECT_EQ(statusValue(dom, "trajectory"), "1");
  EXPECT_GE(std::stoi("0" + statusValue(dom, "candidates")), 1);
  EXPECT_GE(std::stoi("0" + statusValue(dom, "voxels")), 10);
  EXPECT_GE(std::stoi("0" + statusValue(dom, "points")), 5000);
  EXPECT_NE(dom.find("touchdown at "), std::string::npos);
  EXPECT_NE(dom.find("floor_found"), std::string::npos);

  // The picture: the 3D view (its top-left 850 x 480 pixels) has the Kinect's ball in its blue, the
  // candidate's core in orange and the prediction in magenta.
  ScopedTempDir out;
  const fs::path shot = out.path() / "shot.png";
  ASSERT_EQ(runCommand(chromium + "--screenshot=" + shot.string() + " " + page + " 2>/dev/null").first, 0);
  const cv::Mat picture = cv::imread(shot.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(picture.empty());
  const cv::Mat view3d = picture(cv::Rect(8, 40, 850, 480));
  const auto pixels = [&](cv::Scalar low_bgr, cv::Scalar high_bgr) {
    cv::Mat hit;
    cv::inRange(view3d, low_bgr, high_bgr, hit);
    return cv::countNonZero(hit);
  };
  EXPECT_GT(pixels({200, 90, 20}, {255, 160, 90}), 30) << "the Kinect's ball (#2f7bff)";
  EXPECT_GT(pixels({0, 110, 220}, {60, 170, 255}), 100) << "a candidate's core (#ff8c1a)";
  EXPECT_GT(pixels({220, 30, 220}, {255, 100, 255}), 30) << "the prediction (#ff40ff)";
  EXPECT_EQ(view.stop(), 0);  // SIGTERM ends it cleanly
}

TEST_F(ViewedDemo, NothingOutsideTheViewersRoutesIsReachable) {
  ServedView view({folder_});
  // What it serves (so that the refusals below are the server refusing, not a dead server).
  EXPECT_NE(rawGet(view.port(), "/api/run").find("HTTP/1.1 200"), std::string::npos);
  EXPECT_NE(rawGet(view.port(), "/three.min.js").find("HTTP/1.1 200"), std::string::npos);
  const std::string run_folder = fs::path(folder_).filename().string();
  for (const std::string& path : std::vector<std::string>{
           "/match.sqlite", "/../match.sqlite", "/..%2fmatch.sqlite", "/" + run_folder + "/match.sqlite",
           "/../../../../../../etc/passwd", "/%2e%2e/%2e%2e/%2e%2e/etc/passwd", "//etc/passwd",
           "/api/frame/../../../etc/passwd", "/api/depth/..%2f..%2fmatch.sqlite", "/api/frame/99999999999999999999",
           "/three.min.js/../../match.sqlite", "/api/run/../../match.sqlite"}) {
    const std::string response = rawGet(view.port(), path);
    EXPECT_EQ(response.rfind("HTTP/1.1 404", 0), 0u) << path << ":\n" << response.substr(0, 200);
    EXPECT_EQ(response.find("SQLite format 3"), std::string::npos) << path;
    EXPECT_EQ(response.find("root:"), std::string::npos) << path;
  }
}

TEST_F(ViewedDemo, ASecondViewerOnTheSamePortIsRefusedNotShared) {
  ServedView first({folder_});
  // `timeout` ends a second viewer that wrongly shares the port, so that the test fails, not hangs.
  const auto [status, output] = runCommand(std::string("timeout 10 ") + KINECT3D_EXE + " view " + folder_ +
                                           " --bind 127.0.0.1 --port " + std::to_string(first.port()) + " 2>&1");
  EXPECT_NE(output.find("cannot listen on 127.0.0.1:" + std::to_string(first.port())), std::string::npos) << output;
  EXPECT_EQ(status, 2) << output;
  EXPECT_NE(rawGet(first.port(), "/api/run").find("HTTP/1.1 200"), std::string::npos);
}

// The scene of depth frame `frame` as `kinect3d view` serves it.
nlohmann::json servedFrame(const ServedView& view, int frame) {
  const std::string response = rawGet(view.port(), "/api/frame/" + std::to_string(frame));
  EXPECT_EQ(response.rfind("HTTP/1.1 200", 0), 0u) << response.substr(0, 200);
  return nlohmann::json::parse(response.substr(response.find("\r\n\r\n") + 4));
}

// A log written by hand: 30 small depth frames at 30 Hz (a wall 2 m ahead), and after each what
// also_logged writes.
using AlsoLogged = std::function<void(fw::MatchLogWriter&, const fw::DepthImage&)>;
std::string smallLog(const fs::path& dir, const AlsoLogged& also_logged = {}) {
  const std::string folder = (dir / "run").string();
  const fw::Config config = fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults",
                                             std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml", {});
  fw::MatchLogWriter writer(folder, {"demo", "0.1.0", config.toYaml(), 2000.0, ""});
  for (int i = 0; i < 30; ++i) {
    fw::DepthImage image = smallDepthImage(static_cast<std::uint64_t>(i));
    image.depth_mm.assign(image.depth_mm.size(), 2000);
    writer.write({image.stamp.receive_time_s, image});
    if (also_logged) also_logged(writer, image);
  }
  return folder;
}

TEST(ViewedLog, TheFusedBallIsHeldUntilTheFusionClearsIt) {
  // The world ball published with frame 3 and cleared at frame 20, nothing published between (no
  // source saw the ball).
  ScopedTempDir dir;
  const std::string folder = smallLog(dir.path(), [](fw::MatchLogWriter& writer, const fw::DepthImage& image) {
    if (image.index == 3) {
      fw::FusedBall ball;
      ball.position_R = {0.2, 1.5, 1.1};
      ball.state = fw::BallState::kAir;
      ball.sources = {"kinect3d"};
      ball.stamp = image.stamp;
      ball.goal_crossing = fw::GoalCrossing{-1, 0.4, 0.7, image.stamp.source_time_s + 0.5, 0.1, 0.02};
      writer.write({image.stamp.receive_time_s, ball});
    }
    if (image.index == 20) writer.write({image.stamp.receive_time_s, fw::FusedBallCleared{}});
  });
  ServedView view({folder});
  EXPECT_TRUE(servedFrame(view, 2)["fused"].is_null()) << "before the fusion published it";
  for (const int frame : {3, 10, 19}) {
    const nlohmann::json fused = servedFrame(view, frame)["fused"];
    ASSERT_TRUE(fused.is_object()) << "frame " << frame;
    EXPECT_EQ(fused["p_m"], nlohmann::json({0.2, 1.5, 1.1})) << "frame " << frame;
    EXPECT_NEAR(fused["published_ago_s"].get<double>(), (frame - 3) / 30.0, 1e-3) << "frame " << frame;
    EXPECT_EQ(fused["goal_crossing"]["goal"], "own");
    EXPECT_NEAR(fused["goal_crossing"]["x_m"].get<double>(), 0.4, 1e-9);
    EXPECT_NEAR(fused["goal_crossing"]["in_s"].get<double>(), 0.5 - (frame - 3) / 30.0, 1e-3) << "frame " << frame;
  }
  EXPECT_TRUE(servedFrame(view, 21)["fused"].is_null()) << "after the fusion cleared it";
  EXPECT_EQ(view.stop(), 0);
  // It wrote nothing beside the log (no write-ahead files from its reading).
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(folder)) files.push_back(entry.path().filename().string());
  EXPECT_EQ(files, std::vector<std::string>{"match.sqlite"});
}

TEST(ViewedLog, TeammatesAreDrawnInThisRobotsFrameWhereTheirMessagesPutThem) {
  // From frame 5 this robot stands at (1, 2) in the field facing the field's -x; the keeper at (1, 4)
  // facing +y sees a ball at (0, 4, 0.5) with its Kinect and one with its omni camera at (2, 4), and
  // this robot at (1, 2.1) with its omni camera.
  ScopedTempDir dir;
  const std::string folder = smallLog(dir.path(), [](fw::MatchLogWriter& writer, const fw::DepthImage& image) {
    if (image.index < 5) return;
    writer.write({image.stamp.receive_time_s, fw::RobotPose{1.0, 2.0, M_PI / 2, image.stamp, std::nullopt}});
    fw::TeamMessage message;
    message.robot_id = 4;
    message.robot_name = "keeper";
    message.sent_time_s = image.stamp.source_time_s;
    message.pose = fw::RobotPose{1.0, 4.0, 0.0, image.stamp, std::nullopt};
    fw::BallObservation ball;
    ball.position_m = {0.0, 4.0, 0.5};
    message.kinect_balls = {ball};
    fw::BallRay ray;
    ray.origin_F = {1.0, 4.0, 0.75};
    ray.direction_F = (Eigen::Vector3d(2.0, 4.0, 0.11) - ray.origin_F).normalized();
    message.omni_rays = {ray};
    fw::SeenRobot robot;
    robot.position_F = {1.0, 2.1};
    message.robots_seen = {robot};
    writer.write({image.stamp.receive_time_s, message});
  });
  ServedView view({folder});
  EXPECT_TRUE(servedFrame(view, 3)["teammates"].empty()) << "before its first message";
  const nlohmann::json teammates = servedFrame(view, 10)["teammates"];
  ASSERT_EQ(teammates.size(), 1u) << teammates.dump();
  const nlohmann::json& keeper = teammates[0];
  EXPECT_EQ(keeper["name"], "keeper");
  EXPECT_EQ(keeper["p_m"], nlohmann::json({2.0, 0.0, 0.0})) << "2 m to this robot's right";
  EXPECT_NEAR(keeper["heading_rad"].get<double>(), -M_PI / 2, 1e-3);
  EXPECT_EQ(keeper["kinect"], nlohmann::json({{2.0, 1.0, 0.5}}));
  ASSERT_EQ(keeper["rays"].size(), 1u);
  EXPECT_EQ(keeper["rays"][0][0], nlohmann::json({2.0, 0.0, 0.75}));
  EXPECT_EQ(keeper["rays"][0][1], nlohmann::json({2.0, -1.0, 0.11}));
  EXPECT_EQ(keeper["robots_seen"], nlohmann::json({{0.1, 0.0, 0.0}})) << "0.1 m to this robot's right";
  EXPECT_EQ(view.stop(), 0);
}

TEST(ViewedLog, EightSlowClientsDoNotStopANinthFromGettingThePage) {
  ScopedTempDir dir;
  ServedView view({smallLog(dir.path())});
  // Eight clients that start a request and send one more header line every 2 s, for as long as
  // the test lasts: each would hold a worker for ever if a silent second did not end it.
  std::atomic<bool> done{false};
  std::vector<std::thread> slow;
  for (int i = 0; i < 8; ++i) {
    const int sock = connectTo(view.port());
    ASSERT_GE(sock, 0);
    slow.emplace_back([sock, &done] {
      std::string line = "GET / HTTP/1.1\r\n";
      while (!done) {
        send(sock, line.data(), line.size(), MSG_NOSIGNAL);
        line = "X-Slow: 1\r\n";
        for (int waited_ms = 0; waited_ms < 2000 && !done; waited_ms += 10) {
          std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
      }
      close(sock);
    });
  }
  // A ninth gets the page while they go on (within 30 s; it waits for ever without the limits).
  const std::string page = rawGet(view.port(), "/", 30);
  done = true;
  for (std::thread& client : slow) client.join();
  EXPECT_EQ(page.rfind("HTTP/1.1 200", 0), 0u) << page.substr(0, 200);
  EXPECT_NE(page.find("<html"), std::string::npos);
}

TEST(ViewedLog, ADamagedFrameAnswers500WithItsReason) {
  ScopedTempDir dir;
  const std::string log = smallLog(dir.path());
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((log + "/match.sqlite").c_str(), &db), SQLITE_OK);
  ASSERT_EQ(
      sqlite3_exec(db, "UPDATE depth_frame SET depth = x'0badc0de' WHERE frame_index = 4", nullptr, nullptr, nullptr),
      SQLITE_OK);
  sqlite3_close(db);
  ServedView view({log});
  const std::string response = rawGet(view.port(), "/api/depth/4.png");
  EXPECT_EQ(response.rfind("HTTP/1.1 500", 0), 0u) << response.substr(0, 300);
  EXPECT_NE(response.find("depth frame 4 (seq"), std::string::npos) << response;
  EXPECT_NE(response.find("its depth is not zstd-compressed"), std::string::npos) << response;
  EXPECT_EQ(rawGet(view.port(), "/api/depth/5.png").rfind("HTTP/1.1 200", 0), 0u) << "the others are served";
}

TEST(ViewedLog, ListensOnThisMachineOnlyUnlessToldOtherwise) {
  ScopedTempDir dir;
  HostProcess view({"view", smallLog(dir.path()), "--port", "0"}, "", KINECT3D_EXE);
  ASSERT_TRUE(view.waitForOutput("(Ctrl-C stops)"));
  view.signal(SIGTERM);
  EXPECT_EQ(view.waitExit(std::chrono::seconds(30)), 0);
  EXPECT_NE(view.readAll().find("on http://127.0.0.1:"), std::string::npos) << view.readAll();
}

TEST(LiveView, FollowsARobotAsItRunsAndStopsOnSigterm) {
  ScopedTempDir logs;
  ServedView view({"--live", std::string(PROJECT_CONFIG_DIR) + "/robots/demo.yaml", "--set",
                   "logger.folder=" + logs.path().string()});
  // The run grows while the demo's lob plays (3.5 s in real time).
  const auto framesNow = [&] {
    const std::string response = rawGet(view.port(), "/api/run");
    std::smatch match;
    std::regex_search(response, match, std::regex(R"("frames_t_s":\[([^\]]*)\])"));
    const std::string times = match[1].str();
    return times.empty() ? 0 : 1 + std::count(times.begin(), times.end(), ',');
  };
  const long early = framesNow();
  long later = early;
  for (const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
       later <= early + 20 && std::chrono::steady_clock::now() < deadline;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    later = framesNow();
  }
  EXPECT_GT(later, early + 20);
  EXPECT_EQ(view.stop(), 0);
  EXPECT_NO_THROW(fw::MatchLogReader(onlySubfolder(logs.path())));  // the host's log, kept
}

}  // namespace
