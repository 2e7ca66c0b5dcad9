#pragma once
/// @file
/// @brief sid_diagnose --robot: which drive terms a chain's logs support beyond its nominal
/// model, with the text report and the JSON.

#include <sid/cvode/diagnose_robot.hpp>
#include <sid/diagnose_chain.hpp>

#include "chain_identify_app.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>

namespace sid::app {

/// @brief The options of sid_diagnose that apply to a chain: the robot, runs and smoothing as
/// sid_identify --robot takes them (chain.effects: the nominal model's drive terms, default
/// viscous and armature), and what to try beyond them.
struct ChainDiagnoseAppOptions {
  ChainIdentifyAppOptions chain;
  std::string
      candidates;  ///< drive term kinds to try; empty: coulomb, offset, armature, spring, viscous
  std::optional<double> negligible_size;
  /// Smoothing by held-out torque prediction, as sid_identify --robot: --measured, or two runs
  /// or more. Else the library's automatic choice (see sid::ChainSmoothingChoice).
  bool measured = false;
};

/// @brief A chain diagnosis as sid_diagnose --robot makes it, with its report.
struct ChainDiagnoseResult {
  sid::RobotDiagnosis result;
  std::string text;     ///< the report sid_diagnose prints
  nlohmann::json json;  ///< what --json writes
  std::string html;     ///< what --report writes: one self-contained page
};

/// @brief " (vs = 0.1 rad/s)" for a Stribeck term: which of its widths was tried; "" otherwise.
std::string stribeck_width(const sid::DriveTerm& term);

/// @brief Whether what the final model leaves is at the noise: on no joint does the unexplained
/// part exceed half the torque noise.
bool remains_at_noise(const sid::ChainDiagnosis& diagnosis);

/// @brief Diagnoses loaded's runs (loaded.model: the nominal model) with the options o gives
/// (candidates, negligible_size).
/// @throws InputError naming what is wrong.
ChainDiagnoseResult diagnose_loaded(const ChainDiagnoseAppOptions& o, const LoadedChain& loaded);

/// @return the exit code; bad input throws InputError.
int diagnose_robot(const ChainDiagnoseAppOptions& options);

}  // namespace sid::app
