#pragma once
/// @file
/// @brief sid_identify --robot --window --report: the windows' report as one HTML page, with the
/// drive terms (friction, offsets, rotors) plotted over the operating time.

#include <sid/model/chain_model.hpp>

#include "windows_app.hpp"

#include <string>

namespace sid::app {

/// @brief The page: the text report, then per drive term of the model that the windows determine
/// alone (not regrouped) its estimate and ±2 std over the operating time.
std::string windows_report_html(const WindowsResult& r, const sid::ChainModel& model);

}  // namespace sid::app
