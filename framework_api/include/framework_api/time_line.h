// The one rule for a stream of time stamps (a source's frames, a stage's inputs): how the next stamp
// stands to the newest before it. Every stage that sorts, waits, paces or interpolates by time asks
// this first and reacts the same way: a stamp that is not finite is never used; one that repeats or
// goes back a little is late (the stage drops it, or puts it back in order); one that jumps,
// forwards or backwards, by more than the stage's max_jump_s starts a new time line: whatever
// history the stage holds no longer applies, and it starts again from that stamp.
#pragma once

#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

namespace fw {

// A time stamp for a message: "1700000012.3456", "1e+300", "inf", "nan".
inline std::string stampText(double t_s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.15g", t_s);
  return text;
}

// A jump in a recording's or a sensor's clock of more than this is a new time line for a source,
// and for its pacing: a second is 30 frames, far more than a stall or a late frame.
constexpr double kMaxStampJump_s = 1.0;
// Stamps closer than this are the same moment (no sensor sends ten thousand frames a second): one
// that advances by less than this repeats the newest. A fit over frames 1e-31 s apart divides by
// nearly nothing.
constexpr double kMinStampStep_s = 1e-4;

class TimeLine {
 public:
  enum class Step {
    kFirst,      // the first stamp (or the first after restart())
    kOnward,     // later than the newest, by at most max_jump_s
    kLate,       // the newest again (within kMinStampStep_s), or earlier by at most max_jump_s
    kJump,       // more than max_jump_s from the newest, either way: a new time line from here
    kNotFinite,  // NaN or infinite: never used
  };

  explicit TimeLine(double max_jump_s = kMaxStampJump_s) : max_jump_s_(max_jump_s) {}

  // Classifies t_s and, unless it is late or not finite, makes it the newest.
  Step next(double t_s) {
    if (!std::isfinite(t_s)) return Step::kNotFinite;
    previous_s_ = newest_s_;
    if (!newest_s_) {
      newest_s_ = t_s;
      return Step::kFirst;
    }
    const double step_s = t_s - *newest_s_;
    if (std::abs(step_s) > max_jump_s_) {
      newest_s_ = t_s;
      return Step::kJump;
    }
    if (step_s < kMinStampStep_s) return Step::kLate;
    newest_s_ = t_s;
    return Step::kOnward;
  }

  std::optional<double> newest_s() const { return newest_s_; }
  void restart() { newest_s_.reset(); }

  // For a warning about the stamp just classified: "jumps by -1e+06 s (from 12.3 s to -999987.7 s)".
  std::string describe(Step step, double t_s) const {
    const auto number = stampText;
    switch (step) {
      case Step::kJump:
        return "jumps by " + number(t_s - previous_s_.value_or(t_s)) + " s (from " + number(previous_s_.value_or(t_s)) +
               " s to " + number(t_s) + " s)";
      case Step::kLate:
        return "is " + number(t_s) + " s, not after the newest " + number(newest_s_.value_or(t_s)) + " s";
      case Step::kNotFinite:
        return "is not a finite time (" + number(t_s) + ")";
      default:
        return "is " + number(t_s) + " s";
    }
  }

 private:
  double max_jump_s_;
  std::optional<double> newest_s_;
  std::optional<double> previous_s_;  // the newest before the last next()
};

}  // namespace fw
