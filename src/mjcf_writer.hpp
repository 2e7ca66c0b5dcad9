#pragma once
/// @file
/// @brief A MuJoCo model (MJCF) of a URDF's tree: the bodies with the URDF's inertials, the
/// joints with their identified drives, the description's shapes and meshes, a motor per joint
/// of the chain.

#include <Eigen/Core>

#include <string>
#include <vector>

namespace sid::app {

/// @brief What MuJoCo's joints hold of an identification, per joint of the chain (by name).
struct MjcfJointDrives {
  std::vector<std::string> joints;
  Eigen::VectorXd damping;    ///< MuJoCo's damping
  Eigen::VectorXd friction;   ///< Coulomb: MuJoCo's frictionloss
  Eigen::VectorXd armature;   ///< MuJoCo's armature
  Eigen::VectorXd stiffness;  ///< MuJoCo's stiffness (spring reference 0)
};

/// @brief Where the URDF's relative and package:// mesh paths are looked up from (its directory)
/// and where the MJCF goes (mesh paths are written relative to it).
struct MjcfPaths {
  std::string urdf_directory;
  std::string mjcf_directory;
};

/// @brief The MJCF text and what it could not hold (besides `not_written`), one item each.
struct Mjcf {
  std::string text;
  std::vector<std::string> left_out;
};

/// @brief The MuJoCo model of the URDF's tree from link `base`, which is fixed to the world with
/// gravity `gravity` in its frame (as sid's chain takes it). Every link below base is a body
/// with its URDF <inertial>; every joint keeps its type, axis and range; joints of `drives` get
/// its values, the others their URDF <dynamics>. <collision> shapes collide, <visual> ones are
/// drawn only; meshes that MuJoCo cannot read (or that are not found) are left out, and said so
/// in `left_out`. A <mimic> becomes an equality constraint. Each joint of `drives` gets a motor
/// (its effort limit as the control range). A comment at the top says what the identification
/// wrote and lists `not_written` and `left_out`.
/// @throws InputError when the URDF does not parse, base is not a link, or a joint of `drives`
///         is not below base.
Mjcf mjcf_from_urdf(const std::string& urdf, const std::string& base,
                    const Eigen::Vector3d& gravity, const MjcfJointDrives& drives,
                    const std::vector<std::string>& not_written, const MjcfPaths& paths);

}  // namespace sid::app
