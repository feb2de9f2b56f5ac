#include "pl_slam/util/logging.h"

#include <atomic>
#include <iostream>
#include <mutex>

namespace pl_slam {
namespace {

// The sink is process-wide state by nature (like glog's); it is guarded by its own mutex and
// never held while core locks are taken, so it cannot take part in a lock-order cycle.
std::mutex& SinkMutex() {
  static std::mutex m;
  return m;
}
LogSink& Sink() {
  static LogSink sink;
  return sink;
}
std::atomic<int>& MinLevel() {
  static std::atomic<int> level{static_cast<int>(LogLevel::kInfo)};
  return level;
}
const char* LevelName(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug:
      return "DEBUG";
    case LogLevel::kInfo:
      return "INFO";
    case LogLevel::kWarn:
      return "WARN";
    case LogLevel::kError:
      return "ERROR";
  }
  return "?";
}

}  // namespace

void SetLogSink(LogSink sink) {
  std::lock_guard<std::mutex> lock(SinkMutex());
  Sink() = std::move(sink);
}

void SetLogLevel(LogLevel level) { MinLevel() = static_cast<int>(level); }

bool LogEnabled(LogLevel level) { return static_cast<int>(level) >= MinLevel().load(); }

void LogMessage(LogLevel level, const std::string& message) {
  std::lock_guard<std::mutex> lock(SinkMutex());
  if (Sink()) {
    Sink()(level, message);
  } else {
    std::cerr << "[pl_slam " << LevelName(level) << "] " << message << std::endl;
  }
}

}  // namespace pl_slam
