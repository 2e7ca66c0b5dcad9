#pragma once
/// @file
/// @brief An arm identified by sid_identify --robot, read back from its --json file: the model
/// it fitted, rebuilt on the same robot description, and its physically consistent parameters,
/// the form every tool that puts the model to work (payloads, external torques, the real-time
/// dynamics) takes.

#include <sid/model/chain_model.hpp>
#include <sid/model/transmission.hpp>

#include "robot_description.hpp"

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace sid::app {

struct IdentifiedArm {
  std::string source;  ///< the JSON file
  sid::ChainModel model;
  /// Every model parameter (ten per link, then the drive terms): the physically consistent fit,
  /// each link a real body, so that its mass matrix is positive definite everywhere.
  Eigen::VectorXd theta;
  Eigen::VectorXd cutoff_hz;  ///< the smoothing the fit used, per joint
  /// [s] How far the fit found (or was told) the torque lags the angles: each torque is paired
  /// with the angles this much earlier, in its logs and in the logs the arm is put to work on.
  double torque_delay = 0.0;
  /// The fit's residual per joint on its own logs [N m]: at the regression's samples (filtered
  /// torque) and against the log as recorded.
  Eigen::VectorXd residual_rms, residual_rms_measured;
  std::vector<std::string> warnings;  ///< e.g. real bodies that do not reproduce the estimate
  /// Per joint, what its drive can give [N m or N]: the URDF's `<limit effort>` (NaN where
  /// absent); empty for a DH table.
  Eigen::VectorXd effort_limit;
};

/// @brief Reads path (sid_identify --robot --json) for the chain of robot and its transmission
/// (joint-side: sid::Transmission(n)).
/// @throws InputError naming the file and what is wrong: not JSON, a missing key, a fit of
/// another chain or other drive terms (the parameter names differ), a consistent fit that did
/// not converge.
IdentifiedArm read_identified_arm(const std::string& path, const RobotDescription& robot,
                                  const sid::Transmission& transmission);

/// @brief The same from the JSON itself (the library's result as sid_identify writes it);
/// where names it in messages.
IdentifiedArm identified_arm(const nlohmann::json& json, const std::string& where,
                             const RobotDescription& robot, const sid::Transmission& transmission);

}  // namespace sid::app
