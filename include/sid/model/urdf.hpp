#pragma once
/// @file
/// @brief A serial chain and its link parameters from a URDF robot description (its text: the
/// library reads no files), with every body the chain carries lumped into its moving links the
/// way Pinocchio's URDF reader and `buildReducedModel` lump them.

#include <sid/detail/xml.hpp>
#include <sid/model/chain_regressor.hpp>
#include <sid/model/link_inertia.hpp>
#include <sid/model/serial_chain.hpp>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cmath>
#include <limits>
#include <locale>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {

/// @brief A joint's `<limit>` [rad or m, rad/s or m/s, N m or N]; NaN where an attribute is
/// absent (a continuous joint has no lower and upper).
struct UrdfJointLimits {
  double lower = std::numeric_limits<double>::quiet_NaN();
  double upper = std::numeric_limits<double>::quiet_NaN();
  double velocity = std::numeric_limits<double>::quiet_NaN();
  double effort = std::numeric_limits<double>::quiet_NaN();
};

/// @brief A joint's `<mimic>`: its value is multiplier * value(joint) + offset. The chain
/// treats its own joints as independent (as Pinocchio's `buildModel` does by default); a joint
/// held off the chain follows a master whose value `held` gives (see chain_from_urdf).
struct UrdfMimic {
  std::string joint;
  double multiplier = 1.0;
  double offset = 0.0;
};

/// @brief What the URDF says of one moving joint of the chain beyond its placement: usable as
/// priors (limits for excitation design, `<dynamics>` damping and friction for Fv and Fc).
struct UrdfJoint {
  std::string type;  ///< "revolute", "continuous" or "prismatic"
  UrdfJointLimits limit;
  double damping = 0.0;   ///< `<dynamics damping>` [N m s/rad or N s/m], 0 when absent
  double friction = 0.0;  ///< `<dynamics friction>` [N m or N], 0 when absent
  std::optional<UrdfMimic> mimic;
};

/// @brief The chain from one link of a URDF to another.
struct UrdfChain {
  /// Written as the aggregate it was: UrdfChain{chain, theta, joint_names, link_names}.
  UrdfChain(SerialChain<double> chain_in, Eigen::VectorXd theta_in,
            std::vector<std::string> joint_names_in, std::vector<std::string> link_names_in,
            std::vector<UrdfJoint> joints_in = {},
            std::map<std::string, double> held_joints_in = {})
      : chain(std::move(chain_in)),
        theta(std::move(theta_in)),
        joint_names(std::move(joint_names_in)),
        link_names(std::move(link_names_in)),
        joints(std::move(joints_in)),
        held_joints(std::move(held_joints_in)) {}

  SerialChain<double> chain;
  /// The chain's parameters: each moving link's ten standard parameters, including every body
  /// it carries (see chain_from_urdf), friction zero.
  Eigen::VectorXd theta;
  std::vector<std::string> joint_names;  ///< the moving joints, base first
  std::vector<std::string> link_names;   ///< the link each of them moves
  std::vector<UrdfJoint> joints;         ///< per moving joint, base first
  /// The moving joints off or past the chain whose bodies it carries, and the value [rad or m]
  /// each was held at.
  std::map<std::string, double> held_joints;
};

namespace detail {

inline std::string urdf_who() { return "sid::chain_from_urdf"; }

/// A stream that reads numbers as URDF writes them, whatever the global locale.
inline std::istringstream urdf_stream(const std::string& text) {
  std::istringstream in(text);
  in.imbue(std::locale::classic());
  return in;
}

inline Vector3<double> urdf_triple(const XmlElement* e, const char* key, Vector3<double> fallback,
                                   const std::string& where) {
  if (!e) return fallback;
  const std::string* text = e->attribute(key);
  if (!text) return fallback;
  std::istringstream in = urdf_stream(*text);
  Vector3<double> v;
  if (!(in >> v[0] >> v[1] >> v[2]) || !(in >> std::ws).eof() || !v.allFinite())
    throw std::invalid_argument(urdf_who() + ": " + where + ": " + key + "=\"" + *text +
                                "\" is not three finite numbers");
  return v;
}

/// The attribute's number, or fallback if the attribute is absent.
inline double urdf_optional_number(const XmlElement& e, const char* key, double fallback,
                                   const std::string& where) {
  const std::string* text = e.attribute(key);
  if (!text) return fallback;
  std::istringstream in = urdf_stream(*text);
  double v = 0.0;
  if (!(in >> v) || !(in >> std::ws).eof() || !std::isfinite(v))
    throw std::invalid_argument(urdf_who() + ": " + where + ": " + key + "=\"" + *text +
                                "\" is not a finite number");
  return v;
}

inline double urdf_number(const XmlElement& e, const char* key, const std::string& where) {
  if (!e.attribute(key)) throw std::invalid_argument(urdf_who() + ": " + where + " has no " + key);
  return urdf_optional_number(e, key, 0.0, where);
}

/// URDF's <origin xyz rpy>: R = Rz(yaw) Ry(pitch) Rx(roll).
inline FramePose<double> urdf_origin(const XmlElement* origin, const std::string& where) {
  const Vector3<double> xyz = urdf_triple(origin, "xyz", Vector3<double>::Zero(), where);
  const Vector3<double> rpy = urdf_triple(origin, "rpy", Vector3<double>::Zero(), where);
  const double cr = std::cos(rpy[0]), sr = std::sin(rpy[0]), cp = std::cos(rpy[1]),
               sp = std::sin(rpy[1]), cy = std::cos(rpy[2]), sy = std::sin(rpy[2]);
  FramePose<double> pose;
  pose.rotation << cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr, sy * cp,
      sy * sp * sr + cy * cr, sy * sp * cr - cy * sr, -sp, cp * sr, cp * cr;
  pose.translation = xyz;
  return pose;
}

inline FramePose<double> compose(const FramePose<double>& a, const FramePose<double>& b) {
  return {a.rotation * b.rotation, a.translation + a.rotation * b.translation};
}

/// A link's <inertial> in the link's frame; a link without one has no mass.
inline LinkInertia<double> urdf_inertia(const XmlElement& link) {
  const std::string where = "link '" + *link.attribute("name") + "'";
  LinkInertia<double> body;
  const XmlElement* inertial = link.child("inertial");
  if (!inertial) return body;
  const FramePose<double> at = urdf_origin(inertial->child("origin"), where + " <inertial>");
  const XmlElement* mass = inertial->child("mass");
  const XmlElement* inertia = inertial->child("inertia");
  if (!mass || !inertia)
    throw std::invalid_argument(urdf_who() + ": " + where + ": <inertial> needs <mass> and " +
                                "<inertia>");
  body.mass = urdf_number(*mass, "value", where + " <mass>");
  const std::string w = where + " <inertia>";
  const double ixx = urdf_number(*inertia, "ixx", w), ixy = urdf_number(*inertia, "ixy", w),
               ixz = urdf_number(*inertia, "ixz", w), iyy = urdf_number(*inertia, "iyy", w),
               iyz = urdf_number(*inertia, "iyz", w), izz = urdf_number(*inertia, "izz", w);
  Matrix3<double> i;
  i << ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz;
  body.com = at.translation;
  body.inertia_com = at.rotation * i * at.rotation.transpose();
  return body;
}

/// A body's parameters seen from a frame in which the body's own frame has the given pose.
inline LinkParameters<double> moved_parameters(const LinkInertia<double>& body,
                                               const FramePose<double>& pose) {
  return standard_parameters(expressed_in_parent(body, pose));
}

/// The links and joints of a <robot>, indexed; every joint names its parent and child link and
/// no link is the child of two joints.
struct UrdfTree {
  std::map<std::string, const XmlElement*> links;
  std::map<std::string, const XmlElement*> joints;
  std::map<std::string, const XmlElement*> joint_into;                ///< child link -> its joint
  std::map<std::string, std::vector<const XmlElement*>> joints_from;  ///< parent link -> joints

  explicit UrdfTree(const XmlElement& robot) {
    for (const auto& e : robot.children)
      if (e.name == "link") {
        const std::string* name = e.attribute("name");
        if (!name) throw std::invalid_argument(urdf_who() + ": a <link> has no name");
        if (!links.emplace(*name, &e).second)
          throw std::invalid_argument(urdf_who() + ": link '" + *name + "' is defined twice");
      }
    for (const auto& e : robot.children) {
      if (e.name != "joint") continue;
      const std::string name = joint_name(e);
      if (!joints.emplace(name, &e).second)
        throw std::invalid_argument(urdf_who() + ": joint '" + name + "' is defined twice");
      const std::string child = end_link(e, "child"), parent = end_link(e, "parent");
      const auto [into, first] = joint_into.emplace(child, &e);
      if (!first)
        throw std::invalid_argument(urdf_who() + ": link '" + child + "' is the child of joints '" +
                                    joint_name(*into->second) + "' and '" + name + "'");
      joints_from[parent].push_back(&e);
    }
  }

  static std::string joint_name(const XmlElement& joint) {
    const std::string* name = joint.attribute("name");
    return name ? *name : std::string("?");
  }

  static std::string end_link(const XmlElement& joint, const char* end) {
    const XmlElement* e = joint.child(end);
    const std::string* link = e ? e->attribute("link") : nullptr;
    if (!link)
      throw std::invalid_argument(urdf_who() + ": joint '" + joint_name(joint) + "' has no <" +
                                  end + " link=...>");
    return *link;
  }

  const XmlElement& link(const std::string& name) const {
    const auto found = links.find(name);
    if (found == links.end())
      throw std::invalid_argument(urdf_who() + ": there is no link '" + name + "'");
    return *found->second;
  }

  /// The joints from base_link out to tip_link, base first.
  std::vector<const XmlElement*> path(const std::string& base_link,
                                      const std::string& tip_link) const {
    std::vector<const XmlElement*> joints_on_path;
    std::string at = tip_link;
    while (at != base_link) {
      const auto into = joint_into.find(at);
      if (into == joint_into.end())
        throw std::invalid_argument(urdf_who() + ": no joint leads to link '" + at + "': is '" +
                                    base_link + "' an ancestor of '" + tip_link + "'?");
      if (joints_on_path.size() > joints.size())
        throw std::invalid_argument(urdf_who() + ": the joints form a loop");
      joints_on_path.push_back(into->second);
      at = end_link(*into->second, "parent");
    }
    return {joints_on_path.rbegin(), joints_on_path.rend()};
  }
};

inline std::string urdf_type(const XmlElement& joint) {
  const std::string* type = joint.attribute("type");
  if (!type)
    throw std::invalid_argument(urdf_who() + ": joint '" + UrdfTree::joint_name(joint) +
                                "' has no type");
  return *type;
}

inline bool urdf_moves(const std::string& type) {
  return type == "revolute" || type == "continuous" || type == "prismatic";
}

/// The axis of a moving joint, normalised (URDF's default axis is x).
inline Vector3<double> urdf_axis(const XmlElement& joint, const std::string& where) {
  const Vector3<double> axis =
      urdf_triple(joint.child("axis"), "xyz", Vector3<double>::UnitX(), where + " <axis>");
  if (!(axis.norm() > 0.0))
    throw std::invalid_argument(urdf_who() + ": " + where + " has a zero axis");
  return axis.normalized();
}

/// The pose of a joint's child link in its parent link at joint value q [rad or m].
inline FramePose<double> urdf_joint_pose(const XmlElement& joint, const std::string& type,
                                         double q) {
  const std::string where = "joint '" + UrdfTree::joint_name(joint) + "'";
  const FramePose<double> origin = urdf_origin(joint.child("origin"), where);
  if (type == "fixed") return origin;
  if (!urdf_moves(type))
    throw std::invalid_argument(urdf_who() + ": " + where + " is " + type +
                                "; only revolute, continuous, prismatic and fixed joints can be "
                                "held");
  const Vector3<double> axis = urdf_axis(joint, where);
  FramePose<double> motion;
  if (type == "prismatic")
    motion.translation = q * axis;
  else
    motion.rotation = Eigen::AngleAxisd(q, axis).toRotationMatrix();
  return compose(origin, motion);
}

/// A joint's <mimic>, if it has one.
inline std::optional<UrdfMimic> urdf_mimic(const XmlElement& joint) {
  const XmlElement* mimic = joint.child("mimic");
  if (!mimic) return std::nullopt;
  const std::string w = "joint '" + UrdfTree::joint_name(joint) + "' <mimic>";
  const std::string* of = mimic->attribute("joint");
  if (!of) throw std::invalid_argument(urdf_who() + ": " + w + " has no joint");
  return UrdfMimic{*of, urdf_optional_number(*mimic, "multiplier", 1.0, w),
                   urdf_optional_number(*mimic, "offset", 0.0, w)};
}

/// What the URDF says of a moving joint beyond its placement.
inline UrdfJoint urdf_joint_info(const XmlElement& joint, const std::string& type) {
  const std::string where = "joint '" + UrdfTree::joint_name(joint) + "'";
  UrdfJoint info;
  info.type = type;
  if (const XmlElement* limit = joint.child("limit")) {
    const std::string w = where + " <limit>";
    info.limit.lower = urdf_optional_number(*limit, "lower", info.limit.lower, w);
    info.limit.upper = urdf_optional_number(*limit, "upper", info.limit.upper, w);
    info.limit.velocity = urdf_optional_number(*limit, "velocity", info.limit.velocity, w);
    info.limit.effort = urdf_optional_number(*limit, "effort", info.limit.effort, w);
  }
  if (const XmlElement* dynamics = joint.child("dynamics")) {
    const std::string w = where + " <dynamics>";
    info.damping = urdf_optional_number(*dynamics, "damping", 0.0, w);
    info.friction = urdf_optional_number(*dynamics, "friction", 0.0, w);
  }
  info.mimic = urdf_mimic(joint);
  return info;
}

/// The value [rad or m] at which a moving joint off the chain is held: held[name] if given;
/// else, if it mimics a joint whose value the user gave (directly, or through that joint's own
/// <mimic>), multiplier * value + offset; else 0. A mimic whose chain of masters reaches no
/// given value, or turns in a loop, is held at 0 as before.
inline double urdf_held_value(const UrdfTree& tree, const XmlElement& joint,
                              const std::map<std::string, double>& held) {
  const auto given = held.find(UrdfTree::joint_name(joint));
  if (given != held.end()) return given->second;
  if (held.empty()) return 0.0;
  // value(joint) = scale * value(at) + shift, followed out along the masters.
  double scale = 1.0, shift = 0.0;
  const XmlElement* at = &joint;
  for (std::size_t step = 0; step <= tree.joints.size(); ++step) {
    const std::optional<UrdfMimic> mimic = urdf_mimic(*at);
    if (!mimic) return 0.0;
    shift += scale * mimic->offset;
    scale *= mimic->multiplier;
    const auto master = held.find(mimic->joint);
    if (master != held.end()) return scale * master->second + shift;
    const auto next = tree.joints.find(mimic->joint);
    if (next == tree.joints.end()) return 0.0;
    at = next->second;
  }
  return 0.0;  // the masters turn in a loop
}

/// Adds to `into` every body below `link` (not the link itself), whose frame has pose `at` in
/// the frame of the moving link that carries them, skipping the joint `except` (the chain's
/// next joint). Moving joints are held at urdf_held_value and recorded in `used`. Iterative, so
/// that a long line of links cannot overflow the stack.
inline void urdf_carry(const UrdfTree& tree, const std::string& link, const FramePose<double>& at,
                       const XmlElement* except, const std::map<std::string, double>& held,
                       std::map<std::string, double>& used, std::set<std::string>& seen,
                       LinkParameters<double>& into) {
  std::vector<std::pair<std::string, FramePose<double>>> pending{{link, at}};
  while (!pending.empty()) {
    const std::pair<std::string, FramePose<double>> parent = std::move(pending.back());
    pending.pop_back();
    const auto from = tree.joints_from.find(parent.first);
    if (from == tree.joints_from.end()) continue;
    for (const XmlElement* joint : from->second) {
      if (joint == except) continue;
      const std::string name = UrdfTree::joint_name(*joint), type = urdf_type(*joint);
      double q = 0.0;
      if (type != "fixed") {
        q = urdf_held_value(tree, *joint, held);
        used[name] = q;
      }
      const std::string child = UrdfTree::end_link(*joint, "child");
      if (!seen.insert(child).second)
        throw std::invalid_argument(urdf_who() + ": the joints form a loop at link '" + child +
                                    "'");
      const FramePose<double> pose = compose(parent.second, urdf_joint_pose(*joint, type, q));
      into += moved_parameters(urdf_inertia(tree.link(child)), pose);
      pending.emplace_back(child, pose);
    }
  }
}

}  // namespace detail

/// @brief The chain of moving joints from base_link to tip_link of a URDF, with every body it
/// carries, counted as Pinocchio counts them once the joints off the chain are locked
/// (`buildModel` then `buildReducedModel`).
///
/// Revolute, continuous and prismatic joints on the path from base_link to tip_link move; fixed
/// joints on it fold into the next joint's placement. Each moving link carries, in its own
/// frame: the links fixed to it on the path, every branch off the path at it or at a link fixed
/// to it (a camera on a bracket, a sensor on a tilt joint), and for the last moving link every
/// body past tip_link (a hand and its fingers, or the rest of the arm). Moving joints in those
/// bodies are held at `held[name]` [rad or m]; one the map does not name but whose `<mimic>`
/// master it names (directly or through the master's own `<mimic>`) follows it, at multiplier *
/// value + offset; every other one is held at 0 (Pinocchio's `buildModel` ignores `<mimic>`, so
/// with an empty map the lumped bodies are its reduced model's at 0). Bodies before the first
/// moving joint belong to the base and are left out, as is everything not below base_link.
/// @param held values of joints off or past the chain; it may not name a joint of the chain,
///        a fixed joint or a joint the URDF does not have.
/// @param gravity the gravitational acceleration in base_link's frame [m/s^2].
/// @throws std::invalid_argument naming the problem: malformed XML, elements nested deeper than
///         256, a missing or doubly defined link, a link that is the child of two joints, no
///         path from base_link to tip_link, a floating or planar joint on the path or in a
///         carried body, a value that is not a number, no moving joint, more than
///         kMaxChainJoints, a bad `held` entry.
inline UrdfChain chain_from_urdf(const std::string& urdf, const std::string& base_link,
                                 const std::string& tip_link,
                                 const std::map<std::string, double>& held,
                                 const Vector3<double>& gravity = Vector3<double>(0.0, 0.0,
                                                                                  -9.81)) {
  const std::string who = detail::urdf_who();
  const detail::XmlElement robot = detail::XmlParser(urdf, who).parse_document();
  if (robot.name != "robot")
    throw std::invalid_argument(who + ": the root element is <" + robot.name + ">, not <robot>");
  const detail::UrdfTree tree(robot);
  (void)tree.link(base_link);
  const std::vector<const detail::XmlElement*> path = tree.path(base_link, tip_link);
  for (const auto& [name, value] : held) {
    const auto joint = tree.joints.find(name);
    if (joint == tree.joints.end())
      throw std::invalid_argument(who + ": held names joint '" + name + "', which there is not");
    const std::string type = detail::urdf_type(*joint->second);
    if (!detail::urdf_moves(type))
      throw std::invalid_argument(who + ": held names joint '" + name + "', which is " + type);
    for (const detail::XmlElement* on_path : path)
      if (on_path == joint->second)
        throw std::invalid_argument(who + ": held names joint '" + name +
                                    "', which is a joint of the chain");
    if (!std::isfinite(value))
      throw std::invalid_argument(who + ": held value of joint '" + name + "' is not finite");
  }

  std::vector<JointPlacement<double>> joints;
  std::vector<LinkParameters<double>> links;
  std::vector<std::string> joint_names, link_names;
  std::vector<UrdfJoint> infos;
  std::map<std::string, double> held_joints;
  std::set<std::string> seen{base_link};
  // The pose of the path's current link in the last moving link's frame (or the base's).
  FramePose<double> fixed;
  for (std::size_t k = 0; k < path.size(); ++k) {
    const detail::XmlElement& joint = *path[k];
    const std::string name = detail::UrdfTree::joint_name(joint);
    const std::string where = "joint '" + name + "'";
    const std::string type = detail::urdf_type(joint);
    const std::string child = detail::UrdfTree::end_link(joint, "child");
    seen.insert(child);
    const FramePose<double> origin = detail::urdf_origin(joint.child("origin"), where);
    if (type == "fixed") {
      fixed = detail::compose(fixed, origin);
    } else {
      if (!detail::urdf_moves(type))
        throw std::invalid_argument(who + ": " + where + " is " + type +
                                    "; only revolute, continuous, prismatic and fixed joints are "
                                    "supported");
      JointPlacement<double> placement;
      placement.before = detail::compose(fixed, origin);
      placement.axis = detail::urdf_axis(joint, where);
      if (type == "prismatic") placement.type = JointType::Prismatic;
      joints.push_back(placement);
      links.push_back(LinkParameters<double>::Zero());
      joint_names.push_back(name);
      link_names.push_back(child);
      infos.push_back(detail::urdf_joint_info(joint, type));
      fixed = FramePose<double>();
    }
    if (links.empty()) continue;  // the base's
    links.back() += detail::moved_parameters(detail::urdf_inertia(tree.link(child)), fixed);
    detail::urdf_carry(tree, child, fixed, k + 1 < path.size() ? path[k + 1] : nullptr, held,
                       held_joints, seen, links.back());
  }
  if (joints.empty())
    throw std::invalid_argument(who + ": no revolute, continuous or prismatic joint between '" +
                                base_link + "' and '" + tip_link + "'");
  const int n = static_cast<int>(links.size());
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(chain_parameter_count(n));
  for (int i = 0; i < n; ++i)
    theta.segment<kLinkParameters>(kLinkParameters * i) = links[static_cast<std::size_t>(i)];
  return {SerialChain<double>(joints, gravity),
          std::move(theta),
          std::move(joint_names),
          std::move(link_names),
          std::move(infos),
          std::move(held_joints)};
}

/// @brief chain_from_urdf with every joint off or past the chain held at 0.
inline UrdfChain chain_from_urdf(const std::string& urdf, const std::string& base_link,
                                 const std::string& tip_link,
                                 const Vector3<double>& gravity = Vector3<double>(0.0, 0.0,
                                                                                  -9.81)) {
  return chain_from_urdf(urdf, base_link, tip_link, std::map<std::string, double>(), gravity);
}

}  // namespace sid
