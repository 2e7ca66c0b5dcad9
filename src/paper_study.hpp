#pragma once
/// @file
/// @brief sid_montecarlo's study of the paper's two-link arm: its options checked as the tool
/// checks them, and the true trajectory every run adds noise to.

#include <sid/study/montecarlo.hpp>
#include <sid/trajectory.hpp>

#include <string>
#include <vector>

namespace sid::app {

/// @brief The study's options as sid_montecarlo takes them (lists as comma-separated text).
struct PaperStudyOptions {
  int runs = 30;
  std::string levels = "1e-8,1e-6,1e-4";  ///< sigma_q2 of each level [rad^2]
  double sigma_tau2 = 1e-2;
  std::string methods = "raw,filtered,css,oracle";
  std::string seed = std::to_string(sid::MonteCarloOptions().seed);
  int threads = 0;  ///< 0: every core
};

/// @brief The library's options (the IV step included for css_iv).
/// @throws InputError naming the option at fault (as --runs, --levels, ...).
sid::MonteCarloOptions paper_study_options(const PaperStudyOptions& options);

/// @brief The methods of a --methods list.
/// @throws InputError on an unknown or repeated name.
std::vector<sid::StudyMethod> parse_study_methods(const std::string& text);

/// @brief The arm under the paper's input, simulated with CVODE: the truth of every run.
/// @throws std::runtime_error if the simulation fails.
sid::Kinematics<double> paper_study_truth(const sid::TwoLinkParameters<double>& theta);

}  // namespace sid::app
