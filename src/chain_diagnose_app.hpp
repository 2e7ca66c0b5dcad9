#pragma once
/// @file
/// @brief sid_diagnose --robot: which drive terms a chain's logs support beyond its nominal
/// model, with the text report and the JSON.

#include <optional>
#include <string>

#include "chain_identify_app.hpp"

namespace sid::app {

/// @brief The options of sid_diagnose that apply to a chain: the robot, runs and smoothing as
/// sid_identify --robot takes them (chain.effects: the nominal model's drive terms, default
/// viscous and armature), and what to try beyond them.
struct ChainDiagnoseAppOptions {
  ChainIdentifyAppOptions chain;
  std::string
      candidates;  ///< drive term kinds to try; empty: coulomb, offset, armature, spring, viscous
  std::optional<double> negligible_size;
};

/// @return the exit code; bad input throws InputError.
int diagnose_robot(const ChainDiagnoseAppOptions& options);

}  // namespace sid::app
