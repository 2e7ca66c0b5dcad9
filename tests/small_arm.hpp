#pragma once
// A three-joint arm for the excitation tests: standard DH, a shoulder with a vertical axis and two
// pitch joints, links of plausible mass and inertia, the drive terms sid_identify fits, and
// limits about a start away from the joints' zeros.

#include <sid/excitation_design.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/link_inertia.hpp>
#include <sid/model/serial_chain.hpp>

#include <Eigen/Core>

#include <utility>
#include <vector>

namespace sid_test {

struct SmallArm {
  sid::ChainModel model;
  Eigen::VectorXd theta;
  std::vector<Eigen::Index> columns;
  Eigen::VectorXd q0;
  sid::ExcitationLimits limits;
};

inline SmallArm small_arm() {
  const sid::SerialChain<double> chain(
      sid::DhConvention::Standard,
      {{0.0, 1.57079632679489661923, 0.3, 0.0}, {0.4, 0.0, 0.0, 0.0}, {0.3, 0.0, 0.0, 0.0}});
  const sid::Transmission direct(3);
  sid::ChainModel model(chain, {}, sid::drive_terms(sid::default_drive_term_kinds(), direct),
                        direct);
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.parameters());
  const double mass[] = {3.0, 2.0, 1.0};
  const Eigen::Vector3d com[] = {{0.0, -0.1, 0.0}, {-0.2, 0.0, 0.02}, {-0.15, 0.01, 0.0}};
  for (int i = 0; i < 3; ++i) {
    sid::LinkInertia<double> link;
    link.mass = mass[i];
    link.com = com[i];
    link.inertia_com = Eigen::Vector3d(0.02, 0.03, 0.025).asDiagonal() * mass[i] * 0.5;
    theta.segment<10>(10 * i) = sid::standard_parameters(link);
  }
  std::vector<Eigen::Index> columns = sid::chain_base_parameters(model).independent;
  SmallArm arm{std::move(model), theta, std::move(columns), Eigen::Vector3d(0.0, 0.3, -0.2), {}};
  arm.limits.q_range = Eigen::Vector3d(1.5, 1.0, 1.2);
  arm.limits.qd_max = Eigen::Vector3d(1.5, 1.5, 2.0);
  arm.limits.qdd_max = Eigen::Vector3d(3.0, 3.0, 4.0);
  arm.limits.tau_max = Eigen::Vector3d(12.0, 18.0, 6.0);
  return arm;
}

inline sid::ExcitationDesignOptions small_options() {
  sid::ExcitationDesignOptions o;
  o.harmonics = 4;
  o.base_frequency = 0.2;
  o.samples = 100;
  return o;
}

}  // namespace sid_test
