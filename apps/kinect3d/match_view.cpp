#include "match_view.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

#include "framework_api/config.h"
#include "kinect3d/ball_candidates.h"
#include "kinect3d/config_io.h"

namespace kinect3d {

namespace {

using nlohmann::json;

// The page draws every n-th depth pixel in u and v as a point (4: about 19,000 for a Kinect frame),
// in whole centimetres (a third of the bytes of metres with decimals).
constexpr int kPointStride = 4;
// A source's ball counts for a moment when it is at most this old (a frame at 30 Hz, and some).
constexpr double kRecent_s = 0.05;
// A teammate's message counts as now for this long: it sends 20 a second over Wi-Fi, which loses some.
constexpr double kTeammateRecent_s = 0.3;
// A flight is drawn this far past the fit at most.
constexpr double kMaxAhead_s = 1.5;
constexpr int kPathSamples = 40;

double rounded(double value, double step = 0.001) { return std::round(value / step) * step; }
json xyz(const Eigen::Vector3d& p) { return {rounded(p.x()), rounded(p.y()), rounded(p.z())}; }

// The publication of `items` (sorted by time) at or before t_s and at most max_age_s old.
template <typename Item>
const Item* latestAt(const std::vector<std::pair<double, Item>>& items, double t_s, double max_age_s) {
  const auto after = std::upper_bound(items.begin(), items.end(), t_s + 1e-9,
                                      [](double t, const std::pair<double, Item>& item) { return t < item.first; });
  if (after == items.begin() || t_s - std::prev(after)->first > max_age_s) return nullptr;
  return &std::prev(after)->second;
}

}  // namespace

// The publications a moment needs, each with its time on the depth sensor's clock. A cleared
// trajectory or world ball is an empty entry.
struct MatchView::Published {
  std::vector<std::pair<double, fw::BallFrame>> kinect;
  std::vector<std::pair<double, fw::OmniFrame>> omni;
  std::vector<std::pair<double, std::optional<fw::FusedBall>>> fused;
  std::vector<std::pair<double, std::optional<fw::BallTrajectory>>> trajectory;
  std::vector<std::pair<double, fw::RobotPose>> pose;
  std::map<int, std::vector<std::pair<double, fw::TeamMessage>>> team;  // by teammate
};

// The run's timelines as the page draws them, grown with the log.
struct MatchView::Timelines {
  json frames = json::array();
  json height_kinect = {{"t_s", json::array()}, {"z_m", json::array()}};
  json height_fused = height_kinect, height_truth = height_kinect;
  json gap_kinect = {{"t_s", json::array()}, {"d_m", json::array()}}, gap_omni = gap_kinect;
  std::map<std::string, json> processing, dropped;
  std::map<std::string, std::uint64_t> dropped_before;
  json events = json::array();
  double omni_reach_m = 0.0;
};

MatchView::MatchView(const std::string& log_folder)
    : folder_(log_folder),
      log_(std::make_unique<fw::MatchLogReader>(log_folder)),
      truth_(std::make_unique<RecordedTruth>(log_->run())),
      published_(std::make_unique<Published>()),
      timelines_(std::make_unique<Timelines>()) {
  const fw::ConfigView kinect3d =
      fw::Config::parseDocument(log_->run().config_yaml, folder_ + " (recorded configuration)").block("kinect3d");
  detector_config_ = readDetectorConfig(kinect3d);
  detector_ = std::make_unique<BallDetector>(detector_config_, "view");
  index();
}
MatchView::~MatchView() = default;

std::uintmax_t MatchView::logBytes() const {
  std::error_code error;
  std::uintmax_t bytes = 0;
  for (const char* suffix : {"", "-wal"}) {
    const std::uintmax_t size = std::filesystem::file_size(folder_ + "/" + fw::kMatchLogFile + suffix, error);
    if (!error) bytes += size;
  }
  return bytes;
}

void MatchView::reloadIfGrown() {
  if (logBytes() != log_bytes_) index();
}

void MatchView::index() {
  log_bytes_ = logBytes();
  if (frames_.empty()) {
    const auto sources = log_->depthSources();
    depth_source_ = sources.empty() ? "kinect3d" : sources.front().first;
  }
  const std::vector<fw::MatchLogReader::DepthFrameStamp> new_frames =
      log_->depthFrameStamps(depth_source_, frames_.empty() ? 0 : frames_.back().seq);
  if (frames_.empty() && !new_frames.empty()) {
    // The page's zero, and the depth sensor's clock against the host's for what carries only a wall
    // time: fixed by the first frames, so what is indexed stays where it was drawn.
    t0_ = new_frames.front().source_time_s;
    wall_to_source_s_ = log_->clockOffset_s(depth_source_).value_or(0.0);
  }
  Timelines& l = *timelines_;
  const auto addPoint = [&](json& series, const char* value_key, double t, double value) {
    series["t_s"].push_back(rounded(t - t0_));
    series[value_key].push_back(rounded(value));
  };
  for (const auto& frame : new_frames) {
    frames_.push_back(frame);
    l.frames.push_back(rounded(frame.source_time_s - t0_));
    if (truth_->known()) addPoint(l.height_truth, "z_m", frame.source_time_s, truth_->ball_R(frame.source_time_s).z());
  }
  // What was published since the last index (nothing before the first depth frame: it sets the zero).
  Published& p = *published_;
  if (!frames_.empty()) {
    for (const fw::JournalEntry& entry : log_->entries(last_seq_, &last_seq_)) {
      const double wall_t = entry.wall_time_s + wall_to_source_s_;
      if (const auto* frame = std::get_if<fw::BallFrame>(&entry.item)) {
        if (frame->balls.empty() || frame->balls.front().source != depth_source_) continue;
        const double t = frame->stamp.source_time_s;
        p.kinect.emplace_back(t, *frame);
        for (const fw::BallObservation& ball : frame->balls) addPoint(l.height_kinect, "z_m", t, ball.position_m.z());
        if (const auto* fused = latestAt(p.fused, t, kRecent_s); fused != nullptr && *fused) {
          double nearest = 1e9;
          for (const fw::BallObservation& ball : frame->balls) {
            nearest = std::min(nearest, (ball.position_m - (*fused)->position_R).norm());
          }
          addPoint(l.gap_kinect, "d_m", t, nearest);
        }
      } else if (const auto* omni = std::get_if<fw::OmniFrame>(&entry.item)) {
        const double t = omni->stamp.source_time_s;
        p.omni.emplace_back(t, *omni);
        for (const fw::OmniBallObservation& ball : omni->balls)
          l.omni_reach_m = std::max(l.omni_reach_m, ball.distance_m);
        if (const auto* fused = latestAt(p.fused, t, kRecent_s); fused != nullptr && *fused && !omni->balls.empty()) {
          double nearest = 1e9;
          for (const fw::OmniBallObservation& ball : omni->balls) {
            nearest = std::min(nearest, (ball.groundPoint_R() - (*fused)->position_R).head<2>().norm());
          }
          addPoint(l.gap_omni, "d_m", t, nearest);
        }
      } else if (const auto* fused = std::get_if<fw::FusedBall>(&entry.item)) {
        p.fused.emplace_back(fused->stamp.source_time_s, *fused);
        addPoint(l.height_fused, "z_m", fused->stamp.source_time_s, fused->position_F.z());
      } else if (std::holds_alternative<fw::FusedBallCleared>(entry.item)) {
        p.fused.emplace_back(wall_t, std::nullopt);
      } else if (const auto* fit = std::get_if<fw::BallTrajectory>(&entry.item)) {
        if (fit->source == depth_source_) p.trajectory.emplace_back(fit->time_s, *fit);
      } else if (const auto* lost = std::get_if<fw::TrajectoryCleared>(&entry.item)) {
        if (lost->source == depth_source_) p.trajectory.emplace_back(wall_t, std::nullopt);
      } else if (const auto* pose = std::get_if<fw::RobotPose>(&entry.item)) {
        p.pose.emplace_back(pose->stamp.source_time_s, *pose);
      } else if (const auto* message = std::get_if<fw::TeamMessage>(&entry.item)) {
        // Its times are on this robot's fusion clock, the depth sensor's (plugins/team).
        p.team[message->robot_id].emplace_back(message->sent_time_s, *message);
      } else if (const auto* health = std::get_if<fw::PluginHealth>(&entry.item)) {
        json& series = l.processing[health->plugin];
        if (series.is_null()) series = {{"t_s", json::array()}, {"p50_ms", json::array()}, {"p99_ms", json::array()}};
        series["t_s"].push_back(rounded(wall_t - t0_));
        series["p50_ms"].push_back(rounded(1000.0 * health->processing_p50_s, 0.01));
        series["p99_ms"].push_back(rounded(1000.0 * health->processing_p99_s, 0.01));
        json& lost_frames = l.dropped[health->plugin];
        if (lost_frames.is_null()) lost_frames = {{"t_s", json::array()}, {"frames", json::array()}};
        lost_frames["t_s"].push_back(rounded(wall_t - t0_));
        lost_frames["frames"].push_back(health->dropped_frames - l.dropped_before[health->plugin]);
        l.dropped_before[health->plugin] = health->dropped_frames;
      } else if (const auto* event = std::get_if<fw::Event>(&entry.item)) {
        l.events.push_back({{"t_s", rounded(event->stamp.source_time_s - t0_)},
                            {"source", event->source},
                            {"kind", event->kind},
                            {"message", event->message}});
      }
    }
  }
  // Publications arrive in the order they were published, not always in their stamps' order.
  const auto byTime = [](const auto& a, const auto& b) { return a.first < b.first; };
  std::stable_sort(p.kinect.begin(), p.kinect.end(), byTime);
  std::stable_sort(p.omni.begin(), p.omni.end(), byTime);
  std::stable_sort(p.fused.begin(), p.fused.end(), byTime);
  std::stable_sort(p.trajectory.begin(), p.trajectory.end(), byTime);
  std::stable_sort(p.pose.begin(), p.pose.end(), byTime);
  for (auto& [robot_id, messages] : p.team) std::stable_sort(messages.begin(), messages.end(), byTime);

  json processing_series = json::array(), dropped_series = json::array();
  for (const auto& [plugin, series] : l.processing)
    processing_series.push_back({{"plugin", plugin}, {"series", series}});
  for (const auto& [plugin, series] : l.dropped) dropped_series.push_back({{"plugin", plugin}, {"series", series}});
  const fw::RunInfo& run = log_->run();
  run_ = {{"robot", run.robot},
          {"software_version", run.software_version},
          {"replayed_from", run.replayed_from},
          {"folder", folder_},
          {"depth_source", depth_source_},
          {"frames_t_s", l.frames},
          {"ball_radius_m", detector_config_.ball.radius_m},
          {"voxel_m", detector_config_.grid.voxel_m},
          {"max_range_m", detector_config_.points.max_range_m},
          {"omni_reach_m", rounded(l.omni_reach_m)},
          {"truth", truth_->known()},
          {"height", {{"kinect", l.height_kinect}, {"fused", l.height_fused}, {"truth", l.height_truth}}},
          {"gap", {{"kinect", l.gap_kinect}, {"omni", l.gap_omni}}},
          {"processing", processing_series},
          {"dropped", dropped_series},
          {"events", l.events}};
}

json MatchView::run() {
  const std::lock_guard<std::mutex> lock(mutex_);
  reloadIfGrown();
  return run_;
}

DepthFrame MatchView::depthFrame(std::size_t frame) const {
  return fromDepthImage(log_->depthFrame(frames_[frame].seq));
}

std::optional<json> MatchView::frame(std::size_t frame) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (frame >= frames_.size()) return std::nullopt;
  const DepthFrame depth = depthFrame(frame);
  const double t = depth.source_time_s;
  const Published& p = *published_;

  Detections detections;
  detector_->detect(depth, detections);
  json scene = {{"frame", frame}, {"t_s", rounded(t - t0_)}, {"frame_index", depth.index}};
  // What else the sensor measured: a colour image (api/colour/<n>.png), gravity in its frame.
  scene["colour"] = depth.colour.has_value();
  scene["gravity_S_mps2"] = depth.gravity_S_mps2 ? xyz(*depth.gravity_S_mps2) : json(nullptr);

  // The sensor and the depth points it saw (robot frame), while it knows where the floor is.
  json points = json::array();
  scene["sensor"] = nullptr;
  if (const std::optional<Eigen::Isometry3d> T_R_S = detector_->T_R_S()) {
    const Intrinsics& k = depth.intrinsics;
    const double range_m = detector_config_.points.max_range_m;
    json corners = json::array();
    for (const auto& [u, v] : {std::pair{0, 0}, {k.width, 0}, {k.width, k.height}, {0, k.height}}) {
      corners.push_back(xyz(*T_R_S * (range_m * Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0))));
    }
    scene["sensor"] = {{"position_m", xyz(T_R_S->translation())}, {"far_corners_m", corners}};
    for (int v = 0; v < k.height; v += kPointStride) {
      for (int u = 0; u < k.width; u += kPointStride) {
        const double z = depth.at(u, v) / 1000.0;
        if (z < detector_config_.points.min_range_m || z > range_m) continue;
        const Eigen::Vector3d p_R = *T_R_S * Eigen::Vector3d((u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z);
        for (int i = 0; i < 3; ++i) points.push_back(std::lround(100.0 * p_R[i]));
      }
    }
  }
  scene["points_cm"] = points;

  // The paper's Figs. 2-3: the occupied voxels, and each group that passed the mask with its core
  // and the empty shell around it.
  json voxels = json::array(), candidates = json::array();
  if (const OccupancyGrid* grid = detector_->grid(); grid != nullptr && detections.aligned) {
    for (const VoxelIndex& v : grid->occupiedVoxels()) {
      const Eigen::Vector3f c = grid->centerOf(v);
      for (int i = 0; i < 3; ++i) voxels.push_back(rounded(c[i]));
    }
    std::vector<BallCandidate> found;
    BallCandidateFinder(detector_config_.mask).find(*grid, found);
    const double voxel = grid->voxel_m();
    for (const BallCandidate& candidate : found) {
      const Eigen::Vector3d centre =
          0.5 * (grid->centerOf(candidate.min) + grid->centerOf(candidate.max)).cast<double>();
      candidates.push_back({{"centre_m", xyz(centre)},
                            {"core_m", voxel * detector_config_.mask.core_voxels},
                            {"mask_m", voxel * detector_config_.mask.mask_voxels}});
    }
  }
  scene["voxels_m"] = voxels;
  scene["candidates"] = candidates;

  // Every source's ball at this moment, as the robot had them.
  json kinect = json::array(), omni = json::array();
  if (const fw::BallFrame* balls = latestAt(p.kinect, t, kRecent_s)) {
    for (const fw::BallObservation& ball : balls->balls) {
      kinect.push_back({{"p_m", xyz(ball.position_m)},
                        {"state", fw::toString(ball.state)},
                        {"static", ball.is_static},
                        {"colour", fw::toString(ball.colour)},
                        {"colour_note", fw::toString(ball.colour_note)}});
    }
  }
  if (const fw::OmniFrame* image = latestAt(p.omni, t, kRecent_s)) {
    for (const fw::OmniBallObservation& ball : image->balls) {
      Eigen::Vector3d ground = ball.groundPoint_R();
      ground.z() = detector_config_.ball.radius_m;
      omni.push_back({{"p_m", xyz(ground)}});
    }
  }
  scene["kinect"] = kinect;
  scene["omni"] = omni;
  // The world ball as the robot held it then: the fusion's last publication until it cleared the
  // ball, however old (no source sees a ball above the robot, yet the robot still acts on it).
  scene["fused"] = nullptr;
  if (const auto* fused = latestAt(p.fused, t, INFINITY); fused != nullptr && *fused) {
    scene["fused"] = {{"p_m", xyz((*fused)->position_R)},
                      {"state", fw::toString((*fused)->state)},
                      {"sources", (*fused)->sources},
                      {"published_ago_s", rounded(t - (*fused)->stamp.source_time_s)},
                      {"goal_crossing", nullptr}};
    // Where it was to cross a goal line (field frame: the line is the field's), and how soon from t.
    if (const auto& crossing = (*fused)->goal_crossing) {
      scene["fused"]["goal_crossing"] = {{"goal", crossing->goal > 0 ? "opponent's" : "own"},
                                         {"x_m", rounded(crossing->x_m)},
                                         {"z_m", rounded(crossing->z_m)},
                                         {"sigma_m", rounded(crossing->sigma_m)},
                                         {"in_s", rounded(crossing->time_s - t)}};
    }
  }
  scene["pose"] = nullptr;
  const fw::RobotPose* pose = latestAt(p.pose, t, 0.5);
  if (pose != nullptr) scene["pose"] = {{"x_m", pose->x_m}, {"y_m", pose->y_m}, {"theta_rad", pose->theta_rad}};

  // Each teammate as its newest message put it (field frame), drawn in this robot's frame: where it
  // stands, its Kinect's balls, its omni camera's rays to where they meet the resting plane, and the
  // robots its omni camera sees (a mislocalised teammate sees this robot where it does not stand).
  json teammates = json::array();
  for (const auto& [robot_id, messages] : p.team) {
    const fw::TeamMessage* message = latestAt(messages, t, kTeammateRecent_s);
    if (pose == nullptr || message == nullptr || !message->pose) continue;
    const Eigen::Isometry3d T_R_F = pose->T_F_R().inverse();
    json balls = json::array(), rays = json::array();
    for (const fw::BallObservation& ball : message->kinect_balls) balls.push_back(xyz(T_R_F * ball.position_m));
    const double r = detector_config_.ball.radius_m;
    for (const fw::BallRay& ray : message->omni_rays) {
      if (ray.direction_F.z() >= 0.0 || ray.origin_F.z() <= r) continue;  // never meets the resting plane
      const Eigen::Vector3d ground_F = ray.origin_F + (ray.origin_F.z() - r) / -ray.direction_F.z() * ray.direction_F;
      rays.push_back({xyz(T_R_F * ray.origin_F), xyz(T_R_F * ground_F)});
    }
    json robots = json::array();
    for (const fw::SeenRobot& robot : message->robots_seen) {
      robots.push_back(xyz(T_R_F * Eigen::Vector3d(robot.position_F.x(), robot.position_F.y(), 0.0)));
    }
    const Eigen::Vector3d at_R = T_R_F * Eigen::Vector3d(message->pose->x_m, message->pose->y_m, 0.0);
    teammates.push_back({{"robot_id", robot_id},
                         {"name", message->robot_name},
                         {"p_m", xyz(at_R)},
                         {"heading_rad", rounded(fw::wrapAngle(message->pose->theta_rad - pose->theta_rad))},
                         {"kinect", balls},
                         {"rays", rays},
                         {"robots_seen", robots}});
  }
  scene["teammates"] = teammates;

  // The flight as the robot predicted it then: from the fit on to the touchdown.
  scene["trajectory"] = nullptr;
  if (const auto* fit = latestAt(p.trajectory, t, 0.3); fit != nullptr && *fit) {
    const fw::BallTrajectory& trajectory = **fit;
    const double end_s =
        trajectory.touchdown ? std::min(trajectory.touchdown->time_s, t + kMaxAhead_s) : t + kMaxAhead_s;
    json path = json::array();
    for (int i = 0; i <= kPathSamples; ++i) {
      const Eigen::Vector3d position = trajectory.positionAt(t + (end_s - t) * i / kPathSamples);
      if (position.z() < 0.0) break;
      path.push_back(xyz(position));
    }
    json drawn = {
        {"state", fw::toString(trajectory.state)}, {"path_m", path}, {"touchdown", nullptr}, {"crossing", nullptr}};
    if (trajectory.touchdown) {
      drawn["touchdown"] = {
          {"p_m", {rounded(trajectory.touchdown->point_m.x()), rounded(trajectory.touchdown->point_m.y())}},
          {"sigma_m", rounded(trajectory.touchdown->sigma_m)},
          {"in_s", rounded(trajectory.touchdown->time_s - t)}};
    }
    if (trajectory.crossing) {
      drawn["crossing"] = {{"x_m", rounded(trajectory.crossing->x_m)}, {"z_m", rounded(trajectory.crossing->z_m)}};
    }
    scene["trajectory"] = drawn;
  }
  scene["truth"] = truth_->known() ? xyz(truth_->ball_R(t)) : json(nullptr);
  return scene;
}

std::optional<std::string> MatchView::depthPng(std::size_t frame) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (frame >= frames_.size()) return std::nullopt;
  const DepthFrame depth = depthFrame(frame);
  const Intrinsics& k = depth.intrinsics;
  // Range to colour: near is warm, far is cold, no depth is black.
  const cv::Mat depth_mm(k.height, k.width, CV_16UC1, const_cast<std::uint16_t*>(depth.depth_mm.data()));
  const double near_mm = 1000.0 * detector_config_.points.min_range_m,
               far_mm = 1000.0 * detector_config_.points.max_range_m;
  cv::Mat scaled, image;
  depth_mm.convertTo(scaled, CV_8UC1, -255.0 / (far_mm - near_mm), 255.0 * far_mm / (far_mm - near_mm));
  cv::applyColorMap(scaled, image, cv::COLORMAP_JET);
  image.setTo(cv::Scalar(0, 0, 0), depth_mm == 0);
  drawSeenBalls(image, depth, k, Eigen::Vector3d::Zero());
  std::vector<unsigned char> png;
  cv::imencode(".png", image, png);
  return std::string(png.begin(), png.end());
}

std::optional<std::string> MatchView::colourPng(std::size_t frame) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (frame >= frames_.size()) return std::nullopt;
  const DepthFrame depth = depthFrame(frame);
  if (!depth.colour) return std::nullopt;
  const fw::ColourImage& colour = *depth.colour;
  cv::Mat image;
  cv::cvtColor(cv::Mat(colour.height, colour.width, CV_8UC3, const_cast<std::uint8_t*>(colour.rgb.data())), image,
               cv::COLOR_RGB2BGR);
  drawSeenBalls(image, depth, {colour.width, colour.height, colour.fx, colour.fy, colour.cx, colour.cy},
                colour.offset_S_m);
  std::vector<unsigned char> png;
  cv::imencode(".png", image, png);
  return std::string(png.begin(), png.end());
}

void MatchView::drawSeenBalls(cv::Mat& image, const DepthFrame& depth, const Intrinsics& camera,
                              const Eigen::Vector3d& camera_in_S_m) {
  Detections detections;
  detector_->detect(depth, detections);  // where the sensor is, when it finds the floor itself
  // The balls the robot saw then, where they fall in the image, with the ball's size there.
  const std::optional<Eigen::Isometry3d> T_R_S = detector_->T_R_S();
  const fw::BallFrame* balls = latestAt(published_->kinect, depth.source_time_s, kRecent_s);
  if (!T_R_S || balls == nullptr) return;
  for (const fw::BallObservation& ball : balls->balls) {
    const Eigen::Vector3d p_C = T_R_S->inverse() * ball.position_m - camera_in_S_m;
    if (p_C.z() <= 0.0) continue;
    const Eigen::Vector2d pixel = camera.project(p_C);
    const cv::Point centre(static_cast<int>(pixel.x()), static_cast<int>(pixel.y()));
    const int radius = static_cast<int>(camera.fx * detector_config_.ball.radius_m / p_C.z());
    cv::circle(image, centre, radius + 2, cv::Scalar(255, 255, 255), 2, cv::LINE_AA);
    cv::putText(image, ball.state == fw::BallState::kAir ? "air" : "ground", centre + cv::Point(radius + 4, 0),
                cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  }
}

}  // namespace kinect3d
