#pragma once
/// @file
/// @brief sid_external: the torque the outside applies to an identified arm, from a log of its
/// angles and drive torques, and the contacts it makes: by the generalized-momentum observer
/// (sid::MomentumObserver, no acceleration) or by the inverse-dynamics residual.

#include <sid/external_torque.hpp>
#include <sid/trajectory.hpp>

#include "chain_identify_app.hpp"
#include "identified_arm.hpp"

#include <nlohmann/json.hpp>

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

namespace sid::app {

struct ExternalOptions {
  /// robot, base, tip, hold, transmission, columns and the log (inputs: exactly one)
  ChainIdentifyAppOptions chain;
  std::string model;  ///< sid_identify --robot --json of the arm without contact
  std::string method = "observer";
  std::optional<double> gain;  ///< the observer's rate K [1/s]; default min(300, 1 / (2 dt))
  /// The smoothing of the angles before their rates are taken [Hz], one value or one per joint;
  /// "fit": the fit's; empty: the GCV spline's of the log's angles.
  std::string cutoff;
  /// A joint is in contact where |tau_ext| exceeds this many times the fit's residual RMS on its
  /// own logs (as recorded).
  double threshold_factor = 5.0;
  double min_duration = 0.01;  ///< [s]: shorter excursions are noise
  double merge_gap = 0.05;     ///< [s]: contacts closer than this are one
  /// [s] at each end of the log where no contact is looked for: the smoothing spline's rates
  /// and accelerations are least sure there (its ends have no acceleration)
  double skip = 0.1;
  std::string output;  ///< EXT.csv: t, tau_ext1..n, contact
  std::string json;
  std::string plots;  ///< a directory for one plot per joint
  bool force = false;
};

struct ExternalResult {
  sid::ExternalTorque torque;
  std::string method;  ///< --method
  std::string text;
  nlohmann::json json;
  std::vector<std::string> warnings;  ///< the arm's, then the estimate's
};

/// @brief The external torque on run (joint-side) under the identified arm.
/// @throws InputError naming what is wrong (an unknown method, a gain the sampling cannot
/// follow, non-finite data).
ExternalResult external_torque(const IdentifiedArm& arm, const ChainRunFile& run,
                               const ExternalOptions& options);

/// @brief sid_external: reads the arm and the log, writes what the options ask.
/// @return the exit code; bad input throws InputError.
int run_external(const ExternalOptions& options, const char* app_name);

}  // namespace sid::app
