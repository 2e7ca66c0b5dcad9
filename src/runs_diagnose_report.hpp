#pragma once
/// @file
/// @brief The report of a diagnosis of several measured runs (sid_diagnose RUN.csv...): per run
/// the floor and the fits, the named and rejected effects, what no effect explains, the free
/// simulations of the final model and the runs kept for validation.

#include <nlohmann/json.hpp>
#include <optional>
#include <sid/cvode/free_simulation.hpp>
#include <sid/diagnose_runs.hpp>
#include <sid/physical_consistency.hpp>
#include <string>
#include <vector>

#include "runs_report.hpp"

namespace sid::app {

/// The torque prediction of the final and the nominal model on one run not used in the fit.
struct RunsDiagnoseValidation {
  std::string file;
  sid::TorquePrediction final, nominal;
};

/// Everything the report shows; the app fills it, make_runs_diagnose_report only formats.
struct RunsDiagnoseReportInput {
  std::vector<RunFile> runs;
  sid::RunsDiagnoseOptions options;
  sid::RunsDiagnosis diagnosis;
  sid::PhysicalCheck physical;
  std::optional<sid::ConsistentEstimate> consistent;
  std::vector<sid::FreeSimulation> simulations;  ///< per run: the final model, open loop
  double segment = 1.0;                          ///< their restart period [s]
  std::vector<RunsDiagnoseValidation> validation;
  std::optional<double> gear_ratio;  ///< of drive 2, for the rotor coupling line
};

RunsReport make_runs_diagnose_report(const RunsDiagnoseReportInput& in);

}  // namespace sid::app
