#pragma once
/// @file
/// @brief A robot's description as the workflows take it: the serial chain between two links of
/// a URDF (or of a DH table, which has no inertias), its joints' names, `<limit>`s and
/// `<dynamics>`, and the URDF's text, from which an identified model is written back. Reading
/// the file is the caller's; sid::robot_description_from_urdf parses the text.

#include <sid/description_prior.hpp>
#include <sid/model/serial_chain.hpp>
#include <sid/model/urdf.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief The chain of a robot description and what the reports call its parts.
struct RobotDescription {
  SerialChain<double> chain;
  std::vector<std::string> joint_names;
  std::string base, tip;  ///< the links the chain runs between (URDF), or "" for a DH table
  std::string urdf;       ///< the URDF's text ("" for a DH table)
  std::vector<std::string> link_names;  ///< the link each joint moves (URDF)
  Eigen::VectorXd link_parameters;      ///< the description's ten per link (URDF), else empty
  /// Per joint, the URDF's <dynamics> damping and friction (0 where absent or for a DH table).
  Eigen::VectorXd damping, friction;
  /// Per joint, the URDF's <limit> (NaN where absent); empty for a DH table.
  std::vector<UrdfJointLimits> limits;
};

/// @brief The chain of the URDF `text` from link base to link tip (sid::chain_from_urdf), the
/// joints off it held at `held` (by name; the others at 0).
/// @throws std::invalid_argument as chain_from_urdf.
inline RobotDescription robot_description_from_urdf(
    const std::string& text, const std::string& base, const std::string& tip,
    const std::map<std::string, double>& held = {}) {
  UrdfChain urdf = chain_from_urdf(text, base, tip, held);
  const Eigen::Index n = urdf.chain.joints();
  Eigen::VectorXd damping = Eigen::VectorXd::Zero(n), friction = Eigen::VectorXd::Zero(n);
  std::vector<UrdfJointLimits> limits(static_cast<std::size_t>(n));
  for (Eigen::Index j = 0; j < n && j < static_cast<Eigen::Index>(urdf.joints.size()); ++j) {
    damping[j] = urdf.joints[static_cast<std::size_t>(j)].damping;
    friction[j] = urdf.joints[static_cast<std::size_t>(j)].friction;
    limits[static_cast<std::size_t>(j)] = urdf.joints[static_cast<std::size_t>(j)].limit;
  }
  return {
      std::move(urdf.chain),      std::move(urdf.joint_names),          base,    tip,      text,
      std::move(urdf.link_names), urdf.theta.head(kLinkParameters * n), damping, friction, limits};
}

/// @brief What the description gives of the arm's dynamics: a URDF's links and joints'
/// <dynamics>; nothing for a DH table.
inline DescriptionDynamics description_dynamics(const RobotDescription& robot) {
  return {robot.link_parameters, robot.damping, robot.friction};
}

/// @brief Where an excitation of the robot may go.
struct ExcitationRoom {
  Eigen::VectorXd q0;       ///< the middle of each joint's <limit> (0 where it has none)
  Eigen::VectorXd q_range;  ///< largest |q - q0| per joint [rad or m]
  Eigen::VectorXd qd_max;   ///< largest |qd| per joint [rad/s or m/s]
};

/// @brief q0 about the middle of each joint's <limit>, |q - q0| at most q_range and 90 % of its
/// half width, |qd| at most qd_max and 90 % of its velocity limit (q_range and qd_max alone where
/// the description gives no limit).
/// @throws std::invalid_argument naming a joint whose <limit> range is empty.
inline ExcitationRoom excitation_room(const RobotDescription& robot, double q_range,
                                      double qd_max) {
  const int n = robot.chain.joints();
  ExcitationRoom room{Eigen::VectorXd::Zero(n), Eigen::VectorXd::Constant(n, q_range),
                      Eigen::VectorXd::Constant(n, qd_max)};
  for (int j = 0; j < n && j < static_cast<int>(robot.limits.size()); ++j) {
    const UrdfJointLimits& limit = robot.limits[static_cast<std::size_t>(j)];
    if (std::isfinite(limit.lower) && std::isfinite(limit.upper)) {
      if (!(limit.upper > limit.lower))
        throw std::invalid_argument("joint '" + robot.joint_names[static_cast<std::size_t>(j)] +
                                    "' has an empty <limit> range; cannot move it");
      room.q0[j] = 0.5 * (limit.lower + limit.upper);
      room.q_range[j] = std::min(room.q_range[j], 0.45 * (limit.upper - limit.lower));
    }
    if (std::isfinite(limit.velocity) && limit.velocity > 0.0)
      room.qd_max[j] = std::min(room.qd_max[j], 0.9 * limit.velocity);
  }
  return room;
}

}  // namespace sid
