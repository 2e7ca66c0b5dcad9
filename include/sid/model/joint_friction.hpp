#pragma once
/// @file
/// @brief An identified model's viscous and Coulomb friction as each joint feels it: what a
/// URDF's <dynamics damping friction> and MuJoCo's damping and frictionloss hold.
///
/// A joint's own terms count as they are, and so do those of a motor that turns that joint alone:
/// sid writes a motor's terms at its joint's scale (the motor's rate over its own gear ratio,
/// sid::Transmission::motor_direction). A motor that turns several joints (a coupled wrist) has
/// no per-joint equivalent: its terms are listed apart.

#include <sid/model/chain_model.hpp>

#include <Eigen/Core>

#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief Per joint, the damping [N m s/rad or N s/m] and Coulomb friction [N m or N] of a
/// model's viscous and Coulomb terms.
struct JointFriction {
  Eigen::VectorXd damping;
  Eigen::VectorXd friction;
  /// The parameter names of viscous and Coulomb terms on motors that turn several joints.
  std::vector<std::string> coupled;
};

/// @brief The viscous and Coulomb terms of `model` at parameters theta, joint by joint (see the
/// file comment); every other drive term is left to the caller.
/// @throws std::invalid_argument if theta is not one value per parameter of the model.
inline JointFriction joint_friction(const ChainModel& model, const Eigen::VectorXd& theta) {
  if (theta.size() != model.parameters())
    throw std::invalid_argument("sid::joint_friction: theta has " + std::to_string(theta.size()) +
                                " values for the model's " + std::to_string(model.parameters()) +
                                " parameters");
  const int n = model.joints();
  JointFriction out{Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n), {}};
  const Eigen::Index first = theta.size() - static_cast<Eigen::Index>(model.terms().size());
  for (std::size_t i = 0; i < model.terms().size(); ++i) {
    const DriveTerm& term = model.terms()[i];
    if (term.kind != DriveTermKind::Viscous && term.kind != DriveTermKind::Coulomb) continue;
    const double value = theta[first + static_cast<Eigen::Index>(i)];
    if (term.on_motor &&
        (model.transmission().motor_direction(term.index).array() != 0.0).count() != 1) {
      out.coupled.push_back(model.parameter_names()[static_cast<std::size_t>(first) + i]);
      continue;
    }
    (term.kind == DriveTermKind::Viscous ? out.damping : out.friction)[term.index] += value;
  }
  return out;
}

}  // namespace sid
