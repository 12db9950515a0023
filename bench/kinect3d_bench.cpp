// kinect3d_bench: the per-frame cost of the detector on VGA frames, stage by stage (p50, p99),
// next to two baselines measured in the same run on the same frames:
//   - OctoMap as usually used: PCL cloud -> OcTree::insertPointCloud -> core/shell mask on the tree
//   - PCL VoxelGrid + Euclidean clustering as the candidate finder
// and the heap allocations per frame once warm (global operator new is counted in this binary), and
// the scene map's ray integration on its worker thread.
// Pinned to one core. See README "Speed" for the command and the figures.
#include <lz4.h>
#include <octomap/OcTree.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>
#include <sched.h>
#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <new>
#include <sstream>

#include "framework_api/config.h"
#include "framework_api/install_layout.h"
#include "fusion/ball_fusion.h"
#include "fusion/measurements.h"
#include "kinect3d/ball_detector.h"
#include "kinect3d/config_io.h"
#include "kinect3d/kinect_disparity.h"
#include "kinect3d/sim/evaluation.h"
#include "kinect3d/sim/field_sensors.h"
#include "kinect3d/sim/kinect_simulator.h"
#include "matchlog/colour_codec.h"
#include "matchlog/depth_codec.h"

namespace {
std::atomic<long> g_allocations{0};   // every thread's
thread_local long t_allocations = 0;  // this thread's: the frame path's when read on the main thread
}  // namespace

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  ++t_allocations;
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace {

using Clock = std::chrono::steady_clock;
using kinect3d::DepthFrame;

double since_s(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string cpuModel() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  }
  return "an unknown CPU";
}

struct Percentiles {
  double p50_ms, p99_ms;
};
Percentiles percentiles(const std::vector<double>& seconds) {
  return {1e3 * fw::quantile(seconds, 0.5), 1e3 * fw::quantile(seconds, 0.99)};
}

// Every valid pixel in the robot frame above the floor margin: what the baselines start from.
pcl::PointCloud<pcl::PointXYZ>::Ptr fullCloud(const DepthFrame& frame, const Eigen::Isometry3d& T_R_S, double floor_m) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  const kinect3d::Intrinsics& in = frame.intrinsics;
  for (int v = 0; v < in.height; ++v) {
    for (int u = 0; u < in.width; ++u) {
      const double z = frame.at(u, v) * 0.001;
      if (z <= 0.0) continue;
      const Eigen::Vector3d p = T_R_S * in.backProject(u, v, z);
      if (p.z() >= floor_m) cloud->push_back(pcl::PointXYZ(float(p.x()), float(p.y()), float(p.z())));
    }
  }
  return cloud;
}

// The floor under any voxel detector: one pass that back-projects every valid pixel into the robot
// frame and counts it in its voxel (a dense array around the sensor), and does nothing else. Made
// as fast as it can be on baseline x86-64 (SSE2): per row, the cells of all its pixels in one loop
// the compiler vectorises (the back-projection is a lookup table per column and one vector per row:
// three multiply-adds a pixel, no division, no branch; a pixel without depth or outside the region
// goes to a spare cell), then the counting, alternating between two arrays so that neighbouring
// pixels, which mostly share a voxel, do not wait for each other's increment.
class FloorPass {
 public:
  FloorPass(double voxel_m, double max_range_m)
      : inverse_voxel_(float(1.0 / voxel_m)),
        across_(int(std::ceil(2.0 * max_range_m / voxel_m)) + 2),
        high_(int(std::ceil(kinect3d::OccupancyGrid::kMaxHeight_m / voxel_m)) + 2),
        even_counts_(std::size_t(across_) * across_ * high_ + 1),
        odd_counts_(even_counts_.size()) {}

  // Returns the number of voxels hit, so the work cannot be optimised away.
  int run(const DepthFrame& frame, const Eigen::Isometry3f& T_R_S) {
    std::fill(even_counts_.begin(), even_counts_.end(), 0);
    std::fill(odd_counts_.begin(), odd_counts_.end(), 0);
    const kinect3d::Intrinsics& in = frame.intrinsics;
    const int width = in.width;
    // In voxel units, with the region's corner at 0: origin + z (column[u] + row) for z in mm.
    const Eigen::Matrix3f R = T_R_S.linear() * (inverse_voxel_ * 0.001f);
    const Eigen::Vector3f origin(0.5f * float(across_), 0.5f * float(across_),
                                 T_R_S.translation().z() * inverse_voxel_);
    for (auto* axis : {&column_x_, &column_y_, &column_z_}) axis->resize(width);
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3f column = R.col(0) * float((u - in.cx) / in.fx);
      column_x_[u] = column.x();
      column_y_[u] = column.y();
      column_z_[u] = column.z();
    }
    cells_.resize(width);
    const float* column_x = column_x_.data();
    const float* column_y = column_y_.data();
    const float* column_z = column_z_.data();
    std::uint32_t* cells = cells_.data();
    const std::int32_t across = across_, spare = std::int32_t(even_counts_.size() - 1);
    const float across_f = float(across_), high_f = float(high_);
    const float origin_x = origin.x(), origin_y = origin.y(), origin_z = origin.z();
    for (int v = 0; v < in.height; ++v) {
      const Eigen::Vector3f row = R.col(1) * float((v - in.cy) / in.fy) + R.col(2);
      const float row_x = row.x(), row_y = row.y(), row_z = row.z();
      const std::uint16_t* depth = &frame.depth_mm[std::size_t(v) * width];
      for (int u = 0; u < width; ++u) {
        const float z_mm = float(depth[u]);
        const float x = origin_x + z_mm * (row_x + column_x[u]);
        const float y = origin_y + z_mm * (row_y + column_y[u]);
        const float z = origin_z + z_mm * (row_z + column_z[u]);
        const bool inside =
            (z_mm > 0.0f) & (x >= 0.0f) & (y >= 0.0f) & (z >= 0.0f) & (x < across_f) & (y < across_f) & (z < high_f);
        const std::int32_t cell = (std::int32_t(z) * across + std::int32_t(y)) * across + std::int32_t(x);
        cells[u] = std::uint32_t(inside ? cell : spare);
      }
      int u = 0;
      for (; u + 1 < width; u += 2) {
        ++even_counts_[cells[u]];
        ++odd_counts_[cells[u + 1]];
      }
      if (u < width) ++even_counts_[cells[u]];
    }
    int hit = 0;
    for (std::size_t i = 0; i + 1 < even_counts_.size(); ++i) hit += (even_counts_[i] | odd_counts_[i]) != 0;
    return hit;
  }

 private:
  float inverse_voxel_;
  int across_, high_;
  std::vector<std::uint32_t> even_counts_, odd_counts_;  // per voxel, the spare cell last
  std::vector<float> column_x_, column_y_, column_z_;    // each column's share of the ray, voxel units per mm
  std::vector<std::uint32_t> cells_;                     // one row's
};

// What no pass over a depth frame can beat: reading every pixel once (summed, so it is not optimised away).
std::uint64_t readEveryPixel(const DepthFrame& frame) {
  std::uint64_t sum = 0;
  for (const std::uint16_t z : frame.depth_mm) sum += z;
  return sum;
}

// Baseline 1: a fresh OcTree per frame filled by insertPointCloud (ray casting from the sensor),
// then the 3-voxel core / 5-voxel mask tested around every occupied leaf by searching the tree.
int octomapBaseline(const DepthFrame& frame, const Eigen::Isometry3d& T_R_S, double voxel_m) {
  const auto cloud = fullCloud(frame, T_R_S, 0.05);
  octomap::Pointcloud scan;
  scan.reserve(cloud->size());
  for (const auto& p : *cloud) scan.push_back(p.x, p.y, p.z);
  octomap::OcTree tree(voxel_m);
  const Eigen::Vector3d o = T_R_S.translation();
  tree.insertPointCloud(scan, octomap::point3d(float(o.x()), float(o.y()), float(o.z())), 9.5);
  auto occupied = [&](const octomap::OcTreeKey& key) {
    const octomap::OcTreeNode* node = tree.search(key);
    return node != nullptr && tree.isNodeOccupied(node);
  };
  int candidates = 0;
  for (auto leaf = tree.begin_leafs(), end = tree.end_leafs(); leaf != end; ++leaf) {
    if (!tree.isNodeOccupied(*leaf)) continue;
    const octomap::OcTreeKey centre = leaf.getKey();
    bool shell_empty = true;
    for (int dz = -2; dz <= 2 && shell_empty; ++dz) {
      for (int dy = -2; dy <= 2 && shell_empty; ++dy) {
        for (int dx = -2; dx <= 2; ++dx) {
          if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) < 2) continue;  // core
          const octomap::OcTreeKey key(centre[0] + dx, centre[1] + dy, centre[2] + dz);
          if (occupied(key)) {
            shell_empty = false;
            break;
          }
        }
      }
    }
    candidates += shell_empty;
  }
  return candidates;
}

// Baseline 2: PCL's usual candidate finder: VoxelGrid downsampling, then Euclidean clusters of
// ball size.
int pclBaseline(const DepthFrame& frame, const Eigen::Isometry3d& T_R_S) {
  const auto cloud = fullCloud(frame, T_R_S, 0.05);
  pcl::PointCloud<pcl::PointXYZ>::Ptr down(new pcl::PointCloud<pcl::PointXYZ>);
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setInputCloud(cloud);
  grid.setLeafSize(0.05f, 0.05f, 0.05f);
  grid.filter(*down);
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
  tree->setInputCloud(down);
  std::vector<pcl::PointIndices> clusters;
  pcl::EuclideanClusterExtraction<pcl::PointXYZ> extraction;
  extraction.setClusterTolerance(0.1);
  extraction.setMinClusterSize(3);
  extraction.setMaxClusterSize(100000);
  extraction.setSearchMethod(tree);
  extraction.setInputCloud(down);
  extraction.extract(clusters);
  int candidates = 0;
  for (const auto& cluster : clusters) {
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e9f), hi = -lo;
    for (const int i : cluster.indices) {
      lo = lo.cwiseMin(down->points[i].getVector3fMap());
      hi = hi.cwiseMax(down->points[i].getVector3fMap());
    }
    candidates += (hi - lo).maxCoeff() < 0.4f;
  }
  return candidates;
}

struct DetectorRun {
  std::array<std::vector<double>, kinect3d::StageTimes::kCount> stages;
  std::vector<double> total;
  std::vector<double> map_integrations;     // worker time per scene-map integration
  double allocations_per_frame = 0;         // on the frame path (this thread)
  double worker_allocations_per_frame = 0;  // by the scene map's worker (OctoMap's ray casting)
  int balls = 0;
  long occupied_voxels = 0, candidates = 0;
};

DetectorRun runDetector(const std::vector<DepthFrame>& frames, const kinect3d::DetectorConfig& config, int iterations) {
  kinect3d::BallDetector detector(config, "kinect3d");
  kinect3d::Detections detections;
  for (const DepthFrame& frame : frames) detector.detect(frame, detections);  // warm up
  DetectorRun run;
  for (auto& stage : run.stages) stage.reserve(iterations);  // so only the detector allocates below
  run.total.reserve(iterations);
  run.map_integrations.reserve(iterations);
  int integrations = detector.sceneMap()->integrations();
  const long allocations_before = g_allocations.load(), frame_allocations_before = t_allocations;
  for (int i = 0; i < iterations; ++i) {
    detector.detect(frames[i % frames.size()], detections);
    for (int s = 0; s < kinect3d::StageTimes::kCount; ++s) run.stages[s].push_back(detections.times.seconds[s]);
    run.total.push_back(detections.times.total());
    run.balls += static_cast<int>(detections.balls.size());
    run.occupied_voxels += detections.occupied_voxels;
    run.candidates += detections.candidates;
    if (detector.sceneMap()->integrations() != integrations) {
      integrations = detector.sceneMap()->integrations();
      run.map_integrations.push_back(detector.sceneMap()->lastIntegration_s());
    }
  }
  const long frame_allocations = t_allocations - frame_allocations_before;
  run.allocations_per_frame = double(frame_allocations) / iterations;
  run.worker_allocations_per_frame = double(g_allocations.load() - allocations_before - frame_allocations) / iterations;
  return run;
}

// Four teammates round the field, each sending what the team plugin sends at its default rate
// (team.rate_hz, 20 Hz): its pose, its omni camera's rays and the robots it saw, its world ball, and
// for the keeper its Kinect's balls (this robot's detections, placed in the field). Each message
// reaches this robot 0.1 s after it was sent (Wi-Fi).
using TeammateMessages = std::vector<std::pair<double, fw::TeamMessage>>;  // arrival time, message
TeammateMessages teammatesOf(const kinect3d::sim::Scene& scene,
                             const std::vector<std::pair<double, std::vector<fw::BallObservation>>>& kinect,
                             const fusion::FusionConfig& fusion_config, double rate_hz) {
  struct Mate {
    const char* name;
    double x_m, y_m, theta_rad;
    bool kinect;
  };
  const std::vector<Mate> mates = {{"keeper", 0.0, -8.5, 0.0, true},
                                   {"defender", -3.0, -4.0, 0.3, false},
                                   {"wing", 4.0, 1.0, 2.0, false},
                                   {"striker", 1.0, 5.0, 3.1, false}};
  constexpr double kArrivesAfter_s = 0.1;
  TeammateMessages feed;
  for (std::size_t m = 0; m < mates.size(); ++m) {
    kinect3d::sim::Scene view = scene;
    view.robot = kinect3d::sim::CarrierRobot{mates[m].x_m, mates[m].y_m, mates[m].theta_rad, {}, 0.0, 0.0};
    kinect3d::sim::OmniCameraModel model;
    model.false_rate_hz = 2.0;
    model.seed = 100 + m;
    const kinect3d::sim::OmniCameraSimulator camera(view, model);
    fw::RobotPose pose = view.robot.poseAt(0.0);
    fw::TeamMessage message;
    std::optional<Eigen::Vector3d> newest_F;  // its newest ball: its world ball, as a Kinect or the omni places it
    const auto send = [&](double t_s) {
      message.robot_id = static_cast<int>(m) + 2;
      message.robot_name = mates[m].name;
      pose.stamp.source_time_s = t_s;
      message.pose = pose;
      message.pose_sigma_xy_m = fusion_config.pose.sigma_xy_m;
      message.pose_sigma_theta_rad = fusion_config.pose.sigma_theta_rad;
      if (newest_F) {
        fw::FusedBall world;
        world.position_F = *newest_F;
        world.covariance_F = 0.01 * Eigen::Matrix3d::Identity();
        world.sources = {mates[m].kinect ? "kinect3d" : "omni"};
        world.stamp.source_time_s = t_s;
        message.world_ball = world;
      }
      feed.emplace_back(t_s + kArrivesAfter_s, message);
      message = fw::TeamMessage{};
    };
    double next_send_s = scene.start_time_s + 1.0 / rate_hz;
    std::size_t k = 0;
    for (int i = 0; i < camera.frameCount(); ++i) {
      const fw::OmniFrame frame = camera.frame(i);
      const double t_s = frame.stamp.source_time_s - fusion_config.omni.latency_s;
      for (; mates[m].kinect && k < kinect.size() && kinect[k].first <= t_s; ++k) {
        const fw::RobotPose own = scene.robot.poseAt(kinect[k].first - scene.start_time_s);
        for (const fw::BallObservation& ball : kinect[k].second) {
          if (!ball.followed()) continue;  // as the team plugin: a ball the colour image rejected is not sent
          message.kinect_balls.push_back(fusion::kinectBall_F(ball, own));
          newest_F = message.kinect_balls.back().position_m;
        }
      }
      for (const fw::OmniBallObservation& ball : frame.balls) {
        message.omni_rays.push_back(
            fusion::omniRay_F(ball, pose, fusion_config.omni, fusion_config.motion.radius_m, t_s));
        if (!mates[m].kinect) newest_F = pose.fieldFromRobot(ball.groundPoint_R());
      }
      message.robots_seen.clear();
      for (const fw::OmniRobotObservation& robot : frame.robots) {
        message.robots_seen.push_back(fusion::seenRobot_F(robot, pose, fusion_config.omni, t_s));
      }
      if (t_s >= next_send_s) {
        send(t_s);
        next_send_s += 1.0 / rate_hz;
      }
    }
  }
  std::sort(feed.begin(), feed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return feed;
}

// The fusion's cost per update (one Kinect or omni frame, or a teammate's message), on the detections
// of the scene's frames and its simulated omni camera (orange false balls included), fed in time
// order; with_teammates: the four of teammatesOf beside them.
struct FusionRun {
  std::vector<double> update_s;
  double busy_share = 0.0;  // of one core: every update's time over the scene's duration
};
FusionRun runFusion(const kinect3d::sim::Scene& scene, const std::vector<DepthFrame>& frames,
                    const kinect3d::DetectorConfig& detector_config, const fw::Config& config, bool with_teammates,
                    int repetitions) {
  kinect3d::BallDetector detector(detector_config, "kinect3d");
  kinect3d::Detections detections;
  std::vector<std::pair<double, std::vector<fw::BallObservation>>> kinect;
  for (const DepthFrame& frame : frames) {
    detector.detect(frame, detections);
    kinect.emplace_back(frame.source_time_s, detections.balls);
  }
  kinect3d::sim::OmniCameraModel omni_model;
  omni_model.false_rate_hz = 2.0;  // a busy field: an orange false ball most of the time
  const kinect3d::sim::OmniCameraSimulator camera(scene, omni_model);
  std::vector<fw::OmniFrame> omni;
  for (int i = 0; i < camera.frameCount(); ++i) omni.push_back(camera.frame(i));
  const fusion::FusionConfig fusion_config = fusion::readFusionConfig(config.block("fusion"));
  const TeammateMessages team =
      with_teammates ? teammatesOf(scene, kinect, fusion_config, config.block("team").getDouble("rate_hz", 0.1, 1000.0))
                     : TeammateMessages{};
  FusionRun run;
  double busy_s = 0.0;
  for (int r = 0; r < repetitions; ++r) {
    fusion::BallFusion fusion(fusion_config);
    std::size_t k = 0, o = 0, m = 0;
    while (k < kinect.size() || o < omni.size()) {
      const double kinect_s = k < kinect.size() ? kinect[k].first : 1e300;
      const double omni_s = o < omni.size() ? omni[o].stamp.source_time_s : 1e300;
      const double team_s = m < team.size() ? team[m].first : 1e300;
      const Clock::time_point start = Clock::now();
      if (team_s <= std::min(kinect_s, omni_s)) {
        fusion.addTeamMessage(team[m++].second);
      } else if (kinect_s <= omni_s) {
        fusion.addKinectFrame(kinect[k].first, kinect[k].second);
        ++k;
      } else {
        fusion.addOmniFrame(omni[o].stamp.source_time_s, omni[o].balls, omni[o].robots);
        ++o;
      }
      run.update_s.push_back(since_s(start));
      busy_s += run.update_s.back();
    }
  }
  run.busy_share = busy_s / (repetitions * scene.duration_s);
  return run;
}

// Appends a row: label, p50 and p99 in ms (precision digits), and the allocations column.
void row(std::ostringstream& table, const std::string& label, const Percentiles& p, const std::string& allocations = "",
         int precision = 3) {
  char text[512];
  std::snprintf(text, sizeof text, "| %s | %.*f ms | %.*f ms | %s |\n", label.c_str(), precision, p.p50_ms, precision,
                p.p99_ms, allocations.c_str());
  table << text;
}

std::string format(const char* pattern, double value) {
  char text[64];
  std::snprintf(text, sizeof text, pattern, value);
  return text;
}

// The detector's stages, whole frame and scene map at one voxel size; returns the whole frame's p50.
double detectorRows(std::ostringstream& table, const std::string& label, const std::vector<DepthFrame>& frames,
                    const kinect3d::DetectorConfig& config, int iterations) {
  const DetectorRun run = runDetector(frames, config, iterations);
  for (int s = 0; s < kinect3d::StageTimes::kCount; ++s) {
    row(table, "kinect3d " + label + ": " + kinect3d::StageTimes::name(s), percentiles(run.stages[s]));
  }
  const Percentiles total = percentiles(run.total);
  row(table, "**kinect3d " + label + ": whole frame**", total, format("%.1f", run.allocations_per_frame));
  row(table,
      "kinect3d " + label + ": scene map integration, on its worker thread every " +
          std::to_string(config.map.update_interval_frames) + " frames",
      percentiles(run.map_integrations),
      format("%.0f per frame (OctoMap's ray casting)", run.worker_allocations_per_frame));
  std::printf("%s: %.0f occupied voxels, %.1f candidates, %.2f balls per frame\n", label.c_str(),
              double(run.occupied_voxels) / iterations, double(run.candidates) / iterations,
              double(run.balls) / iterations);
  return total.p50_ms;
}

// The match log's colour codec, chosen by this table: size and time per frame of the colour
// images a robot logs (simulated, and the real colour frames in $KINECT3D_REAL_DATA when set), each
// from the RGB a depth plugin hands out to the RGB a reader gets back, conversions included.
std::string colourCodecTable(int repeats) {
  struct Image {
    std::string label;
    int width, height;
    std::vector<std::uint8_t> rgb;
  };
  std::vector<Image> images;
  {
    kinect3d::sim::KinectSimulator simulator(kinect3d::sim::loadScene("kick_away"));
    simulator.setColour(true);
    DepthFrame frame;
    kinect3d::sim::GroundTruth truth;
    simulator.render(15, frame, truth);
    images.push_back({"simulated (kick_away)", frame.colour->width, frame.colour->height, frame.colour->rgb});
  }
  if (const char* real = std::getenv("KINECT3D_REAL_DATA")) {
    for (const char* file :
         {"realdata/pcl_single_frames/five_people_rgb.png", "realdata/pcl_single_frames/office1_rgb.png",
          "realdata/pcl_grabber_sequences/frame_20121214T142255.814212_rgb.tiff"}) {
      const cv::Mat bgr = cv::imread(std::string(real) + "/" + file, cv::IMREAD_COLOR);
      if (bgr.empty()) continue;
      cv::Mat rgb;
      cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
      images.push_back({std::string("real: ") + file, rgb.cols, rgb.rows,
                        std::vector<std::uint8_t>(rgb.data, rgb.data + rgb.total() * 3)});
    }
  }
  // Through OpenCV, as the log wrote colour until libjpeg-turbo's own API replaced it: to OpenCV's
  // BGR order and back around its codec.
  const auto throughOpenCv = [](const char* extension, std::vector<int> parameters) {
    return [extension, parameters](const Image& image, std::vector<unsigned char>& bytes, double& encode_s,
                                   double& decode_s) {
      Clock::time_point start = Clock::now();
      cv::Mat bgr;
      cv::cvtColor(cv::Mat(image.height, image.width, CV_8UC3, const_cast<std::uint8_t*>(image.rgb.data())), bgr,
                   cv::COLOR_RGB2BGR);
      cv::imencode(extension, bgr, bytes, parameters);
      encode_s = since_s(start);
      start = Clock::now();
      cv::Mat rgb;
      cv::cvtColor(cv::imdecode(bytes, cv::IMREAD_COLOR), rgb, cv::COLOR_BGR2RGB);
      decode_s = since_s(start);
    };
  };
  const auto turboJpeg = [](int quality) {
    return [quality](const Image& image, std::vector<unsigned char>& bytes, double& encode_s, double& decode_s) {
      fw::JpegEncoder encoder(quality);  // made once per frame in the table, once per run in the log
      Clock::time_point start = Clock::now();
      const fw::JpegEncoder::Bytes jpeg = encoder.encode(image.rgb.data(), image.width, image.height);
      encode_s = since_s(start);
      bytes.assign(jpeg.data, jpeg.data + jpeg.size);
      std::vector<std::uint8_t> rgb;
      start = Clock::now();
      fw::decodeJpeg(bytes.data(), bytes.size(), image.width, image.height, rgb);
      decode_s = since_s(start);
    };
  };
  using Timed = std::function<void(const Image&, std::vector<unsigned char>&, double&, double&)>;
  const std::vector<std::pair<std::string, Timed>> codecs = {
      {"PNG, level 1, through OpenCV", throughOpenCv(".png", {cv::IMWRITE_PNG_COMPRESSION, 1})},
      {"JPEG, quality 90, through OpenCV (the log's before)", throughOpenCv(".jpg", {cv::IMWRITE_JPEG_QUALITY, 90})},
      {"JPEG, quality 75, libjpeg-turbo from RGB", turboJpeg(75)},
      {"JPEG, quality 90, libjpeg-turbo from RGB (the log's default)", turboJpeg(90)}};
  std::ostringstream table;
  table << "| image | codec | size | encode p50 | decode p50 |\n|---|---|---|---|---|\n";
  for (const Image& image : images) {
    for (const auto& [name, timed] : codecs) {
      std::vector<double> encode_s, decode_s;
      std::vector<unsigned char> bytes;
      for (int i = 0; i < repeats; ++i) {
        double encode = 0.0, decode = 0.0;
        timed(image, bytes, encode, decode);
        encode_s.push_back(encode);
        decode_s.push_back(decode);
      }
      table << "| " << image.label << " (" << image.width << "x" << image.height << ") | " << name << " | "
            << format("%.0f KB", bytes.size() / 1024.0) << " | " << format("%.2f ms", percentiles(encode_s).p50_ms)
            << " | " << format("%.2f ms", percentiles(decode_s).p50_ms) << " |\n";
    }
  }
  return table.str();
}

// Wilson's RVL for Kinect depth, as published (2017), for the depth codec table: runs of zeros and
// of valid pixels, each valid pixel's zigzagged difference to the previous valid one, every number
// in 4-bit groups (3 bits and a "more" bit) packed into 32-bit words.
class Rvl {
 public:
  static void encode(const std::uint16_t* depth, std::size_t pixels, std::vector<std::uint8_t>& out) {
    out.clear();
    Writer writer{out};
    std::int32_t previous = 0;
    for (std::size_t i = 0; i < pixels;) {
      const std::size_t zeros_from = i;
      while (i < pixels && depth[i] == 0) ++i;
      writer.put(std::uint32_t(i - zeros_from));
      const std::size_t valid_from = i;
      while (i < pixels && depth[i] != 0) ++i;
      writer.put(std::uint32_t(i - valid_from));
      for (std::size_t k = valid_from; k < i; ++k) {
        const std::int32_t difference = std::int32_t(depth[k]) - previous;
        writer.put((std::uint32_t(difference) << 1) ^ std::uint32_t(difference >> 31));
        previous = depth[k];
      }
    }
    writer.flush();
  }
  static void decode(const std::vector<std::uint8_t>& in, std::size_t pixels, std::vector<std::uint16_t>& depth) {
    depth.assign(pixels, 0);
    Reader reader{in.data()};
    std::int32_t previous = 0;
    for (std::size_t i = 0; i < pixels;) {
      i += reader.get();
      for (std::uint32_t valid = reader.get(); valid > 0; --valid) {
        const std::uint32_t z = reader.get();
        previous += std::int32_t(z >> 1) ^ -std::int32_t(z & 1);
        depth[i++] = std::uint16_t(previous);
      }
    }
  }

 private:
  struct Writer {
    std::vector<std::uint8_t>& out;
    std::uint32_t word = 0;
    int groups = 0;
    void put(std::uint32_t value) {
      do {
        std::uint32_t group = value & 7;
        value >>= 3;
        if (value != 0) group |= 8;
        word = (word << 4) | group;
        if (++groups == 8) flush();
      } while (value != 0);
    }
    void flush() {
      if (groups == 0) return;
      word <<= 4 * (8 - groups);
      const std::size_t at = out.size();
      out.resize(at + 4);
      std::memcpy(&out[at], &word, 4);
      word = 0;
      groups = 0;
    }
  };
  struct Reader {
    const std::uint8_t* next;
    std::uint32_t word = 0;
    int groups = 0;
    std::uint32_t get() {
      std::uint32_t value = 0;
      for (int shift = 0;; shift += 3) {
        if (groups == 0) {
          std::memcpy(&word, next, 4);
          next += 4;
          groups = 8;
        }
        const std::uint32_t group = word >> 28;
        word <<= 4;
        --groups;
        value |= (group & 7) << shift;
        if ((group & 8) == 0) return value;
      }
    }
  };
};

// The match log's depth codec, chosen by this table: size and encode and decode time per frame of
// simulated frames (busy scenes) and the real depth frames in $KINECT3D_REAL_DATA when set.
std::string depthCodecTable(int repeats) {
  struct Image {
    std::string label;
    int width, height;
    std::vector<std::uint16_t> depth;
  };
  std::vector<Image> images;
  for (const char* name : {"kick_away", "clutter", "people_no_ball_3"}) {
    kinect3d::sim::KinectSimulator simulator(kinect3d::sim::loadScene(name));
    DepthFrame frame;
    kinect3d::sim::GroundTruth truth;
    simulator.render(simulator.frameCount() / 2, frame, truth);
    images.push_back(
        {std::string("simulated: ") + name, frame.intrinsics.width, frame.intrinsics.height, frame.depth_mm});
  }
  if (const char* real = std::getenv("KINECT3D_REAL_DATA")) {
    for (const char* file :
         {"realdata/pcl_single_frames/five_people_depth_mm.png", "realdata/pcl_single_frames/office1_depth_mm.png",
          "realdata/pcl_grabber_sequences/frame_20121214T142255.814212_depth.tiff", "real-depth/tum_depth.png"}) {
      const cv::Mat image = cv::imread(std::string(real) + "/" + file, cv::IMREAD_ANYDEPTH);
      if (image.type() != CV_16UC1) continue;
      images.push_back({std::string("real: ") + file,
                        image.cols,
                        image.rows,
                        {image.ptr<std::uint16_t>(), image.ptr<std::uint16_t>() + image.total()}});
    }
    // Raw disparity: in millimetres, as a log holds it.
    const std::string nyu = std::string(real) + "/real-depth/nyu_raw_disparity.pgm";
    if (std::ifstream(nyu).good()) {
      const DepthFrame frame = kinect3d::loadRawDisparityPgm(nyu);
      images.push_back({"real: real-depth/nyu_raw_disparity.pgm, in mm", frame.intrinsics.width,
                        frame.intrinsics.height, frame.depth_mm});
    }
  }

  struct Codec {
    std::string name;
    std::function<void(const Image&, std::vector<std::uint8_t>&)> encode;
    std::function<void(const Image&, const std::vector<std::uint8_t>&, std::vector<std::uint16_t>&)> decode;
  };
  fw::DepthEncoder log_encoder, level3_encoder(fw::DepthCodec::kZstdPalette, 3),
      row_delta_encoder(fw::DepthCodec::kZstdRowDelta);
  const auto zstdEncode = [](fw::DepthEncoder& encoder) {
    return [&encoder](const Image& image, std::vector<std::uint8_t>& out) {
      const fw::DepthEncoder::Bytes bytes = encoder.encode(image.depth.data(), image.width, image.height);
      out.assign(bytes.data, bytes.data + bytes.size);
    };
  };
  const auto zstdDecode = [](fw::DepthCodec codec) {
    return [codec](const Image& image, const std::vector<std::uint8_t>& in, std::vector<std::uint16_t>& out) {
      fw::decodeDepth(codec, in.data(), in.size(), image.width, image.height, out);
    };
  };
  std::vector<std::uint16_t> residuals;
  const std::vector<Codec> codecs = {
      {"PNG, zlib level 1 (the log's to schema 4)",
       [](const Image& image, std::vector<std::uint8_t>& out) {
         cv::imencode(".png",
                      cv::Mat(image.height, image.width, CV_16UC1, const_cast<std::uint16_t*>(image.depth.data())), out,
                      {cv::IMWRITE_PNG_COMPRESSION, 1});
       },
       [](const Image& image, const std::vector<std::uint8_t>& in, std::vector<std::uint16_t>& out) {
         fw::decodeDepth(fw::DepthCodec::kPng, in.data(), in.size(), image.width, image.height, out);
       }},
      {"RVL",
       [](const Image& image, std::vector<std::uint8_t>& out) {
         Rvl::encode(image.depth.data(), image.depth.size(), out);
       },
       [](const Image& image, const std::vector<std::uint8_t>& in, std::vector<std::uint16_t>& out) {
         Rvl::decode(in, image.depth.size(), out);
       }},
      {"lz4 on row deltas",
       [&residuals](const Image& image, std::vector<std::uint8_t>& out) {
         residuals.resize(image.depth.size());
         fw::rowDeltaResiduals(image.depth.data(), image.width, image.height, residuals.data());
         const int raw = int(residuals.size() * 2);
         out.resize(LZ4_compressBound(raw));
         out.resize(LZ4_compress_default(reinterpret_cast<const char*>(residuals.data()),
                                         reinterpret_cast<char*>(out.data()), raw, int(out.size())));
       },
       [](const Image& image, const std::vector<std::uint8_t>& in, std::vector<std::uint16_t>& out) {
         out.resize(image.depth.size());
         LZ4_decompress_safe(reinterpret_cast<const char*>(in.data()), reinterpret_cast<char*>(out.data()),
                             int(in.size()), int(out.size() * 2));
         fw::undoRowDeltaResiduals(out.data(), image.width, image.height);
       }},
      {"zstd level 1 on row deltas (the log's, schema 5 to 9)", zstdEncode(row_delta_encoder),
       zstdDecode(fw::DepthCodec::kZstdRowDelta)},
      {"zstd level 3 on palette steps", zstdEncode(level3_encoder), zstdDecode(fw::DepthCodec::kZstdPalette)},
      {"**zstd level 1 on palette steps (the log's)**", zstdEncode(log_encoder),
       zstdDecode(fw::DepthCodec::kZstdPalette)},
  };

  std::ostringstream table;
  table << "| frame | codec | size | of PNG's | encode p50 | decode p50 |\n|---|---|---|---|---|---|\n";
  double log_worst_encode_ms = 0.0, log_worst_of_png = 0.0;  // the log's codec over every frame
  for (const Image& image : images) {
    std::size_t png_size = 0;
    for (const Codec& codec : codecs) {
      std::vector<double> encode_s, decode_s;
      std::vector<std::uint8_t> bytes;
      std::vector<std::uint16_t> decoded;
      for (int i = 0; i < repeats; ++i) {
        Clock::time_point start = Clock::now();
        codec.encode(image, bytes);
        encode_s.push_back(since_s(start));
        start = Clock::now();
        codec.decode(image, bytes, decoded);
        decode_s.push_back(since_s(start));
      }
      if (decoded != image.depth) {
        throw std::runtime_error(codec.name + " did not give " + image.label + " back exactly");
      }
      if (png_size == 0) png_size = bytes.size();
      if (&codec == &codecs.back()) {
        log_worst_encode_ms = std::max(log_worst_encode_ms, percentiles(encode_s).p50_ms);
        log_worst_of_png = std::max(log_worst_of_png, double(bytes.size()) / png_size);
      }
      table << "| " << image.label << " | " << codec.name << " | " << format("%.0f KB", bytes.size() / 1024.0) << " | "
            << format("%.0f %%", 100.0 * bytes.size() / png_size) << " | "
            << format("%.2f ms", percentiles(encode_s).p50_ms) << " | "
            << format("%.2f ms", percentiles(decode_s).p50_ms) << " |\n";
    }
  }
  table << "\nThe log's codec on these " << images.size() << " frames: encode p50 at most "
        << format("%.2f ms", log_worst_encode_ms)
        << (log_worst_encode_ms <= 1.5 ? " (target <= 1.5 ms: met)" : " (target <= 1.5 ms: **not met**)")
        << ", size at most " << format("%.0f %%", 100.0 * log_worst_of_png) << " of PNG's"
        << (log_worst_of_png <= 1.0 ? " (target: no larger: met)" : " (target: no larger: **not met**)") << ".\n";
  return table.str();
}

// Prints a codec table and writes it to path as a page saying what made it and how.
int codecPage(const std::string& path, const char* title, const char* option, const char* how,
              const std::string& table) {
  std::printf("%s\n%s", cpuModel().c_str(), table.c_str());
  std::ofstream out(path);
  out << "# " << title << "\n\nGenerated by `KINECT3D_REAL_DATA=<folder> build/bin/kinect3d_bench " << option << " "
      << path << "` on " << cpuModel() << ", pinned to one core; " << how << "\n\n"
      << table;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Per-frame cost of the Kinect3D detector against a floor pass and OctoMap and PCL baselines."};
  std::vector<std::string> scene_names{"kick_away", "clutter"};
  std::string out_path;
  int iterations = 600, baseline_frames = 20;
  const std::string defaults_dir = fw::defaultConfigDir() + "/defaults";
  app.add_option("--scene", scene_names,
                 "Simulated scenes whose frames are timed; the first also at 0.05 m voxels, against PCL and "
                 "through the fusion")
      ->capture_default_str();
  app.add_option("--iterations", iterations, "Detector frames timed per voxel size and scene")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--baseline-frames", baseline_frames, "Frames timed per baseline (they are slow)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--out", out_path, "Also write the tables to this markdown file");
  std::string codec_out, depth_codec_out;
  app.add_option("--colour-codec", codec_out,
                 "Instead: time the match log's colour codec against others and write the table to this file");
  app.add_option("--depth-codec", depth_codec_out,
                 "Instead: time the match log's depth codec against others and write the table to this file");
  CLI11_PARSE(app, argc, argv);

  // One core, as on the robot's laptop where the other core runs the rest of the software.
  cpu_set_t one_core;
  CPU_ZERO(&one_core);
  CPU_SET(0, &one_core);
  const bool pinned = sched_setaffinity(0, sizeof one_core, &one_core) == 0;
  if (!codec_out.empty()) {
    return codecPage(codec_out, "Colour codec of the match log", "--colour-codec",
                     "50 encodes and decodes per image, each from and to RGB as the log holds it, conversions "
                     "included (Debian's OpenCV encodes JPEG with libjpeg-turbo too). Why the log uses the last: "
                     "[match-log.md](match-log.md#the-colour-codec).",
                     colourCodecTable(50));
  }
  if (!depth_codec_out.empty()) {
    return codecPage(depth_codec_out, "Depth codec of the match log", "--depth-codec",
                     "50 encodes and decodes per frame, each checked to give the frame back exactly. Simulated "
                     "frames: the middle frame of each scene. Sizes in KB of 1024 bytes; a raw VGA depth frame is "
                     "600 KB. Why the log uses the last codec: [match-log.md](match-log.md#the-depth-codec).",
                     depthCodecTable(50));
  }
  const fw::Config config = fw::Config::load(defaults_dir, "", {});

  std::ostringstream tables;
  for (std::size_t k = 0; k < scene_names.size(); ++k) {
    const kinect3d::sim::Scene scene = kinect3d::sim::loadScene(scene_names[k]);
    kinect3d::sim::KinectSimulator simulator(scene);
    std::vector<DepthFrame> frames(simulator.frameCount());
    kinect3d::sim::GroundTruth truth;
    for (int i = 0; i < simulator.frameCount(); ++i) simulator.render(i, frames[i], truth);
    kinect3d::DetectorConfig coarse = kinect3d::readDetectorConfig(config.block("kinect3d"));
    coarse.ground.pose = scene.sensor_pose;
    const Eigen::Isometry3d T_R_S = scene.sensor_pose.T_R_S();
    std::printf("Scene %s, %zu VGA frames\n", scene_names[k].c_str(), frames.size());

    std::ostringstream table;
    table << "## Scene `" << scene_names[k] << "`: " << frames.size() << " VGA frames cycled\n\n"
          << "| path | p50 | p99 | heap allocations per frame |\n|---|---|---|---|\n";
    const double ours_p50 = detectorRows(table, "0.27 m", frames, coarse, iterations);

    FloorPass floor(coarse.grid.voxel_m, coarse.points.max_range_m);
    std::vector<double> floor_s;
    int hit = 0;
    for (int i = 0; i < iterations; ++i) {
      const Clock::time_point start = Clock::now();
      hit += floor.run(frames[i % frames.size()], T_R_S.cast<float>());
      floor_s.push_back(since_s(start));
    }
    const Percentiles floor_p = percentiles(floor_s);
    row(table, "floor: back-project and voxel-hash every valid pixel, nothing else (0.27 m)", floor_p,
        format("%.0f voxels hit per frame", double(hit) / iterations));
    std::vector<double> read_s;
    std::uint64_t sum = 0;
    for (int i = 0; i < iterations; ++i) {
      const Clock::time_point start = Clock::now();
      sum += readEveryPixel(frames[i % frames.size()]);
      read_s.push_back(since_s(start));
    }
    const Percentiles read_p = percentiles(read_s);
    row(table, "memory: read every pixel of the frame once, nothing else", read_p,
        format("(%.0f m of depth summed)", double(sum) / iterations * 1e-3));

    std::vector<double> octomap_s;
    for (int i = 0; i < baseline_frames; ++i) {
      const Clock::time_point start = Clock::now();
      octomapBaseline(frames[(i * 7) % frames.size()], T_R_S, coarse.grid.voxel_m);
      octomap_s.push_back(since_s(start));
    }
    const Percentiles octomap = percentiles(octomap_s);
    row(table, "baseline: PCL cloud -> OcTree::insertPointCloud -> mask on tree (0.27 m)", octomap, "", 1);

    if (k == 0) {
      // 5 cm voxels: a 7-voxel core (35 cm) holds the ball wherever it sits, with a one-voxel shell.
      kinect3d::DetectorConfig fine = coarse;
      fine.grid.voxel_m = 0.05;
      fine.mask.core_voxels = 7;
      fine.mask.mask_voxels = 9;
      detectorRows(table, "0.05 m", frames, fine, iterations);
      std::vector<double> pcl_s;
      for (int i = 0; i < baseline_frames; ++i) {
        const Clock::time_point start = Clock::now();
        pclBaseline(frames[(i * 7) % frames.size()], T_R_S);
        pcl_s.push_back(since_s(start));
      }
      row(table, "baseline: PCL VoxelGrid (0.05 m) + Euclidean clustering", percentiles(pcl_s), "", 1);
      const FusionRun alone = runFusion(scene, frames, coarse, config, false, 20);
      row(table, "fusion: one update of the world's ball (a Kinect or omni frame, orange false balls in view)",
          percentiles(alone.update_s), format("%.2f %% of a core", 100.0 * alone.busy_share));
      const FusionRun with_team = runFusion(scene, frames, coarse, config, true, 20);
      row(table,
          "fusion with four teammates: one update (also a teammate's message: its omni rays, robots seen and world "
          "ball, the keeper's Kinect balls; 20 a second from each)",
          percentiles(with_team.update_s), format("%.2f %% of a core", 100.0 * with_team.busy_share));
    }
    table << "\nkinect3d at 0.27 m: p50 " << format("%.3f ms", ours_p50)
          << (ours_p50 <= 1.0 ? " (target <= 1 ms: met)" : " (target <= 1 ms: **not met**)") << ", "
          << format("%.0fx", octomap.p50_ms / ours_p50) << " faster than the OctoMap baseline"
          << (octomap.p50_ms / ours_p50 >= 100.0 ? " (target >= 100x: met)" : " (target >= 100x: **not met**)") << ", "
          << format("%.2f", ours_p50 / floor_p.p50_ms) << " times the floor pass"
          << (ours_p50 <= 2.0 * floor_p.p50_ms ? " (target <= 2x: met)" : " (target <= 2x: **not met**)")
          << "; the floor pass is " << format("%.1f", floor_p.p50_ms / read_p.p50_ms)
          << " times reading the frame.\n\n";
    tables << table.str();
  }

  std::printf("%s, %d detector iterations per voxel size, %d baseline frames, %s\n\n%s", cpuModel().c_str(), iterations,
              baseline_frames, pinned ? "pinned to CPU 0" : "not pinned", tables.str().c_str());
  if (!out_path.empty()) {
    std::ofstream out(out_path);
    std::string command = "build/bin/kinect3d_bench --out " + out_path;
    out << "# Detector speed\n\nGenerated by `" << command << "` on " << cpuModel() << ", pinned to one core ("
        << (pinned ? "CPU 0" : "pinning failed") << "); " << iterations
        << " detector frames per voxel size and scene after a warm-up pass, " << baseline_frames
        << " frames per baseline. Wall-clock times per frame; heap "
        << "allocations counted by a replaced global operator new, on the frame's own thread and, separately, on "
        << "the scene map's worker thread. The worker runs on the "
        << "same pinned core, so its time competes with the frames it does not belong to. The 'map' stage is what "
        << "the frame itself spends on the scene map: handing rays over every n-th frame, and waiting when the "
        << "previous integration has not finished. The floor pass is what any voxel detector pays before it "
        << "does anything: every valid pixel back-projected and counted in its voxel, written as fast as baseline "
        << "x86-64 allows (`FloorPass` in bench/kinect3d_bench.cpp); reading the frame once is the floor under "
        << "that. Both make the figures comparable between machines. The whole robot stack (every plugin, "
        << "logging, latency) is measured by tools/soak.sh (README, \"Measured speed\").\n\n"
        << tables.str();
  }
  return 0;
}
