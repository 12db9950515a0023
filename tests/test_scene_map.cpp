// The scene map alone: what OctoMap remembers across frames (free, occupied, unknown, static) from
// rays integrated on its worker thread, and the .bt file octovis opens. Built with nothing but the
// map, so that ThreadSanitizer can watch the worker (tools/sanitize.sh thread).
#include <gtest/gtest.h>

#include <octomap/OcTree.h>

#include <algorithm>

#include "kinect3d/scene_map.h"
#include "scoped_temp_dir.h"

namespace {

using kinect3d::DepthFrame;
using kinect3d::SceneMap;
using State = SceneMap::VoxelState;

constexpr double kVoxel_m = 0.27;

// A wall filling the view 5 m ahead of the sensor, whose optical frame is the map frame here.
DepthFrame wallFrame() {
  DepthFrame frame;
  frame.resize(kinect3d::Intrinsics{});
  std::fill(frame.depth_mm.begin(), frame.depth_mm.end(), 5000);
  return frame;
}

SceneMap::Config everyFrame() {
  SceneMap::Config config;
  config.voxel_m = kVoxel_m;
  config.update_interval_frames = 1;
  config.static_after_s = 1.0;
  return config;
}

TEST(SceneMap, KnowsFreeOccupiedAndUnknownFromRays) {
  SceneMap map(everyFrame(), 0.5, 9.5);
  const DepthFrame frame = wallFrame();
  map.update(frame, Eigen::Isometry3d::Identity(), 0.0);
  EXPECT_EQ(map.integrations(), 0) << "rays are in flight until the next ray frame publishes them";
  EXPECT_EQ(map.stateAt({0.0, 0.0, 2.0}), State::kUnknown);
  map.update(frame, Eigen::Isometry3d::Identity(), 0.1);
  EXPECT_EQ(map.integrations(), 1);
  EXPECT_EQ(map.stateAt({0.0, 0.0, 2.0}), State::kFree) << "rays crossed it on their way to the wall";
  EXPECT_EQ(map.stateAt({0.0, 0.0, 5.0}), State::kOccupied);
  EXPECT_EQ(map.stateAt({0.0, 0.0, 7.0}), State::kUnknown) << "behind the wall";
  EXPECT_EQ(map.stateAt({0.0, -5.0, 2.0}), State::kUnknown) << "outside the view";
}

TEST(SceneMap, SpaceOccupiedForSecondsBecomesStaticAndWhatLeavesIsForgotten) {
  SceneMap map(everyFrame(), 0.5, 9.5);
  const DepthFrame wall = wallFrame();
  DepthFrame far = wallFrame();
  std::fill(far.depth_mm.begin(), far.depth_mm.end(), 8000);
  int frame = 0;  // one every 0.1 s
  auto feed = [&](const DepthFrame& depth, int frames) {
    for (int i = 0; i < frames; ++i, ++frame) map.update(depth, Eigen::Isometry3d::Identity(), frame * 0.1);
  };
  feed(wall, 11);  // rays up to t = 1.0 s, published up to t = 0.9 s
  EXPECT_EQ(map.stateAt({0.0, 0.0, 5.0}), State::kOccupied) << "occupied for 0.9 s, static after 1 s";
  feed(wall, 1);
  EXPECT_EQ(map.stateAt({0.0, 0.0, 5.0}), State::kStatic);
  // The wall goes; the rays now reach 8 m and pass through where it stood. Clamped at OctoMap's
  // maximum log-odds (3.5), it takes 9 misses of -0.4 to be free again: forgotten, not for ever.
  feed(far, 5);
  EXPECT_EQ(map.stateAt({0.0, 0.0, 5.0}), State::kStatic) << "four misses do not undo a clamped hit";
  feed(far, 6);
  EXPECT_EQ(map.stateAt({0.0, 0.0, 5.0}), State::kFree);
  EXPECT_EQ(map.stateAt({0.0, 0.0, 8.0}), State::kOccupied);
  map.clear();
  EXPECT_EQ(map.stateAt({0.0, 0.0, 8.0}), State::kUnknown);
}

TEST(SceneMap, WritesABtFileOctoMapReads) {
  SceneMap map(everyFrame(), 0.5, 9.5);
  const DepthFrame frame = wallFrame();
  map.update(frame, Eigen::Isometry3d::Identity(), 0.0);
  const ScopedTempDir temp;
  const std::string path = (temp.path() / "scene.bt").string();
  map.writeBinary(path);  // waits for the rays in flight
  octomap::OcTree tree(path);
  EXPECT_DOUBLE_EQ(tree.getResolution(), kVoxel_m);
  const octomap::OcTreeNode* wall = tree.search(0.0, 0.0, 5.0);
  ASSERT_NE(wall, nullptr);
  EXPECT_TRUE(tree.isNodeOccupied(wall));
  const octomap::OcTreeNode* air = tree.search(0.0, 0.0, 2.0);
  ASSERT_NE(air, nullptr);
  EXPECT_FALSE(tree.isNodeOccupied(air));
  EXPECT_THROW(map.writeBinary("/nonexistent/scene.bt"), std::runtime_error);
}

}  // namespace
