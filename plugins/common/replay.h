// What the source plugins share: a source that is "sim:<scene>", "file:<path>" or "log:<folder>" (a
// match log), a list of stamped items played at their own pace, and the simulated world several
// hosts may share.
#pragma once

#include <cmath>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "framework_api/config.h"
#include "framework_api/log.h"
#include "framework_api/plugin.h"
#include "framework_api/replay_clock.h"
#include "matchlog/match_log.h"

namespace replay {

// Loads the items of `<block>.source` with simulate(scene), readFile(path) or, from a match log,
// every item of type Item it recorded; any error, and any other scheme, becomes a ConfigError naming
// the key and where it was set.
template <typename Item>
std::vector<Item> load(const fw::ConfigView& block,
                       const std::function<std::vector<Item>(const std::string&)>& simulate,
                       const std::function<std::vector<Item>(const std::string&)>& readFile) {
  const std::string source = block.getString("source");
  try {
    if (source.rfind("sim:", 0) == 0) return simulate(source.substr(4));
    if (source.rfind("file:", 0) == 0) return readFile(source.substr(5));
    if (source.rfind("log:", 0) == 0) {
      std::vector<Item> items;
      for (const fw::JournalEntry& entry : fw::MatchLogReader(source.substr(4)).entries()) {
        if (const Item* item = std::get_if<Item>(&entry.item)) items.push_back(*item);
      }
      return items;
    }
    throw std::runtime_error("expected sim:<scene>, file:<path> or log:<folder>");
  } catch (const std::runtime_error& e) {
    throw fw::ConfigError(block.originOf("source") + ": " + block.path() + ".source = '" + source + "': " + e.what());
  }
}

// host.sim_world_start_wall_s: when several hosts simulate one world, its time 0 (0: they do not).
inline double simWorldStart(const fw::PluginContext& context) {
  return context.robot_config->block("host").getDouble("sim_world_start_wall_s", 0.0, 1e10);
}

// The pace of the plugin's `source` (its realtime key): a simulated scene in a world shared by
// several hosts (host.sim_world_start_wall_s, its items stamped on the wall clock) keeps to the wall
// clock, anything else to the anchor the host's sources share.
inline fw::ReplayClock clockFor(const fw::PluginContext& context) {
  const bool realtime = context.config.getBool("realtime");
  const bool shared_world = simWorldStart(context) > 0.0 && context.config.getString("source").rfind("sim:", 0) == 0;
  return shared_world ? fw::ReplayClock(realtime, 0.0) : fw::ReplayClock(realtime, &context.world->replayPace());
}

// Hands out items in order, each once its source time is due on the replay clock (the one pacing
// rule: a jump in the recorded time re-bases the pace, with a warning naming the item). An item
// whose time is not finite is skipped with a warning; one whose time goes back or jumps is handed
// out all the same, since the stages after it apply the time-line rule (framework_api/time_line.h).
template <typename Item>
class Player {
 public:
  Player(std::string name, std::vector<Item> items, fw::ReplayClock clock, std::function<double(const Item&)> time_of)
      : name_(std::move(name)), items_(std::move(items)), clock_(clock), time_of_(std::move(time_of)) {}

  bool finished() const { return next_ >= items_.size(); }
  std::size_t size() const { return items_.size(); }
  // The next item if it is due (waiting up to 0.1 s for it), else nothing yet.
  std::optional<Item> next() {
    if (finished()) return std::nullopt;
    const double t_s = time_of_(items_[next_]);
    if (!std::isfinite(t_s)) {
      fw::logWarn(name_, "item " + std::to_string(next_) + " of " + std::to_string(items_.size()) +
                             " skipped: its time stamp is not finite");
      ++next_;
      return std::nullopt;
    }
    switch (clock_.waitFor(t_s)) {
      case fw::ReplayClock::Pace::kNotYet:
        return std::nullopt;
      case fw::ReplayClock::Pace::kRebased:
        fw::logWarn(name_, "item " + std::to_string(next_) + " at " + std::to_string(t_s) +
                               " s is more than a second off the pace: pacing starts again from it");
        break;
      case fw::ReplayClock::Pace::kDue:
        break;
    }
    return items_[next_++];
  }

 private:
  std::string name_;
  std::vector<Item> items_;
  fw::ReplayClock clock_;
  std::function<double(const Item&)> time_of_;
  std::size_t next_ = 0;
};

}  // namespace replay
