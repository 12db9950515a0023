#include "framework_api/config.h"

#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fw {

struct Config::Data {
  YAML::Node root{YAML::NodeType::Map};
  // Dotted key -> "file:line" or "--set key=value": where the value in force came from.
  std::map<std::string, std::string> origins;
};

namespace {

namespace fs = std::filesystem;

std::string joinKey(const std::string& parent, const std::string& key) {
  return parent.empty() ? key : parent + "." + key;
}

std::vector<std::string> splitKey(const std::string& dotted) {
  std::vector<std::string> parts;
  std::stringstream in(dotted);
  for (std::string part; std::getline(in, part, '.');) parts.push_back(part);
  return parts;
}

bool parseInt(const std::string& text, long& out);

// The node at a dotted path below root, or an undefined node. Navigates with reset() because
// assigning yaml-cpp nodes would rewrite the tree.
YAML::Node lookup(const YAML::Node& root, const std::string& dotted) {
  YAML::Node current;
  current.reset(root);
  if (dotted.empty()) return current;
  for (const std::string& part : splitKey(dotted)) {
    const YAML::Node& parent = current;
    long index;
    const bool by_index = parent.IsSequence() && parseInt(part, index) && index >= 0;
    if (!by_index && !parent.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
    // Copy-construct: a missing key gives a "zombie" node that reset() would refuse.
    const YAML::Node next = by_index ? parent[static_cast<std::size_t>(index)] : parent[part];
    if (!next.IsDefined()) return YAML::Node(YAML::NodeType::Undefined);
    current.reset(next);
  }
  return current;
}

// Where a value was written, for error messages.
struct Source {
  std::string label;  // file path, or "--set key=value"
  bool has_lines = true;

  std::string at(const YAML::Node& node) const {
    if (!has_lines || node.Mark().is_null()) return label;
    return label + ":" + std::to_string(node.Mark().line + 1);
  }
};

enum class ScalarKind { kBool, kInt, kReal, kString };

bool parseInt(const std::string& text, long& out) {
  if (text.empty()) return false;
  char* end = nullptr;
  errno = 0;
  out = std::strtol(text.c_str(), &end, 10);
  return errno == 0 && *end == '\0';
}

bool parseReal(const std::string& text, double& out) {
  if (text.empty()) return false;
  char* end = nullptr;
  out = std::strtod(text.c_str(), &end);
  return *end == '\0' && std::isfinite(out);
}

bool parseBool(const std::string& text, bool& out) {
  if (text == "true" || text == "True" || text == "TRUE") return out = true, true;
  if (text == "false" || text == "False" || text == "FALSE") return out = false, true;
  return false;
}

ScalarKind kindOf(const YAML::Node& scalar) {
  if (scalar.Tag() == "!") return ScalarKind::kString;  // quoted
  const std::string& text = scalar.Scalar();
  long i;
  double d;
  bool b;
  if (parseInt(text, i)) return ScalarKind::kInt;
  if (parseReal(text, d)) return ScalarKind::kReal;
  if (parseBool(text, b)) return ScalarKind::kBool;
  return ScalarKind::kString;
}

const char* describe(ScalarKind kind) {
  switch (kind) {
    case ScalarKind::kBool:
      return "true or false";
    case ScalarKind::kInt:
      return "an integer";
    case ScalarKind::kReal:
      return "a number";
    case ScalarKind::kString:
      return "a string";
  }
  return "?";
}

bool accepts(ScalarKind expected, ScalarKind given) {
  if (expected == ScalarKind::kString) return true;
  if (expected == ScalarKind::kReal) return given == ScalarKind::kReal || given == ScalarKind::kInt;
  return expected == given;
}

std::string listKeys(const YAML::Node& map) {
  std::string keys;
  for (const auto& entry : map) keys += (keys.empty() ? "" : ", ") + entry.first.as<std::string>();
  return keys.empty() ? "none" : keys;
}

void recordOrigins(const YAML::Node& node, const std::string& key, const Source& source,
                   std::map<std::string, std::string>& origins) {
  origins[key] = source.at(node);
  if (node.IsMap()) {
    for (const auto& entry : node) {
      recordOrigins(entry.second, joinKey(key, entry.first.as<std::string>()), source, origins);
    }
  } else if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i) {
      recordOrigins(node[i], joinKey(key, std::to_string(i)), source, origins);
    }
  }
}

// Merges overlay into base, where base already holds the defaults: the schema.
void mergeInto(YAML::Node& base, const YAML::Node& overlay, const std::string& path, const Source& source,
               Config::Data& data) {
  for (const auto& entry : overlay) {
    const std::string name = entry.first.as<std::string>();
    const std::string key = joinKey(path, name);
    const YAML::Node& value = entry.second;
    const YAML::Node& const_base = base;
    YAML::Node target = const_base[name];
    if (!target.IsDefined()) {
      throw ConfigError(source.at(entry.first) + ": unknown key '" + key + "'" +
                        (path.empty() ? " (known blocks: " : " (known keys here: ") + listKeys(base) + ")");
    }
    auto wrongType = [&](const std::string& expected) {
      return ConfigError(source.at(value) + ": " + key + " has the wrong type; expected " + expected);
    };
    if (target.IsNull()) {
      // Optional block: no schema here, the reader checks it.
      base[name] = YAML::Clone(value);
    } else if (target.IsMap()) {
      if (value.IsNull()) continue;  // "key:" with nothing under it keeps the defaults
      if (!value.IsMap()) throw wrongType("a map with keys " + listKeys(target));
      YAML::Node child = base[name];
      mergeInto(child, value, key, source, data);
      continue;
    } else if (target.IsSequence()) {
      if (!value.IsSequence()) throw wrongType("a list, e.g. [a, b]");
      base[name] = YAML::Clone(value);
    } else {
      const ScalarKind expected = kindOf(target);
      if (!value.IsScalar() || !accepts(expected, kindOf(value))) throw wrongType(describe(expected));
      base[name] = YAML::Clone(value);
    }
    recordOrigins(value, key, source, data.origins);
  }
}

// YAML maps may not repeat a key; yaml-cpp keeps the last silently, which would let a robot file's
// second `kinect3d:` block replace its first without a word.
void rejectDuplicateKeys(const YAML::Node& node, const std::string& label) {
  if (node.IsMap()) {
    std::map<std::string, int> lines;
    for (const auto& entry : node) {
      const std::string key = entry.first.Scalar();
      const int line = entry.first.Mark().line + 1;
      const auto [first, inserted] = lines.emplace(key, line);
      if (!inserted) {
        throw ConfigError(label + ":" + std::to_string(line) + ": duplicate key '" + key + "' (first at line " +
                          std::to_string(first->second) + ")");
      }
      rejectDuplicateKeys(entry.second, label);
    }
  } else if (node.IsSequence()) {
    for (const auto& item : node) rejectDuplicateKeys(item, label);
  }
}

// A robot's configuration is a few kilobytes and a few hundred values, nested a few levels: these
// bound what a bad file (a wrong file, an alias bomb) can cost before it is refused.
constexpr std::uintmax_t kMaxFileBytes = 1024 * 1024;
constexpr int kMaxDepth = 32;
constexpr std::size_t kMaxValues = 100000;  // with every alias expanded

// Refuses a document nested deeper than kMaxDepth, or that expands (through its aliases) to more
// than kMaxValues values, naming the line where it went too far.
void rejectOversized(const YAML::Node& node, const std::string& label, int depth, std::size_t& values) {
  const std::string where = label + ":" + std::to_string(node.Mark().line + 1) + ": ";
  if (++values > kMaxValues) {
    throw ConfigError(where + "more than " + std::to_string(kMaxValues) +
                      " values once its aliases are expanded; a robot configuration has a few hundred");
  }
  if (depth > kMaxDepth) throw ConfigError(where + "nested more than " + std::to_string(kMaxDepth) + " levels deep");
  if (node.IsMap()) {
    for (const auto& entry : node) rejectOversized(entry.second, label, depth + 1, values);
  } else if (node.IsSequence()) {
    for (const auto& item : node) rejectOversized(item, label, depth + 1, values);
  }
}

YAML::Node parseYaml(const std::string& text, const std::string& label) {
  try {
    YAML::Node node = YAML::Load(text);
    if (node.IsNull() || !node.IsDefined()) return YAML::Node(YAML::NodeType::Map);
    std::size_t values = 0;
    rejectOversized(node, label, 0, values);
    if (!node.IsMap()) throw ConfigError(label + ": expected a map of keys at the top level");
    rejectDuplicateKeys(node, label);
    return node;
  } catch (const YAML::DeepRecursion& e) {
    throw ConfigError(label + ":" + std::to_string(e.mark.line + 1) + ": nested more than " +
                      std::to_string(kMaxDepth) + " levels deep");
  } catch (const YAML::ParserException& e) {
    throw ConfigError(label + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
}

YAML::Node loadYamlFile(const std::string& path) {
  std::error_code error;
  const std::uintmax_t bytes = std::filesystem::file_size(path, error);
  if (!error && bytes > kMaxFileBytes) {
    throw ConfigError(path + ": " + std::to_string(bytes / 1024) + " KB is not a configuration file (at most " +
                      std::to_string(kMaxFileBytes / 1024) + " KB); is it the right file?");
  }
  std::ifstream in(path);
  if (!in) throw ConfigError("cannot read configuration file '" + path + "'");
  std::stringstream text;
  text << in.rdbuf();
  return parseYaml(text.str(), path);
}

// "a.b.c=value" -> {a: {b: {c: value}}}
YAML::Node overrideToYaml(const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw ConfigError("--set '" + assignment + "': expected key=value, e.g. kinect3d.grid.voxel_m=0.2");
  }
  YAML::Node value;
  try {
    value = YAML::Load(assignment.substr(eq + 1));
    std::size_t values = 0;
    rejectOversized(value, "--set '" + assignment + "'", 0, values);
  } catch (const YAML::ParserException& e) {
    throw ConfigError("--set '" + assignment + "': value is not valid YAML: " + e.msg);
  }
  const std::vector<std::string> parts = splitKey(assignment.substr(0, eq));
  for (auto part = parts.rbegin(); part != parts.rend(); ++part) {
    if (part->empty()) throw ConfigError("--set '" + assignment + "': empty key component");
    YAML::Node wrapper(YAML::NodeType::Map);
    wrapper[*part] = value;
    value = wrapper;
  }
  return value;
}

}  // namespace

Config Config::load(const std::string& defaults_dir, const std::string& robot_file,
                    const std::vector<std::string>& overrides) {
  auto data = std::make_shared<Data>();

  std::error_code error;
  if (!fs::is_directory(defaults_dir, error)) {
    throw ConfigError("defaults folder '" + defaults_dir + "' does not exist");
  }
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(defaults_dir)) {
    if (entry.path().extension() == ".yaml") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    const YAML::Node defaults = loadYamlFile(file.string());
    const std::string block = file.stem().string();
    if (defaults.size() != 1 || !defaults[block]) {
      throw ConfigError(file.string() + ": a defaults file holds exactly one top-level block named '" + block +
                        "' after the file");
    }
    data->root[block] = YAML::Clone(defaults[block]);
    recordOrigins(defaults[block], block, Source{file.string()}, data->origins);
  }

  if (!robot_file.empty()) {
    mergeInto(data->root, loadYamlFile(robot_file), "", Source{robot_file}, *data);
  }
  Config config(std::move(data));
  return config.with(overrides);
}

Config Config::with(const std::vector<std::string>& overrides) const {
  // Built from the clone, not copied and then assigned: a copied YAML::Node shares its tree, and
  // assigning to it rebinds that shared node, so the overrides below would change this
  // configuration too (and every run after it made from this one).
  auto data = std::make_shared<Data>(Data{YAML::Clone(data_->root), data_->origins});
  for (const std::string& assignment : overrides) {
    mergeInto(data->root, overrideToYaml(assignment), "", Source{"--set " + assignment, false}, *data);
  }
  return Config(std::move(data));
}

Config Config::loadDocument(const std::string& path) {
  auto data = std::make_shared<Data>();
  data->root = loadYamlFile(path);
  recordOrigins(data->root, "", Source{path}, data->origins);
  return Config(std::move(data));
}

Config Config::parseDocument(const std::string& text, const std::string& label) {
  auto data = std::make_shared<Data>();
  data->root = parseYaml(text, label);
  recordOrigins(data->root, "", Source{label}, data->origins);
  return Config(std::move(data));
}

ConfigView Config::root() const { return ConfigView(data_, ""); }

bool Config::hasBlock(const std::string& name) const { return lookup(data_->root, name).IsDefined(); }

ConfigView Config::block(const std::string& name) const {
  if (!hasBlock(name)) {
    throw ConfigError("no configuration block '" + name + "' (is config/defaults/" + name + ".yaml missing?)");
  }
  return ConfigView(data_, name);
}

ConfigView ConfigView::block(const std::string& name) const { return Config(data_).block(name); }

std::string Config::toYaml() const {
  YAML::Emitter out;
  out << data_->root;
  return out.c_str();
}

std::string ConfigView::fullKey(const std::string& key) const { return joinKey(path_, key); }

std::string ConfigView::originOf(const std::string& key) const {
  // A missing key is blamed on the nearest enclosing value that has an origin: its block's file.
  for (std::string dotted = fullKey(key);;) {
    const auto found = data_->origins.find(dotted);
    if (found != data_->origins.end()) return found->second;
    const auto dot = dotted.rfind('.');
    if (dot == std::string::npos) return "configuration";
    dotted.resize(dot);
  }
}

void ConfigView::fail(const std::string& key, const std::string& problem) const {
  throw ConfigError(originOf(key) + ": " + fullKey(key) + " " + problem);
}

bool ConfigView::has(const std::string& key) const {
  const YAML::Node node = lookup(data_->root, fullKey(key));
  return node.IsDefined() && !node.IsNull();
}

std::vector<std::string> ConfigView::keys() const {
  std::vector<std::string> names;
  const YAML::Node node = lookup(data_->root, path_);
  if (node.IsMap()) {
    for (const auto& entry : node) names.push_back(entry.first.as<std::string>());
  }
  return names;
}

std::string ConfigView::scalar(const std::string& key, const std::string& expected) const {
  const YAML::Node node = lookup(data_->root, fullKey(key));
  if (!node.IsDefined() || node.IsNull()) fail(key, "is missing; expected " + expected);
  if (!node.IsScalar()) fail(key, "has the wrong type; expected " + expected);
  return node.Scalar();
}

namespace {
std::string formatNumber(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}
}  // namespace

bool ConfigView::getBool(const std::string& key) const {
  bool value;
  const std::string text = scalar(key, "true or false");
  if (!parseBool(text, value)) fail(key, "= " + text + " has the wrong type; expected true or false");
  return value;
}

int ConfigView::getInt(const std::string& key, int min, int max) const {
  const std::string expected = "an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]";
  const std::string text = scalar(key, expected);
  long value;
  if (!parseInt(text, value)) fail(key, "= " + text + " has the wrong type; expected " + expected);
  if (value < min || value > max) fail(key, "= " + text + " is out of range; expected " + expected);
  return static_cast<int>(value);
}

double ConfigView::getDouble(const std::string& key, double min, double max) const {
  const std::string expected = "a number in [" + formatNumber(min) + ", " + formatNumber(max) + "]";
  const std::string text = scalar(key, expected);
  double value;
  if (!parseReal(text, value)) fail(key, "= " + text + " has the wrong type; expected " + expected);
  if (value < min || value > max) fail(key, "= " + text + " is out of range; expected " + expected);
  return value;
}

std::string ConfigView::getString(const std::string& key) const { return scalar(key, "a string"); }

std::string ConfigView::getChoice(const std::string& key, const std::vector<std::string>& allowed) const {
  std::string expected = "one of";
  for (const auto& choice : allowed) expected += " '" + choice + "'";
  const std::string value = scalar(key, expected);
  if (std::find(allowed.begin(), allowed.end(), value) == allowed.end()) {
    fail(key, "= '" + value + "' is not allowed; expected " + expected);
  }
  return value;
}

std::vector<std::string> ConfigView::getStringList(const std::string& key) const {
  const YAML::Node node = lookup(data_->root, fullKey(key));
  if (!node.IsDefined() || node.IsNull()) fail(key, "is missing; expected a list of strings");
  if (!node.IsSequence()) fail(key, "has the wrong type; expected a list of strings, e.g. [a, b]");
  std::vector<std::string> values;
  for (const auto& item : node) {
    if (!item.IsScalar()) fail(key, "has the wrong type; expected a list of strings, e.g. [a, b]");
    values.push_back(item.Scalar());
  }
  return values;
}

std::vector<double> ConfigView::getDoubleList(const std::string& key, std::size_t size) const {
  const std::string expected = size == 0 ? "a list of numbers" : "a list of " + std::to_string(size) + " numbers";
  const YAML::Node node = lookup(data_->root, fullKey(key));
  if (!node.IsDefined() || node.IsNull()) fail(key, "is missing; expected " + expected);
  if (!node.IsSequence() || (size != 0 && node.size() != size)) {
    fail(key, "has the wrong form; expected " + expected);
  }
  std::vector<double> values;
  for (const auto& item : node) {
    double value;
    if (!item.IsScalar() || !parseReal(item.Scalar(), value)) {
      fail(key, "has the wrong form; expected " + expected);
    }
    values.push_back(value);
  }
  return values;
}

std::size_t ConfigView::listSize(const std::string& key) const {
  const YAML::Node node = lookup(data_->root, fullKey(key));
  if (!node.IsDefined() || node.IsNull()) fail(key, "is missing; expected a list");
  if (!node.IsSequence()) fail(key, "has the wrong type; expected a list");
  return node.size();
}

std::vector<ConfigView> ConfigView::childList(const std::string& key) const {
  const YAML::Node node = lookup(data_->root, fullKey(key));
  if (!node.IsDefined() || node.IsNull()) fail(key, "is missing; expected a list of maps");
  if (!node.IsSequence()) fail(key, "has the wrong type; expected a list of maps");
  std::vector<ConfigView> children;
  for (std::size_t i = 0; i < node.size(); ++i) {
    if (!node[i].IsMap()) fail(key + "." + std::to_string(i), "has the wrong type; expected a map");
    children.push_back(ConfigView(data_, fullKey(key + "." + std::to_string(i))));
  }
  return children;
}

ConfigView ConfigView::child(const std::string& key) const {
  const YAML::Node node = lookup(data_->root, fullKey(key));
  if (!node.IsDefined() || node.IsNull()) fail(key, "is missing; expected a map");
  if (!node.IsMap()) fail(key, "has the wrong type; expected a map");
  return ConfigView(data_, fullKey(key));
}

void ConfigView::requireOnlyKeys(const std::vector<std::string>& allowed) const {
  for (const std::string& key : keys()) {
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      std::string known;
      for (const auto& name : allowed) known += (known.empty() ? "" : ", ") + name;
      fail(key, "is an unknown key (known keys here: " + known + ")");
    }
  }
}

std::string yamlQuoted(const std::string& text) {
  YAML::Emitter emitter;
  emitter << YAML::DoubleQuoted << text;
  return emitter.c_str();
}

}  // namespace fw
