// Minimal thread-safe logging to stderr: "2026-11-21 10:00:00.123 INFO  [kinect3d] message".
// Standard output is left to a program's data (JSON lines, summaries).
#pragma once

#include <cstdint>
#include <string>

namespace fw {

enum class LogLevel { kInfo, kWarn, kError };

void log(LogLevel level, const std::string& component, const std::string& message);
// Messages below this level are not printed, in the whole process (host.log_level; info at first).
void setLeastLogLevel(LogLevel least);
inline void logInfo(const std::string& component, const std::string& message) {
  log(LogLevel::kInfo, component, message);
}
inline void logWarn(const std::string& component, const std::string& message) {
  log(LogLevel::kWarn, component, message);
}
inline void logError(const std::string& component, const std::string& message) {
  log(LogLevel::kError, component, message);
}

// Whether the count-th occurrence (from 1) of one kind of message is worth a line: the first five,
// then one in a hundred, so a failing camera or a broken clock cannot flood the log during a match.
inline bool worthLogging(std::uint64_t count) { return count <= 5 || count % 100 == 0; }

}  // namespace fw
