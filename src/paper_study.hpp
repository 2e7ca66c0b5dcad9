#pragma once
/// @file
/// @brief sid_montecarlo's studies: the paper's two-link arm and any chain of a URDF, their
/// options checked as the tool checks them, and the true trajectory every run adds noise to.

#include <sid/study/chain_montecarlo.hpp>
#include <sid/study/montecarlo.hpp>
#include <sid/trajectory.hpp>

#include "chain_montecarlo_report.hpp"
#include "chain_simulate_app.hpp"

#include <optional>
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

/// @brief The chain study's own options (--robot and the excitation of its true run).
struct ChainStudyOptions {
  std::string robot, base, tip, hold;
  int harmonics = 5;
  double base_frequency = 0.1, q_range = 1.0, qd_max = 1.5;
  double duration = 10.0, rate = 400.0;  ///< [s], [Hz]
  /// The sensors each run is logged through (as sid_simulate's --encoder-bits,
  /// --encoder-ratio, --torque-delay).
  std::string encoder_bits, encoder_ratio;
  double torque_delay = 0.0;  ///< [s]
  /// css_tcv estimates the torque's delay within ± this [s]; unset: it pairs at no delay.
  std::optional<double> estimate_torque_delay;
};

/// @brief The library's options of the chain study: the shared ones, the chain's IV step, and
/// the paper's filters at the same cutoffs in Hz at any rate.
/// @throws InputError naming the option at fault.
sid::ChainMonteCarloOptions chain_study_options(const PaperStudyOptions& shared,
                                                const ChainStudyOptions& chain);

/// @brief The chain's true run (the URDF's arm under a random Fourier excitation drawn from
/// options.seed) and what the reports say of it.
struct ChainStudyTruth {
  SimulatedRobot simulated;
  ChainStudySetup setup;
};

/// Sets options.sensors, which need the chain's joints.
/// @throws InputError as simulate_robot_truth, and naming a sensor option at fault.
ChainStudyTruth chain_study_truth(const ChainStudyOptions& chain,
                                  sid::ChainMonteCarloOptions& options);

}  // namespace sid::app
