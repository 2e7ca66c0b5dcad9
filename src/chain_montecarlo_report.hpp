#pragma once
/// @file
/// @brief The reports of the chain study (sid_montecarlo --robot): the terminal tables (per noise
/// level and method, the relative bias and standard deviation of the base parameters summarised
/// over them, and the prediction of the true torque) and the JSON summary.
///
/// Everything here is deterministic for a given result, except the wall-time line.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <sid/study/chain_montecarlo.hpp>
#include <string>
#include <vector>

namespace sid::app {

/// @brief What the study simulated, for the header and the JSON.
struct ChainStudySetup {
  std::string robot, base, tip;
  std::vector<std::string> joint_names;
  Eigen::Index samples = 0;
  double duration = 0.0, sample_time = 0.0;
  int harmonics = 0;
  double base_frequency = 0.0, q_range = 0.0, qd_max = 0.0;
};

/// @brief The settings header printed before the study runs (no thread count).
std::string chain_montecarlo_header(const sid::ChainMonteCarloOptions& options,
                                    const ChainStudySetup& setup);

/// @brief Per level, one row per method: median and largest |bias| and std over the base
/// parameters (in % of each true value; those zero in truth left out), the RMS relative error,
/// the true torque's prediction error (mean and largest over runs) and the failed runs. Then
/// the base parameters zero in truth, and the failures.
std::string chain_montecarlo_tables(const sid::ChainMonteCarloResult& result);

/// @brief "wall time 12.3 s (2 threads; ...)".
std::string chain_montecarlo_wall_line(const sid::ChainMonteCarloResult& result);

/// @brief The JSON summary: {"robot", "joint_names", "runs", "seed", "parameter_names",
/// "parameter_combinations", "true_beta", "zero_in_truth", "levels": [{"sigma_q2", "methods":
/// {"css": {"mean", "var", "bias_pct", "std_pct", "median_abs_bias_pct", "max_abs_bias_pct",
/// "median_std_pct", "max_std_pct", "rms_rel_error_pct", "torque_error_pct",
/// "mean_torque_error_pct", ...}}}], "wall_seconds", ...}; NaN becomes null.
nlohmann::json chain_montecarlo_json(const sid::ChainMonteCarloResult& result,
                                     const sid::ChainMonteCarloOptions& options,
                                     const ChainStudySetup& setup);

/// @brief Every β̂ of every run as CSV in dir, the files montecarlo_csv_files names: columns
/// beta1..betaP, the comment lines saying which combination of the model's parameters each is.
void write_chain_montecarlo_csv(const std::string& dir, const sid::ChainMonteCarloResult& result);

}  // namespace sid::app
