#pragma once
/// @file
/// @brief sid_identify --robot's result as one self-contained HTML page: no script, no network,
/// the plots inline SVG.

#include "chain_identify_app.hpp"

#include <string>

namespace sid::app {

/// @brief The page: the summary (runs, cutoffs, torque errors, held-out prediction), the
/// physically consistent model's cost and what was written, the warnings, the base parameters
/// with their std, the consistent links and drive terms, per joint the measured and the model's
/// torque and their difference on each fitted and held-out run, and the tool's text report.
/// It reads what the text and JSON reports read (r.json, r.text) and the runs in r.result.
std::string identify_report_html(const ChainIdentifyResult& r);

}  // namespace sid::app
