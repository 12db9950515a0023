#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "framework_api/config.h"
#include "scoped_temp_dir.h"

namespace {

namespace fs = std::filesystem;

// A throwaway config folder: defaults/sensor.yaml and defaults/host.yaml, plus robot files.
class ConfigTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(root_ / "defaults");
    write("defaults/host.yaml", "host:\n  robot_name: unnamed\n  plugins: []\n");
    write("defaults/sensor.yaml",
          "sensor:\n"
          "  source: sim:kick_away\n"
          "  enabled: true\n"
          "  min_points: 4\n"
          "  voxel_m: 0.27\n"
          "  pose_in_robot: ~\n"
          "  grid:\n"
          "    core_voxels: 3\n");
  }

  std::string write(const std::string& name, const std::string& text) {
    const fs::path path = root_ / name;
    std::ofstream(path) << text;
    return path.string();
  }
  fw::Config load(const std::string& robot_text, const std::vector<std::string>& overrides = {}) {
    const std::string robot = robot_text.empty() ? "" : write("robot.yaml", robot_text);
    return fw::Config::load((root_ / "defaults").string(), robot, overrides);
  }
  // The message of the ConfigError that f throws.
  template <typename F>
  std::string errorOf(F f) {
    try {
      f();
    } catch (const fw::ConfigError& e) {
      return e.what();
    }
    ADD_FAILURE() << "expected a ConfigError";
    return "";
  }
  std::string robotPath() const { return (root_ / "robot.yaml").string(); }

  ScopedTempDir temp_;
  const fs::path root_ = temp_.path();
};

TEST_F(ConfigTest, AConfigurationWithOverridesLeavesTheOneItCameFromAsItWas) {
  const fw::Config base = load("sensor:\n  voxel_m: 0.2\n");
  const fw::Config changed = base.with({"sensor.voxel_m=0.1", "sensor.grid.core_voxels=5", "host.plugins=[a, b]"});
  const fw::Config again = base.with({"sensor.min_points=9"});
  EXPECT_EQ(changed.block("sensor").getDouble("voxel_m", 0.0, 1.0), 0.1);
  EXPECT_EQ(changed.block("sensor").child("grid").getInt("core_voxels", 0, 10), 5);
  for (const fw::Config* config : {&base, &again}) {
    EXPECT_EQ(config->block("sensor").getDouble("voxel_m", 0.0, 1.0), 0.2);
    EXPECT_EQ(config->block("sensor").child("grid").getInt("core_voxels", 0, 10), 3);
    EXPECT_EQ(config->block("host").getStringList("plugins").size(), 0u);
  }
  EXPECT_EQ(again.block("sensor").getInt("min_points", 0, 10), 9);
  EXPECT_EQ(base.block("sensor").getInt("min_points", 0, 10), 4);
}

TEST_F(ConfigTest, MergesDefaultsThenRobotThenCommandLine) {
  const fw::Config config = load("sensor:\n  voxel_m: 0.2\n  min_points: 6\n", {"sensor.min_points=8"});
  const fw::ConfigView sensor = config.block("sensor");
  EXPECT_EQ(sensor.getString("source"), "sim:kick_away");         // default
  EXPECT_DOUBLE_EQ(sensor.getDouble("voxel_m", 0.01, 1.0), 0.2);  // robot file
  EXPECT_EQ(sensor.getInt("min_points", 1, 100), 8);              // command line
  EXPECT_EQ(sensor.child("grid").getInt("core_voxels", 1, 9), 3);
  EXPECT_EQ(sensor.originOf("voxel_m"), robotPath() + ":2");
  EXPECT_EQ(sensor.originOf("min_points"), "--set sensor.min_points=8");
  EXPECT_EQ(sensor.originOf("source"), (root_ / "defaults/sensor.yaml").string() + ":2");
}

TEST_F(ConfigTest, IntegerAcceptedWhereRealExpected) {
  EXPECT_DOUBLE_EQ(load("sensor:\n  voxel_m: 1\n").block("sensor").getDouble("voxel_m", 0, 2), 1.0);
}

TEST_F(ConfigTest, UnknownKeyNamesFileLineAndKey) {
  const std::string error = errorOf([&] { load("sensor:\n  voxel_size: 0.2\n"); });
  EXPECT_NE(error.find(robotPath() + ":2: unknown key 'sensor.voxel_size'"), std::string::npos) << error;
  EXPECT_NE(error.find("voxel_m"), std::string::npos) << "should list the known keys: " << error;
}

TEST_F(ConfigTest, UnknownBlockIsAnError) {
  const std::string error = errorOf([&] { load("sensr:\n  voxel_m: 0.2\n"); });
  EXPECT_NE(error.find(":1: unknown key 'sensr' (known blocks: host, sensor)"), std::string::npos) << error;
}

TEST_F(ConfigTest, WrongTypesNameTheExpectedForm) {
  EXPECT_NE(errorOf([&] {
              load("sensor:\n  min_points: 4.5\n");
            }).find(":2: sensor.min_points has the wrong type; expected an integer"),
            std::string::npos);
  EXPECT_NE(errorOf([&] {
              load("sensor:\n  enabled: maybe\n");
            }).find("sensor.enabled has the wrong type; expected true or false"),
            std::string::npos);
  EXPECT_NE(
      errorOf([&] { load("sensor:\n  voxel_m: big\n"); }).find("sensor.voxel_m has the wrong type; expected a number"),
      std::string::npos);
  EXPECT_NE(errorOf([&] {
              load("sensor:\n  grid: 3\n");
            }).find("sensor.grid has the wrong type; expected a map with keys core_voxels"),
            std::string::npos);
  EXPECT_NE(
      errorOf([&] { load("host:\n  plugins: console\n"); }).find("host.plugins has the wrong type; expected a list"),
      std::string::npos);
}

TEST_F(ConfigTest, OutOfRangeNamesOriginAndRange) {
  const fw::Config config = load("sensor:\n  voxel_m: -0.2\n");
  const std::string error = errorOf([&] { config.block("sensor").getDouble("voxel_m", 0.01, 2.0); });
  EXPECT_EQ(error, robotPath() +
                       ":2: sensor.voxel_m = -0.2 is out of range; expected a number in "
                       "[0.01, 2]");
}

TEST_F(ConfigTest, BadCommandLineOverrides) {
  EXPECT_NE(errorOf([&] { load("", {"sensor.voxel_m"}); }).find("expected key=value"), std::string::npos);
  EXPECT_NE(errorOf([&] { load("", {"sensor.nope=1"}); }).find("--set sensor.nope=1: unknown key 'sensor.nope'"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { load("", {"sensor.min_points=[1"}); }).find("not valid YAML"), std::string::npos);
}

TEST_F(ConfigTest, FileProblemsNameTheFile) {
  EXPECT_NE(errorOf([&] {
              fw::Config::load((root_ / "defaults").string(), "/nonexistent.yaml", {});
            }).find("cannot read configuration file '/nonexistent.yaml'"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { load("sensor:\n  voxel_m: [0.2\n"); }).find("YAML syntax error"), std::string::npos);
  EXPECT_NE(errorOf([&] {
              fw::Config::load("/nonexistent_dir", "", {});
            }).find("defaults folder '/nonexistent_dir' does not exist"),
            std::string::npos);
  write("defaults/extra.yaml", "other:\n  a: 1\n");
  EXPECT_NE(errorOf([&] { load(""); }).find("exactly one top-level block named 'extra'"), std::string::npos);
}

TEST_F(ConfigTest, DuplicateKeysAndBlocksNameBothLines) {
  const std::string block =
      errorOf([&] { load("sensor:\n  min_points: 5\nhost:\n  robot_name: a\nsensor:\n  voxel_m: 0.2\n"); });
  EXPECT_NE(block.find(robotPath() + ":5: duplicate key 'sensor' (first at line 1)"), std::string::npos) << block;
  const std::string key = errorOf([&] { load("sensor:\n  min_points: 5\n  voxel_m: 0.2\n  min_points: 6\n"); });
  EXPECT_NE(key.find(robotPath() + ":4: duplicate key 'min_points' (first at line 2)"), std::string::npos) << key;
}

TEST_F(ConfigTest, MissingKeyNamesTheFileOfItsBlock) {
  const fw::Config config = load("sensor:\n  min_points: 5\n");
  const std::string message = errorOf([&] { config.block("sensor").getDouble("no_such_key", 0.0, 1.0); });
  EXPECT_NE(message.find("defaults/sensor.yaml:2: sensor.no_such_key is missing"), std::string::npos) << message;
}

TEST_F(ConfigTest, OptionalBlockIsAbsentUnlessGivenAndCheckedByItsReader) {
  EXPECT_FALSE(load("").block("sensor").has("pose_in_robot"));
  const fw::Config config = load("sensor:\n  pose_in_robot:\n    z: 0.7\n    yaw: 5\n");
  const fw::ConfigView pose = config.block("sensor").child("pose_in_robot");
  EXPECT_DOUBLE_EQ(pose.getDouble("z", 0, 2), 0.7);
  const std::string error = errorOf([&] { pose.requireOnlyKeys({"x", "y", "z", "yaw_deg"}); });
  EXPECT_NE(error.find(robotPath() + ":4: sensor.pose_in_robot.yaw is an unknown key"), std::string::npos) << error;
  EXPECT_NE(errorOf([&] {
              pose.getDouble("x", -1, 1);
            }).find("sensor.pose_in_robot.x is missing; expected a number in [-1, 1]"),
            std::string::npos);
}

TEST_F(ConfigTest, ChoicesAndLists) {
  const fw::Config config = load("host:\n  plugins: [a, b]\n");
  EXPECT_EQ(config.block("host").getStringList("plugins"), (std::vector<std::string>{"a", "b"}));
  const std::string error = errorOf([&] { config.block("sensor").getChoice("source", {"openni2", "oni"}); });
  EXPECT_NE(error.find("sensor.source = 'sim:kick_away' is not allowed; expected one of 'openni2' 'oni'"),
            std::string::npos)
      << error;
}

TEST_F(ConfigTest, AFileTooLargeToBeAConfigurationIsRefusedBeforeItIsRead) {
  // A 2 MB file (a log or an image given as --robot by mistake): refused at once, naming it.
  const std::string message = errorOf([&] { load("# " + std::string(2 * 1024 * 1024, 'x') + "\n"); });
  EXPECT_NE(message.find(robotPath() + ": 2048 KB is not a configuration file (at most 1024 KB)"), std::string::npos)
      << message;
}

TEST_F(ConfigTest, AnAliasBombIsRefusedWithItsLine) {
  // Nine levels of ten aliases each: a billion values once expanded, from a few hundred bytes.
  std::string bomb = "sensor:\n  a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n";
  for (int level = 1; level <= 9; ++level) {
    const std::string previous = "*a" + std::to_string(level - 1);
    bomb += "  a" + std::to_string(level) + ": &a" + std::to_string(level) + " [";
    for (int i = 0; i < 10; ++i) bomb += (i == 0 ? "" : ", ") + previous;
    bomb += "]\n";
  }
  ASSERT_LT(bomb.size(), 600u);
  const std::string message = errorOf([&] { load(bomb); });
  EXPECT_NE(message.find(robotPath() + ":"), std::string::npos) << message;
  EXPECT_NE(message.find("more than 100000 values once its aliases are expanded"), std::string::npos) << message;
}

TEST_F(ConfigTest, DeepNestingIsRefusedWithItsLine) {
  for (const int depth : {40, 5000}) {
    SCOPED_TRACE(depth);
    std::string nested = "sensor: ";
    for (int i = 0; i < depth; ++i) nested += "[";
    for (int i = 0; i < depth; ++i) nested += "]";
    const std::string message = errorOf([&] { load(nested + "\n"); });
    EXPECT_NE(message.find(robotPath() + ":1: nested more than 32 levels deep"), std::string::npos) << message;
  }
  EXPECT_NE(errorOf([&] {
              load("", {"sensor.grid=" + std::string(50, '[') + std::string(50, ']')});
            }).find("nested more than 32 levels deep"),
            std::string::npos);
}

TEST(ProjectConfig, EveryShippedRobotFileLoads) {
  for (const auto& entry : fs::directory_iterator(std::string(PROJECT_CONFIG_DIR) + "/robots")) {
    SCOPED_TRACE(entry.path().string());
    const fw::Config config =
        fw::Config::load(std::string(PROJECT_CONFIG_DIR) + "/defaults", entry.path().string(), {});
    EXPECT_FALSE(config.block("host").getStringList("plugins").empty());
  }
}

}  // namespace
