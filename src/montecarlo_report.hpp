#pragma once
/// @file
/// @brief The reports of the Monte Carlo study (sid_montecarlo): the terminal tables in the
/// layout of the paper's tables 2-7 (ours beside the paper's printed values), the JSON summary,
/// the CSV files of every estimate and the figures (the paper's Fig. 2 and 3, box plots).
///
/// Everything here is deterministic for a given result, except the wall-time line.

#include <Eigen/Core>
#include <algorithm>
#include <nlohmann/json.hpp>
#include <sid/study/montecarlo.hpp>
#include <sid/trajectory.hpp>
#include <string>
#include <vector>

#include "plot.hpp"

namespace sid::app {

/// @brief A noise level as short text: 1e-06 -> "1e-6", 2.5e-05 -> "2.5e-5", 0.01 -> "0.01".
std::string level_label(double sigma_q2);

/// @brief The names theta1 .. theta7.
std::vector<std::string> montecarlo_parameter_names();

/// @brief The settings header printed before the study runs (no thread count: the output must
/// not depend on it).
/// @param samples number of samples of the true trajectory.
std::string montecarlo_header(const sid::MonteCarloOptions& options, Eigen::Index samples);

/// @brief Per level: the table of sample means (ours / paper), of sample variances
/// (ours / paper, "~" marks the paper's order-of-magnitude-only entries), bias % and std %,
/// the RMS ranking of the methods and the failed runs, if any. Fits in 100 columns.
std::string montecarlo_tables(const sid::MonteCarloResult& result);

/// @brief "wall time 12.3 s (2 threads)": the one line that depends on the machine.
std::string montecarlo_wall_line(const sid::MonteCarloResult& result);

/// @brief A number, or null for NaN and infinities (which JSON has not).
nlohmann::json number_or_null(double v);

/// @brief What both studies' JSON say of one method at one level: the estimates' mean,
/// variance, bias and std (in % of the truth), standard error, RMS relative error and failures.
nlohmann::json method_summary_json(const sid::MethodSummary& summary);

/// @brief The JSON summary: {"runs", "seed", "true_theta", "levels": [{"sigma_q2", "methods":
/// {"raw": {"mean", "var", "bias_pct", "std_pct", "rms_rel_error_pct", ...}, ...}}],
/// "wall_seconds"} plus extras (sigma_tau2, threads, methods, samples, paper values).
/// Non-finite numbers become null.
nlohmann::json montecarlo_json(const sid::MonteCarloResult& result,
                               const sid::MonteCarloOptions& options, Eigen::Index samples);

/// @brief The files write_montecarlo_csv writes in its directory: "estimates.csv" (all runs,
/// long format) and one "<method>_<level>.csv" per level and method.
std::vector<std::string> montecarlo_csv_files(const sid::StudySettings& options);

/// @brief Writes every theta-hat of every run (a failed run's row is nan):
/// - estimates.csv: level,method,run,theta1..theta7 (method by name; one row per level, method
///   and run);
/// - <method>_<level>.csv: run,theta1..theta7, numeric only (readable by sid's CSV reader).
void write_montecarlo_csv(const std::string& dir, const sid::MonteCarloResult& result);

/// @brief The same files for any study: `names` head the estimate columns, `comments` follow
/// the first comment line ("every <what> of every run").
void write_estimates_csv(const std::string& dir, const std::vector<sid::LevelSummary>& levels,
                         const std::vector<std::string>& names,
                         const std::vector<std::string>& comments, const std::string& what);

/// @brief The files write_montecarlo_plots writes in its directory (PNG, data and script of
/// every figure).
std::vector<std::string> montecarlo_plot_files();

/// @brief The level index whose noise the figures 2 and 3 show: the index of sigma_q2 = 1e-6 in
/// the levels if it is there, else 1 (its index in the default levels), so the figures show the
/// noise of run 0 at 1e-6 of the study (or of the default study).
std::size_t montecarlo_figure_level_index(const sid::StudySettings& options);

/// @brief One box per level and method, named "METHOD LEVEL" (e.g. "css 1e-6"), holding
/// values_of(summary): the groups of the studies' box plots.
template <typename ValuesOf>
std::vector<BoxGroup> method_level_groups(const std::vector<sid::LevelSummary>& levels,
                                          const ValuesOf& values_of) {
  std::vector<BoxGroup> groups;
  for (const auto& l : levels)
    for (const auto& s : l.methods)
      groups.push_back(
          {std::string(sid::study_method_name(s.method)) + " " + level_label(l.sigma_q2),
           Eigen::VectorXd(values_of(s))});
  return groups;
}

/// @brief A box plot's width for its groups [pixel]: room for every group's name.
inline int box_plot_width(const BoxPlot& plot) {
  return std::max(800, 120 * static_cast<int>(plot.groups.size()) + 200);
}

/// @brief Samples y at times tk placed on the grid t (NaN elsewhere): an estimate that keeps a
/// subset of the sample times drawn against the full grid.
Eigen::VectorXd on_grid(const Eigen::VectorXd& t, const Eigen::VectorXd& tk,
                        const Eigen::VectorXd& y);

/// @brief Draws the figures: fig2_qdd1.png and fig3_qdd2.png (the paper's Fig. 2 and 3: exact,
/// CSS and filtered accelerations of run 0 at sigma_q2 = 1e-6 over 0 <= t <= 10 s, the filtered
/// method's clipped start marked), fig2_qdd1_detail.png and fig3_qdd2_detail.png (the same from
/// t = 0.25 s, where the start transient no longer sets the scale) and theta1.png .. theta7.png
/// (box plots of theta-hat by method and level, the true value as reference line).
/// @return one PlotResult per figure (a missing gnuplot is reported there, never thrown).
std::vector<PlotResult> write_montecarlo_plots(const std::string& dir,
                                               const sid::Kinematics<double>& truth,
                                               const sid::MonteCarloResult& result,
                                               const sid::MonteCarloOptions& options);

}  // namespace sid::app
