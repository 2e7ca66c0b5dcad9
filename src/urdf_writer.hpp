#pragma once
/// @file
/// @brief Writing identified link parameters into a copy of a URDF, so that Pinocchio, MuJoCo and
/// Gazebo load the identified model.

#include <sid/model/link_inertia.hpp>

#include <Eigen/Core>

#include <string>
#include <vector>

namespace sid::app {

/// @brief The URDF text with the <inertial> of each named link replaced (or added) so that the
/// chain read from it between base and tip has the given link parameters. A moving link that
/// carries other bodies in the description (links fixed to it, bodies past the tip) keeps them:
/// its own <inertial> becomes the identified parameters less what they carry.
/// When that own part is no real body, the bodies fixed to the link join it (a hand on a flange:
/// the data see their sum only), theirs removed; if it still is none (a fit on the edge of real
/// bodies, with moving parts past it), the nearest real body is written. A comment at the link
/// says which, and by how much the written inertia differs.
/// @param links the moving links, base first; phi their identified parameters (lumped, in the
///        link's frame, as sid::chain_from_urdf gives them).
/// @param what the option messages start with ("--write-urdf").
/// @throws InputError when a link is lighter than what it carries in the description, or the
///         result does not read back to what was written.
std::string urdf_with_link_parameters(const std::string& urdf, const std::string& base,
                                      const std::string& tip, const std::vector<std::string>& links,
                                      const std::vector<sid::LinkParameters<double>>& phi,
                                      const std::string& what);

/// @brief The URDF text with each named joint's <dynamics> set to the given damping and friction
/// (one value per joint, in the joints' order), and a comment after <robot> saying what was
/// identified and which parameters (`left_out`, by name) a URDF has no place for.
/// @throws InputError when a joint's element is not found.
std::string urdf_with_joint_dynamics(const std::string& urdf,
                                     const std::vector<std::string>& joints,
                                     const Eigen::VectorXd& damping,
                                     const Eigen::VectorXd& friction,
                                     const std::vector<std::string>& left_out);

}  // namespace sid::app
