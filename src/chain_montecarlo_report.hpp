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
#include <sid/trajectory.hpp>
#include <string>
#include <vector>

#include "plot.hpp"

namespace sid::app {

/// @brief What the study simulated, for the header and the JSON.
struct ChainStudySetup {
  std::string robot, base, tip;
  std::vector<std::string> joint_names;
  Eigen::Index samples = 0;
  double duration = 0.0, sample_time = 0.0;
  int harmonics = 0;
  double base_frequency = 0.0, q_range = 0.0, qd_max = 0.0;
  std::string encoder_bits, encoder_ratio;  ///< as given; empty: not quantised, on the joint
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

/// @brief The files write_chain_montecarlo_plots writes for a chain of `joints` joints and
/// `parameters` base parameters (PNG, data and script of every figure).
std::vector<std::string> chain_montecarlo_plot_files(int joints, Eigen::Index parameters);

/// @brief Draws the chain study's figures: torque_error.png (every run's error of the true
/// torque's prediction by method and level, log scale: the study's ranking at a glance),
/// qdd_j1.png .. qdd_jn.png (as the paper's Fig. 2 and 3: exact, CSS and filtered accelerations
/// of run 0 at sigma_q2 = 1e-6, over the samples every method keeps) and beta1.png .. betaP.png
/// (box plots of each base parameter's estimates by method and level, the true value as reference
/// line).
/// @return one PlotResult per figure (a missing gnuplot is reported there, never thrown).
std::vector<PlotResult> write_chain_montecarlo_plots(const std::string& dir,
                                                     const sid::ChainKinematics<double>& truth,
                                                     const sid::ChainMonteCarloResult& result,
                                                     const sid::ChainMonteCarloOptions& options,
                                                     const std::vector<std::string>& joint_names);

}  // namespace sid::app
