#pragma once
/// @file
/// @brief sid_identify --robot --window: the chain identified window by window over its logs,
/// with each parameter's drift over the operating time.

#include <sid/identify_windows.hpp>

#include "chain_identify_app.hpp"

#include <nlohmann/json.hpp>

#include <string>

namespace sid::app {

/// @brief A window length from --window: a number of seconds with an optional unit (s, min, h,
/// d), or "log" for each log whole (0).
/// @throws InputError naming --window for anything else or a length that is not positive.
double parse_window(const std::string& text);

/// @brief The report sid_identify prints for windows (one line per window, then the drift of
/// every parameter) and what --json writes.
std::string windows_text(const sid::ChainWindows& w, std::size_t logs, double window);
nlohmann::json windows_json(const sid::ChainWindows& w, const sid::ChainModel& model,
                            double window);

/// @brief An identification window by window, with its report.
struct WindowsResult {
  sid::ChainWindows windows;
  std::string text;     ///< the report sid_identify prints
  nlohmann::json json;  ///< what --json writes
};

/// @brief Identifies each window of loaded's runs (options o: window, estimator, ...).
/// @throws InputError naming what is wrong with the runs or options.
WindowsResult identify_windows_loaded(const ChainIdentifyAppOptions& o, LoadedChain loaded);

/// @brief Identifies each window of the logs, prints the report and writes --json.
/// @return the exit code; bad input throws InputError.
int identify_robot_windows(const ChainIdentifyAppOptions& options, const char* app_name);

}  // namespace sid::app
