// Per-robot configuration: defaults < robot file < command line, merged and validated in one place.
//
// The defaults files (config/defaults/<block>.yaml, one top-level block each) are the schema: a key
// the defaults do not have is unknown, and a value must have the type of its default (an integer
// default takes integers, a real default takes any number, a boolean takes true/false, a list takes
// a list). A default of null (~) marks an optional block with no default value, such as a sensor
// pose that is found automatically when omitted; its content is checked by the code that reads it.
// Ranges are checked where values are read, through ConfigView's typed getters. Every error names
// the file and line (or the --set argument), the dotted key and the expected form.
#pragma once

#include <cmath>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace fw {

// YAML keys ending in _deg hold degrees; code works in radians.
inline double degreesToRadians(double degrees) { return degrees * M_PI / 180.0; }

class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ConfigView;

// Any text (a path, a URI) as a YAML double-quoted scalar, for an override's value.
std::string yamlQuoted(const std::string& text);

class Config {
 public:
  // Loads every defaults file in defaults_dir, merges robot_file over them (empty = none), then
  // each "dotted.key=value" override (the value is YAML: 0.2, true, [a, b], {x: 1}).
  static Config load(const std::string& defaults_dir, const std::string& robot_file,
                     const std::vector<std::string>& overrides);
  // This configuration with more overrides on top (what a command sets for its run).
  Config with(const std::vector<std::string>& overrides) const;

  // A standalone YAML document with no schema (scene files, camera files): every value keeps its
  // file:line for errors, and the reader checks keys with requireOnlyKeys and the typed getters.
  static Config loadDocument(const std::string& path);
  // The same for YAML text; label stands for the file name in errors.
  static Config parseDocument(const std::string& text, const std::string& label);
  ConfigView root() const;

  // The configuration of one top-level block, e.g. "kinect3d". Throws ConfigError if there is none.
  ConfigView block(const std::string& name) const;
  bool hasBlock(const std::string& name) const;

  // The merged configuration as YAML, for logs and --print-config.
  std::string toYaml() const;

  struct Data;  // parsed tree and where each value came from; defined in config.cpp

 private:
  friend class ConfigView;  // its block() reaches the other top-level blocks
  explicit Config(std::shared_ptr<const Data> data) : data_(std::move(data)) {}
  std::shared_ptr<const Data> data_;
};

// A read-only typed view of one subtree. Getters check type and range and throw ConfigError with
// the value's origin. Views are cheap to copy and keep the configuration alive.
class ConfigView {
 public:
  bool has(const std::string& key) const;  // present and not null
  std::vector<std::string> keys() const;   // keys of this map, in file order

  bool getBool(const std::string& key) const;
  int getInt(const std::string& key, int min, int max) const;
  double getDouble(const std::string& key, double min, double max) const;
  std::string getString(const std::string& key) const;
  // A string that must be one of `allowed`.
  std::string getChoice(const std::string& key, const std::vector<std::string>& allowed) const;
  std::vector<std::string> getStringList(const std::string& key) const;
  // A list of exactly `size` numbers (any size when size is 0), e.g. a position [x, y, z].
  std::vector<double> getDoubleList(const std::string& key, std::size_t size) const;
  ConfigView child(const std::string& key) const;
  // Another top-level block of the same configuration, for what several blocks share (the ball).
  ConfigView block(const std::string& name) const;
  // The number of entries of a list; its entries are keys "<key>.0", "<key>.1", ...
  std::size_t listSize(const std::string& key) const;
  // The maps of a list of maps, e.g. a scene's objects; their paths are "objects.0", "objects.1".
  std::vector<ConfigView> childList(const std::string& key) const;

  // For optional blocks (null default): every key of this map must be in `allowed`.
  void requireOnlyKeys(const std::vector<std::string>& allowed) const;

  // "kinect3d.grid" for the view of that block; "" for the root.
  const std::string& path() const { return path_; }
  // "config/robots/demo.yaml:12" for the value at key, or the --set argument that set it.
  std::string originOf(const std::string& key) const;

 private:
  friend class Config;
  ConfigView(std::shared_ptr<const Config::Data> data, std::string path)
      : data_(std::move(data)), path_(std::move(path)) {}
  std::string fullKey(const std::string& key) const;
  // The scalar text at key; throws "missing" or "wrong type, expected <expected>".
  std::string scalar(const std::string& key, const std::string& expected) const;
  [[noreturn]] void fail(const std::string& key, const std::string& problem) const;

  std::shared_ptr<const Config::Data> data_;
  std::string path_;
};

}  // namespace fw
