#pragma once
/// @file
/// @brief A progress bar on standard error for the tools' long work.

#include <chrono>
#include <string>

namespace sid::app {

/// @brief Draws "app: [####....] done/total unit, elapsed, about ... left" on standard error,
/// once the work has run for a second and at most every 0.1 s; nothing when disabled (a quiet
/// run, or standard error not a terminal: see stderr_is_terminal).
class ProgressBar {
 public:
  ProgressBar(std::string app, std::string unit, bool enabled);

  void update(int done, int total);
  /// Clears the bar's line, so the report that follows starts on a clean line.
  void finish();

 private:
  using Clock = std::chrono::steady_clock;
  std::string app_, unit_;
  bool enabled_;
  bool drawn_ = false;
  Clock::time_point start_, last_;
};

/// @brief Whether standard error is a terminal (a bar in a log file would only be noise).
bool stderr_is_terminal();

}  // namespace sid::app
