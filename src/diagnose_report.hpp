#pragma once
/// @file
/// @brief The reports of the model-discrepancy diagnosis (sid_diagnose): the terminal report,
/// the JSON summary and the figures (torque residual before/after over time, the mean residual
/// against joint velocity, simulated against measured angles before/after).

#include <nlohmann/json.hpp>
#include <sid/cvode/simulation_check.hpp>
#include <sid/diagnosis/result.hpp>
#include <string>
#include <vector>

#include "plot.hpp"

namespace sid::app {

/// @brief What the report says about the run besides the result itself.
struct DiagnoseReportContext {
  std::string input;  ///< the data file as the user named it
  Eigen::Index samples_total = 0;
  double segment = 1.0;        ///< free-simulation restart interval [s]
  double window_length = 0.5;  ///< [s]
  int noise_runs = 0;          ///< SimulationCheckOptions::noise_runs
  double threshold = 0.0;      ///< SimulationCheckOptions::threshold
  bool has_reference = false;
  double rest_velocity = 0.0;  ///< DiagnoseOptions::rest_velocity [rad/s]
  double rest_margin = 0.0;    ///< DiagnoseOptions::rest_margin [s]
};

/// @brief The readable report: noise floor, nominal fit, where model and data disagree, the
/// named effects (with the look-alike notes), not separable and not named candidates (with
/// detection limits), the before/after table per joint and, with a reference, the drift table.
std::string diagnose_report(const sid::DiagnosisResult& result, const sid::SimulationCheck& sim,
                            const DiagnoseReportContext& context);

/// @brief The JSON summary: {"effects": [{"id", "name", "estimate", "std", "value_names",
/// "units", "wald", "p_value", "information_drop", "cv_drop", "note"}], "not_separable": [{"id",
/// "name", "explanation"}], "not_named": [{"id", "name", "reason", "detection_limit"}],
/// "noise_floor": [j1, j2], "nominal": {"parameter_names", "theta", "std", "residual_rms",
/// "excess_rms", "sim_error_rms", "windows", "sim_windows"}, "final": {same}, "drift": [...]
/// (null without a reference), "simulation": {...}, "seconds", "input", "samples_used"}.
/// Non-finite numbers become null.
nlohmann::json diagnose_json(const sid::DiagnosisResult& result, const sid::SimulationCheck& sim,
                             const DiagnoseReportContext& context);

/// @brief The files write_diagnose_plots writes in its directory (PNG, data and script each).
std::vector<std::string> diagnose_plot_files();

/// @brief Draws residual_j1/j2.png (torque residual of the nominal and the final model over
/// time, flagged windows of the nominal model shaded), friction_j1/j2.png (mean residual in
/// bins of joint velocity: a Coulomb step or a Stribeck bump shows as the friction curve the
/// model lacks), sim_q1/q2.png (measured angle and the free simulations of both models) and
/// sim_error_q1/q2.png (measured - simulated angle of both models, with the band the torque
/// noise alone explains).
/// @return one PlotResult per figure (a missing gnuplot is reported there, never thrown).
std::vector<PlotResult> write_diagnose_plots(const std::string& dir,
                                             const sid::DiagnosisResult& result,
                                             const sid::SimulationCheck& sim);

/// @brief Mean of y in `bins` equal bins of x between the 1st and 99th percentile of x (the
/// extremes are few and noisy); bins with fewer than min_count points are NaN.
/// @return {bin centres, means}.
std::pair<Eigen::VectorXd, Eigen::VectorXd> binned_mean(const Eigen::Ref<const Eigen::VectorXd>& x,
                                                        const Eigen::Ref<const Eigen::VectorXd>& y,
                                                        int bins, int min_count = 5);

/// @brief One line on a free simulation: its error, or where and why it failed (the first
/// failure only, with the number of failed segments).
std::string simulation_summary(const sid::FreeSimulation& sim);

}  // namespace sid::app
