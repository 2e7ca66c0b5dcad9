#pragma once
/// @file
/// @brief The paper's two-link arm as a sid::SerialChain, and its parameters θ as a map of the
/// chain's link parameters.
///
/// The map runs one way. θ1 = Izz_1 + l1² m_2, θ2 = Izz_2, θ3 = l1 mx_2, θ4 = mx_1 + l1 m_2,
/// θ5 = mx_2, θ6 = Fv_1, θ7 = Fv_2 (Izz about each link's joint, mx along the link), so that
/// Z(q, q̇, q̈) θ(φ) = Y(q, q̇, q̈) φ whenever my_1 = my_2 = 0 and Fc_1 = Fc_2 = 0. The paper's
/// model is a relaxation of the chain's: it does not tie θ3 to l1 θ5, and it has no column for
/// a first moment across the link (my_i), which the chain's base set keeps. So θ is not a base
/// set of the chain: its closed form stays a kernel of its own, and θ(φ) is how a chain's link
/// parameters become the paper's.

#include <sid/model/chain_regressor.hpp>
#include <sid/model/serial_chain.hpp>
#include <sid/model/two_link_arm.hpp>

#include <Eigen/Core>

#include <stdexcept>
#include <string>

namespace sid {

/// @brief The paper's arm as a chain: both joints turn about z, link 1's frame has x along the
/// link (joint 2 at (l1, 0, 0)), and gravity g points along the base's x, so that q = 0 hangs
/// down as in the paper.
template <typename Scalar>
SerialChain<Scalar> two_link_chain(Scalar l1, Scalar g = Scalar(kPaperGravity)) {
  JointPlacement<Scalar> shoulder, elbow;
  elbow.before.translation = Vector3<Scalar>(l1, Scalar(0), Scalar(0));
  return SerialChain<Scalar>({shoulder, elbow}, Vector3<Scalar>(g, Scalar(0), Scalar(0)));
}

/// @brief θ of the paper's model from the two-joint chain's parameters (chain_parameter_names
/// order: ten per link, then Fv_1, Fv_2, Fc_1, Fc_2; see the file comment).
/// @throws std::invalid_argument if phi does not have chain_parameter_count(2) entries.
template <typename Scalar>
TwoLinkParameters<Scalar> two_link_parameters_from_links(
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& phi, Scalar l1) {
  if (phi.size() != chain_parameter_count(2))
    throw std::invalid_argument("sid::two_link_parameters_from_links: phi has " +
                                std::to_string(phi.size()) + " entries, expected " +
                                std::to_string(chain_parameter_count(2)));
  const auto link = [&](int i, int k) { return phi[kLinkParameters * i + k]; };
  constexpr int m = 0, mx = 1, izz = 9;
  TwoLinkParameters<Scalar> theta;
  theta << link(0, izz) + l1 * l1 * link(1, m), link(1, izz), l1 * link(1, mx),
      link(0, mx) + l1 * link(1, m), link(1, mx), phi[2 * kLinkParameters],
      phi[2 * kLinkParameters + 1];
  return theta;
}

}  // namespace sid
