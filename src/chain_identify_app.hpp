#pragma once
/// @file
/// @brief sid_identify --robot: identification of any serial chain from its robot description
/// and its logs, with the text report and the JSON.

#include <sid/chain_consistency.hpp>
#include <sid/cvode/identify_robot.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>

#include "mjcf_writer.hpp"
#include "robot_description.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace sid::app {

/// @brief The options of sid_identify that apply to a chain.
struct ChainIdentifyAppOptions {
  std::string robot;         ///< URDF or DH table
  std::string base, tip;     ///< URDF links (empty: the root and the one leaf)
  std::string hold;          ///< "joint=value,...": joints off the chain held there (URDF)
  std::string transmission;  ///< YAML; empty: the logs are joint-side
  std::vector<std::string> inputs;
  std::string columns;  ///< "t=time,q1=...,tau1=..." renames the log's columns
  std::vector<std::string> validate;
  std::optional<double> validate_fraction;  ///< fit the first 1 - f of one run, predict the rest
  /// --window: "10min", "600" [s], "2h", or "log" (each log one window); empty: one fit of all.
  std::string window;
  /// Blocks of the blocked cross-validation that judges the consistent links without held-out
  /// runs (0: the fitted equations judge); unset: the library's default.
  std::optional<int> consistency_folds;
  /// [s] How far the logs' torque lags their angles (sid::ChainIdentifyOptions::torque_delay).
  std::optional<double> torque_delay;
  /// [s] Estimate the torque's lag within ±this (sid::RobotIdentifyOptions::estimate_torque_delay).
  std::optional<double> estimate_torque_delay;
  std::string cutoff;  ///< one value or one per joint [Hz]; empty: chosen
  /// Drive term kinds added to viscous friction and armature (or, with no_default_effects, the
  /// whole list); empty: coulomb,offset; "none": rigid bodies only.
  std::string effects;
  bool no_default_effects = false;  ///< --effects lists every drive term (sid_identify)
  std::optional<double> rest_fraction;
  std::optional<double> coulomb_epsilon;
  std::optional<double> skip;
  std::string estimator = "ls";
  std::string json;
  std::string write_urdf;  ///< a copy of the URDF with the physically consistent links
  std::string write_mjcf;  ///< a MuJoCo model of the URDF with the physically consistent links
  std::string report;      ///< the result as one self-contained HTML page
  /// --write-urdf also refuses links that do not reproduce the estimate within its uncertainty.
  bool strict_consistency = false;
  bool force = false;

  sid::ConsistentLinksPolicy consistency() const {
    sid::ConsistentLinksPolicy policy;
    policy.strict = strict_consistency;
    return policy;
  }
};

/// @brief A log of the chain, joint-side.
struct ChainRunFile {
  std::string file;
  sid::ChainTrajectory<double> data;
};

/// @brief What the --robot options describe: the chain, its transmission, the model with the
/// drive terms of options.effects (else default_kinds), the identification options and the runs.
struct LoadedChain {
  RobotDescription robot;
  sid::Transmission transmission;
  bool motor_side = false;
  sid::ChainModel model;
  sid::ChainIdentifyOptions options;
  std::vector<ChainRunFile> runs;
};

/// @throws InputError naming the option or file at fault.
LoadedChain load_chain(const ChainIdentifyAppOptions& options,
                       const std::vector<sid::DriveTermKind>& default_kinds);

/// @brief A log's samples as the identification takes them: at least 4, at the joints (a
/// motor-side log through the transmission).
/// @throws InputError prefixed with name.
ChainRunFile identification_run(const std::string& name, sid::ChainTrajectory<double> run,
                                const sid::Transmission& transmission, bool motor_side);

/// @brief The log at path as loaded's runs are read (--columns of o, loaded's transmission).
/// @throws InputError naming the file.
ChainRunFile load_chain_run(const ChainIdentifyAppOptions& o, const LoadedChain& loaded,
                            const std::string& path);

/// @brief The chain and model sid_identify --robot fits: options.effects added to the default
/// drive terms (identify_drive_term_kinds), and the runs of options.inputs.
/// @throws InputError as load_chain.
LoadedChain load_identify_chain(const ChainIdentifyAppOptions& options);

/// @brief The drive term kinds sid_identify --robot fits on every joint: viscous friction and
/// armature (the terms every geared drive has), plus those --effects adds (coulomb and offset
/// when it is not given), in sid::DriveTermKind's order. "none" alone gives rigid bodies only;
/// with no_default_effects the list is exactly --effects'.
/// @throws InputError naming --effects or --no-default-effects.
std::vector<sid::DriveTermKind> identify_drive_term_kinds(const std::string& effects,
                                                          bool no_default_effects);

/// @brief What the description says of model's parameters: its links, and its joints'
/// <dynamics> damping and friction for the viscous and Coulomb terms (0 elsewhere); empty for a
/// DH table, which has no inertias. The prior a physically consistent fit stays near.
Eigen::VectorXd description_prior(const RobotDescription& robot, const sid::ChainModel& model);

/// @brief An identification as sid_identify --robot makes it, with its report.
struct ChainIdentifyResult {
  LoadedChain loaded;               ///< the robot and model (its runs are in result.fitted_runs)
  sid::RobotIdentification result;  ///< its warnings are said on stderr by the tool
  std::string text;                 ///< the report sid_identify prints
  nlohmann::json json;              ///< what --json writes
};
/// @brief The library's identification options from the tool's (estimator, validate_fraction)
/// and loaded's (smoothing, rest rule, skips; the description's prior).
/// @throws InputError naming the option at fault.
sid::RobotIdentifyOptions robot_identify_options(const ChainIdentifyAppOptions& options,
                                                 const LoadedChain& loaded);
/// @brief The report sid_identify prints and its JSON, for an identification of loaded's model.
ChainIdentifyResult identify_report(const ChainIdentifyAppOptions& options, LoadedChain loaded,
                                    sid::RobotIdentification result);
/// @brief Identifies loaded's model from its runs (options o: estimator, validate_fraction,
/// cutoff, ...) and predicts held_out.
/// @throws InputError naming what is wrong with the runs or options.
ChainIdentifyResult identify_loaded(const ChainIdentifyAppOptions& o, LoadedChain loaded,
                                    std::vector<ChainRunFile> held_out);
/// @brief The robot's URDF with the physically consistent links of r.
/// @throws InputError (prefixed with what) for a DH table, or links that are no result under
/// `policy` (sid::consistent_links_problem): those are never written.
std::string consistent_urdf(const ChainIdentifyResult& r, const std::string& what,
                            const sid::ConsistentLinksPolicy& policy = {});
/// @brief The MuJoCo model of the robot's URDF with the physically consistent links of r and
/// their joints' damping, frictionloss, armature and stiffness (paths: where meshes are found
/// and written from).
/// @throws InputError as consistent_urdf.
Mjcf consistent_mjcf(const ChainIdentifyResult& r, const std::string& what,
                     const sid::ConsistentLinksPolicy& policy, const MjcfPaths& paths);
/// @brief The directory part of a path ("" for a bare file name).
std::string fs_parent(const std::string& path);
/// @brief Refuses --write-urdf and --write-mjcf for a robot described by a DH table.
void require_model_files(const ChainIdentifyAppOptions& options, const RobotDescription& robot);
/// @brief Prints r's report and warnings (app_name: warning: ...), writes --json and
/// --write-urdf and --write-mjcf (which refuse links that are no result).
void write_identify_outputs(const ChainIdentifyAppOptions& options, const ChainIdentifyResult& r,
                            const char* app_name);
/// @brief Runs the identification and prints the report (the JSON too with --json).
/// @return the exit code; bad input throws InputError.
int identify_robot(const ChainIdentifyAppOptions& options, const char* app_name);

}  // namespace sid::app
