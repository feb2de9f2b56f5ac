// A minimal logging interface for the ROS-free core. By default messages go to stderr; the ROS
// layer installs a sink that forwards them to rosconsole.
#pragma once

#include <functional>
#include <sstream>
#include <string>

namespace pl_slam {

enum class LogLevel { kDebug = 0, kInfo = 1, kWarn = 2, kError = 3 };

using LogSink = std::function<void(LogLevel, const std::string&)>;

/// Replaces the process-wide sink (nullptr restores the stderr sink). Thread-safe.
void SetLogSink(LogSink sink);
/// Messages below this level are dropped (default kInfo).
void SetLogLevel(LogLevel level);
/// True when a message at this level would be emitted.
bool LogEnabled(LogLevel level);
/// Emits one message through the current sink.
void LogMessage(LogLevel level, const std::string& message);

}  // namespace pl_slam

#define PL_SLAM_LOG_(level, expr)                              \
  do {                                                         \
    if (::pl_slam::LogEnabled(level)) {                        \
      std::ostringstream pl_slam_log_stream_;                  \
      pl_slam_log_stream_ << expr;                             \
      ::pl_slam::LogMessage(level, pl_slam_log_stream_.str()); \
    }                                                          \
  } while (false)

#define PL_LOG_DEBUG(expr) PL_SLAM_LOG_(::pl_slam::LogLevel::kDebug, expr)
#define PL_LOG_INFO(expr) PL_SLAM_LOG_(::pl_slam::LogLevel::kInfo, expr)
#define PL_LOG_WARN(expr) PL_SLAM_LOG_(::pl_slam::LogLevel::kWarn, expr)
#define PL_LOG_ERROR(expr) PL_SLAM_LOG_(::pl_slam::LogLevel::kError, expr)
