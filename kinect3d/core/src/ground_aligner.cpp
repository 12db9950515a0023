#include "kinect3d/ground_aligner.h"

#include <pcl/ModelCoefficients.h>
#include <pcl/point_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <algorithm>
#include <cmath>

#include "framework_api/log.h"

namespace kinect3d {

namespace {
// Every 8th pixel in u and v: 4800 points at VGA, plenty for a plane and fast to fit.
constexpr int kSampleStride = 8;

template <typename Visit>
void forSampledPoints(const DepthFrame& frame, double max_range_m, Visit visit) {
  const Intrinsics& in = frame.intrinsics;
  for (int v = kSampleStride / 2; v < in.height; v += kSampleStride) {
    for (int u = kSampleStride / 2; u < in.width; u += kSampleStride) {
      const double z = frame.at(u, v) * 0.001;
      if (z <= 0.0 || z > max_range_m) continue;
      visit(in.backProject(u, v, z));
    }
  }
}
}  // namespace

GroundAligner::GroundAligner(const Config& config) : config_(config) {
  if (config_.pose) T_R_S_ = config_.pose->T_R_S();
}

GroundAligner::~GroundAligner() = default;

std::optional<Eigen::Isometry3d> GroundAligner::update(const DepthFrame& frame) {
  if (config_.pose) return T_R_S_;
  if (!T_R_S_) {
    T_R_S_ = fitFloor(frame);
    frames_since_check_ = 0;
    return T_R_S_;
  }
  if (++frames_since_check_ >= config_.refit_interval_frames) {
    frames_since_check_ = 0;
    const double on_floor = inlierFraction(frame, *T_R_S_);
    if (on_floor < config_.min_inlier_fraction) {
      fw::logWarn("ground", "floor fit degraded (" + std::to_string(on_floor) + " of points on it); refitting");
      if (auto refit = fitFloor(frame)) T_R_S_ = refit;
    }
  }
  return T_R_S_;
}

double GroundAligner::inlierFraction(const DepthFrame& frame, const Eigen::Isometry3d& T_R_S) const {
  int total = 0, on_floor = 0;
  forSampledPoints(frame, config_.max_fit_range_m, [&](const Eigen::Vector3d& p_S) {
    ++total;
    on_floor += std::abs((T_R_S * p_S).z()) < config_.distance_threshold_m;
  });
  return total > 0 ? double(on_floor) / total : 0.0;
}

std::optional<Eigen::Isometry3d> GroundAligner::fitFloor(const DepthFrame& frame) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  forSampledPoints(frame, config_.max_fit_range_m, [&](const Eigen::Vector3d& p_S) {
    cloud->push_back(pcl::PointXYZ(float(p_S.x()), float(p_S.y()), float(p_S.z())));
  });
  if (cloud->size() < 100) return std::nullopt;

  // A plane whose normal is near the image's up (-y in the optical frame): walls and robot sides
  // are vertical and cannot win. The floor is the lowest such plane: a desk or a bench top can hold
  // more points than a floor seen far off, but the floor's points lie below it. So the search goes
  // on among the points below each plane found, while there are enough of them to be a floor.
  pcl::SACSegmentation<pcl::PointXYZ> segmentation;
  segmentation.setOptimizeCoefficients(true);
  segmentation.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
  segmentation.setMethodType(pcl::SAC_RANSAC);
  segmentation.setAxis(Eigen::Vector3f(0.0f, -1.0f, 0.0f));
  segmentation.setEpsAngle(config_.max_tilt_rad);
  segmentation.setDistanceThreshold(config_.distance_threshold_m);
  segmentation.setMaxIterations(200);
  const std::size_t enough = static_cast<std::size_t>(std::ceil(config_.min_inlier_fraction * cloud->size()));
  constexpr int kMaxPlanes = 4;  // a floor, and at most three tops above it
  pcl::PointIndices inliers;
  pcl::ModelCoefficients coefficients;
  std::size_t most_found = 0;  // for the message when no plane is enough
  pcl::PointCloud<pcl::PointXYZ>::Ptr searched = cloud;
  for (int plane = 0; plane < kMaxPlanes; ++plane) {
    pcl::PointIndices found;
    pcl::ModelCoefficients found_coefficients;
    segmentation.setInputCloud(searched);
    segmentation.segment(found, found_coefficients);
    most_found = std::max(most_found, found.indices.size());
    if (found_coefficients.values.size() != 4 || found.indices.size() < enough) break;
    inliers = found;
    coefficients = found_coefficients;
    // The side of the plane away from the sensor (the sensor at the origin is above any floor).
    Eigen::Vector4f plane_S(coefficients.values[0], coefficients.values[1], coefficients.values[2],
                            coefficients.values[3]);
    if (plane_S[3] < 0.0f) plane_S = -plane_S;
    plane_S /= plane_S.head<3>().norm();
    pcl::PointCloud<pcl::PointXYZ>::Ptr below(new pcl::PointCloud<pcl::PointXYZ>);
    for (const pcl::PointXYZ& point : *searched) {
      if (plane_S.dot(Eigen::Vector4f(point.x, point.y, point.z, 1.0f)) < -config_.distance_threshold_m) {
        below->push_back(point);
      }
    }
    if (below->size() < enough) break;
    searched = below;
  }
  if (coefficients.values.size() != 4 || inliers.indices.size() < enough) {
    fw::logWarn("ground", "no floor found (" + std::to_string(most_found) + " of " + std::to_string(cloud->size()) +
                              " points on the best plane)");
    return std::nullopt;
  }
  // Plane n.p + d = 0 in the sensor frame, with n pointing up (towards the sensor, d > 0).
  Eigen::Vector3d up_S(coefficients.values[0], coefficients.values[1], coefficients.values[2]);
  double d = coefficients.values[3] / up_S.norm();
  up_S.normalize();
  if (d < 0.0) {
    up_S = -up_S;
    d = -d;
  }
  // Robot axes in the sensor frame: z up; y the optical axis projected onto the floor (the floor
  // cannot tell yaw, so the robot is taken to face where the sensor looks); x = y cross z.
  const Eigen::Vector3d forward_S = (Eigen::Vector3d::UnitZ() - up_S * up_S.z()).normalized();
  Eigen::Matrix3d R_S_R;
  R_S_R.col(0) = forward_S.cross(up_S);
  R_S_R.col(1) = forward_S;
  R_S_R.col(2) = up_S;
  Eigen::Isometry3d T_R_S = Eigen::Isometry3d::Identity();
  T_R_S.linear() = R_S_R.transpose();
  T_R_S.translation() = Eigen::Vector3d(0.0, 0.0, d);  // the sensor is d above the floor
  const fw::SensorPose pose = fw::SensorPose::fromTransform(T_R_S);
  if (pose.z_m < config_.min_height_m || pose.z_m > config_.max_height_m) {
    fw::logWarn("ground", "implausible floor in frame " + std::to_string(frame.index) + ": it puts the sensor " +
                              std::to_string(pose.z_m) + " m up (expected " + std::to_string(config_.min_height_m) +
                              "-" + std::to_string(config_.max_height_m) + " m); still looking");
    return std::nullopt;
  }
  fw::logInfo("ground", "floor found: sensor " + std::to_string(pose.z_m) + " m up, pitch " +
                            std::to_string(pose.pitch_rad * 180.0 / M_PI) + " deg, roll " +
                            std::to_string(pose.roll_rad * 180.0 / M_PI) + " deg (" +
                            std::to_string(inliers.indices.size()) + " inliers)");
  return T_R_S;
}

}  // namespace kinect3d
