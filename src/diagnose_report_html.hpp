#pragma once
/// @file
/// @brief sid_diagnose --robot's result as one self-contained HTML page: no script, no network,
/// the charts inline SVG.

#include "chain_diagnose_app.hpp"

#include <string>

namespace sid::app {

/// @brief The page: the summary (runs, nominal model, smoothing), the verdict, per joint the
/// torque noise and the nominal and final models' residual (a chart and a table), the named
/// effects with their tests, the terms not named and why, the free simulations' angle errors
/// against the exact-model replicates, and the tool's text report. It reads what the text and
/// JSON reports read (r.result, r.text; not r.html).
std::string diagnose_report_html(const ChainDiagnoseAppOptions& o, const LoadedChain& loaded,
                                 const ChainDiagnoseResult& r);

}  // namespace sid::app
