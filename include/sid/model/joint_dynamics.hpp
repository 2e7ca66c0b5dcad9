#pragma once
/// @file
/// @brief An identified model's drive terms as each joint feels them: what a URDF's <dynamics
/// damping friction> and MuJoCo's damping, frictionloss, armature and stiffness hold.
///
/// A joint's own terms count as they are, and so do those of a motor that turns that joint alone:
/// sid writes a motor's terms at its joint's scale (the motor's rate over its own gear ratio,
/// sid::Transmission::motor_direction). A motor that turns several joints (a coupled wrist) has
/// no per-joint equivalent: its terms are listed apart. A spring acts on a joint's own angle only
/// on the joint's side (a motor's angle carries the transmission's zero).

#include <sid/model/chain_model.hpp>

#include <Eigen/Core>

#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief Per joint, a model's viscous, Coulomb, armature and spring terms.
struct JointDynamics {
  Eigen::VectorXd damping;    ///< [N m s/rad or N s/m]
  Eigen::VectorXd friction;   ///< Coulomb [N m or N]
  Eigen::VectorXd armature;   ///< the rotors' inertia at the joint [kg m^2 or kg]
  Eigen::VectorXd stiffness;  ///< [N m/rad or N/m], about the joint's zero
  /// The parameter names of those terms that no joint feels alone: on motors that turn several
  /// joints, and springs on a motor.
  std::vector<std::string> coupled;
};

/// @brief The viscous, Coulomb, armature and spring terms of `model` at parameters theta, joint by
/// joint (see the file comment); every other drive term (offsets, Stribeck, Coulomb asymmetry) is
/// left to the caller.
/// @throws std::invalid_argument if theta is not one value per parameter of the model.
inline JointDynamics joint_dynamics(const ChainModel& model, const Eigen::VectorXd& theta) {
  if (theta.size() != model.parameters())
    throw std::invalid_argument("sid::joint_dynamics: theta has " + std::to_string(theta.size()) +
                                " values for the model's " + std::to_string(model.parameters()) +
                                " parameters");
  const int n = model.joints();
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  JointDynamics out{zero, zero, zero, zero, {}};
  const Eigen::Index first = theta.size() - static_cast<Eigen::Index>(model.terms().size());
  for (std::size_t i = 0; i < model.terms().size(); ++i) {
    const DriveTerm& term = model.terms()[i];
    Eigen::VectorXd* per_joint = nullptr;
    switch (term.kind) {
      case DriveTermKind::Viscous:
        per_joint = &out.damping;
        break;
      case DriveTermKind::Coulomb:
        per_joint = &out.friction;
        break;
      case DriveTermKind::Armature:
        per_joint = &out.armature;
        break;
      case DriveTermKind::Spring:
        per_joint = &out.stiffness;
        break;
      default:
        continue;
    }
    const bool alone =
        !term.on_motor ||
        (term.kind != DriveTermKind::Spring &&
         (model.transmission().motor_direction(term.index).array() != 0.0).count() == 1);
    if (!alone) {
      out.coupled.push_back(model.parameter_names()[static_cast<std::size_t>(first) + i]);
      continue;
    }
    (*per_joint)[term.index] += theta[first + static_cast<Eigen::Index>(i)];
  }
  return out;
}

}  // namespace sid
