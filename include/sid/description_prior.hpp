#pragma once
/// @file
/// @brief What a robot's description (a URDF) says of its dynamics, as the prior a physically
/// consistent fit stays near where the data say little: the links' inertial parameters and the
/// joints' damping and Coulomb friction.

#include <sid/model/chain_model.hpp>
#include <sid/model/urdf.hpp>

#include <Eigen/Core>

#include <stdexcept>
#include <string>

namespace sid {

/// @brief The dynamics a robot's description gives.
struct DescriptionDynamics {
  /// Ten standard parameters per moving link, base first; empty for a description without
  /// inertias (a DH table), which gives no prior.
  Eigen::VectorXd link_parameters;
  /// Per joint, `<dynamics damping>` and `<dynamics friction>`; empty: zero.
  Eigen::VectorXd damping, friction;
};

/// @brief What a URDF's chain says: its links' parameters (each carrying the bodies fixed to it)
/// and its joints' `<dynamics>`.
inline DescriptionDynamics description_dynamics(const UrdfChain& urdf) {
  const int n = urdf.chain.joints();
  DescriptionDynamics d;
  d.link_parameters = urdf.theta.head(kLinkParameters * n);
  d.damping = Eigen::VectorXd::Zero(n);
  d.friction = Eigen::VectorXd::Zero(n);
  for (int j = 0; j < n && j < static_cast<int>(urdf.joints.size()); ++j) {
    d.damping[j] = urdf.joints[static_cast<std::size_t>(j)].damping;
    d.friction[j] = urdf.joints[static_cast<std::size_t>(j)].friction;
  }
  return d;
}

/// @brief Every parameter of model as the description gives it: the links' ten each, the
/// joint-side viscous and Coulomb terms its damping and friction, 0 for the other drive terms.
/// Empty when the description has no link parameters (consistent_chain_parameters' default).
/// @throws std::invalid_argument when the sizes are not the model's.
inline Eigen::VectorXd description_prior(const ChainModel& model,
                                         const DescriptionDynamics& description) {
  const DescriptionDynamics& d = description;
  if (d.link_parameters.size() == 0) return {};
  const char* who = "sid::description_prior";
  if (d.link_parameters.size() != model.rigid_body_parameters())
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(d.link_parameters.size()) +
                                " link parameters for a model with " +
                                std::to_string(model.rigid_body_parameters()));
  const auto per_joint = [&](const Eigen::VectorXd& v) {
    return v.size() == 0 || v.size() == model.joints();
  };
  if (!per_joint(d.damping) || !per_joint(d.friction))
    throw std::invalid_argument(std::string(who) +
                                ": damping and friction take one value per joint (" +
                                std::to_string(model.joints()) + ") or none");
  Eigen::VectorXd prior = Eigen::VectorXd::Zero(model.parameters());
  prior.head(d.link_parameters.size()) = d.link_parameters;
  Eigen::Index column = model.rigid_body_parameters();
  for (const DriveTerm& t : model.terms()) {
    if (!t.on_motor && t.kind == DriveTermKind::Viscous && d.damping.size())
      prior[column] = d.damping[t.index];
    if (!t.on_motor && t.kind == DriveTermKind::Coulomb && d.friction.size())
      prior[column] = d.friction[t.index];
    ++column;
  }
  return prior;
}

}  // namespace sid
