#pragma once
/// @file
/// @brief A serial chain and its link parameters from a URDF robot description (its text: the
/// library reads no files).

#include <sid/detail/xml.hpp>
#include <sid/model/chain_regressor.hpp>
#include <sid/model/link_inertia.hpp>
#include <sid/model/serial_chain.hpp>

#include <Eigen/Core>

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief The chain from one link of a URDF to another.
struct UrdfChain {
  SerialChain<double> chain;
  /// The chain's parameters: each moving link's ten standard parameters (links attached to it
  /// by fixed joints on the path included), friction zero.
  Eigen::VectorXd theta;
  std::vector<std::string> joint_names;  ///< the revolute and continuous joints, base first
  std::vector<std::string> link_names;   ///< the link each of them moves
};

namespace detail {

inline std::string urdf_who() { return "sid::chain_from_urdf"; }

inline Vector3<double> urdf_triple(const XmlElement* e, const char* key, Vector3<double> fallback,
                                   const std::string& where) {
  if (!e) return fallback;
  const std::string* text = e->attribute(key);
  if (!text) return fallback;
  std::istringstream in(*text);
  Vector3<double> v;
  if (!(in >> v[0] >> v[1] >> v[2]) || !(in >> std::ws).eof() || !v.allFinite())
    throw std::invalid_argument(urdf_who() + ": " + where + ": " + key + "=\"" + *text +
                                "\" is not three finite numbers");
  return v;
}

inline double urdf_number(const XmlElement& e, const char* key, const std::string& where) {
  const std::string* text = e.attribute(key);
  if (!text) throw std::invalid_argument(urdf_who() + ": " + where + " has no " + key);
  std::istringstream in(*text);
  double v = 0.0;
  if (!(in >> v) || !(in >> std::ws).eof() || !std::isfinite(v))
    throw std::invalid_argument(urdf_who() + ": " + where + ": " + key + "=\"" + *text +
                                "\" is not a finite number");
  return v;
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
  LinkInertia<double> moved;
  moved.mass = body.mass;
  moved.com = pose.rotation * body.com + pose.translation;
  moved.inertia_com = pose.rotation * body.inertia_com * pose.rotation.transpose();
  return standard_parameters(moved);
}

/// The joints from base_link out to tip_link, base first.
inline std::vector<const XmlElement*> urdf_path(const XmlElement& robot,
                                                const std::string& base_link,
                                                const std::string& tip_link) {
  std::vector<const XmlElement*> path;
  std::string link = tip_link;
  while (link != base_link) {
    const XmlElement* into = nullptr;
    for (const auto& e : robot.children)
      if (e.name == "joint" && e.child("child") && e.child("child")->attribute("link") &&
          *e.child("child")->attribute("link") == link)
        into = &e;
    if (!into || !into->child("parent") || !into->child("parent")->attribute("link"))
      throw std::invalid_argument(urdf_who() + ": no joint leads to link '" + link + "': is '" +
                                  base_link + "' an ancestor of '" + tip_link + "'?");
    if (path.size() > robot.children.size())
      throw std::invalid_argument(urdf_who() + ": the joints form a loop");
    path.push_back(into);
    link = *into->child("parent")->attribute("link");
  }
  return {path.rbegin(), path.rend()};
}

inline const XmlElement& urdf_link(const XmlElement& robot, const std::string& name) {
  for (const auto& e : robot.children)
    if (e.name == "link" && e.attribute("name") && *e.attribute("name") == name) return e;
  throw std::invalid_argument(urdf_who() + ": there is no link '" + name + "'");
}

}  // namespace detail

/// @brief The chain of revolute and continuous joints from base_link to tip_link of a URDF.
/// Fixed joints on the path fold into the next joint's placement, and the links they attach
/// add their inertia to the moving link before them (links attached before the first moving
/// joint belong to the base). Branches off the path are ignored.
/// @throws std::invalid_argument naming the problem: malformed XML, a missing link, no path
///         from base_link to tip_link, a prismatic, floating or planar joint on the path, a
///         value that is not a number, no moving joint, more than kMaxChainJoints.
inline UrdfChain chain_from_urdf(const std::string& urdf, const std::string& base_link,
                                 const std::string& tip_link,
                                 const Vector3<double>& gravity = Vector3<double>(0.0, 0.0,
                                                                                  -9.81)) {
  const detail::XmlElement robot = detail::XmlParser(urdf, detail::urdf_who()).parse_document();
  if (robot.name != "robot")
    throw std::invalid_argument(detail::urdf_who() + ": the root element is <" + robot.name +
                                ">, not <robot>");
  (void)detail::urdf_link(robot, base_link);
  std::vector<JointPlacement<double>> joints;
  std::vector<LinkParameters<double>> links;
  std::vector<std::string> joint_names, link_names;
  FramePose<double>
      fixed;  // from the last moving link's frame (or the base) to this joint's parent
  for (const detail::XmlElement* joint : detail::urdf_path(robot, base_link, tip_link)) {
    const std::string* name = joint->attribute("name");
    const std::string where = "joint '" + (name ? *name : std::string("?")) + "'";
    const std::string* type = joint->attribute("type");
    const std::string child = *joint->child("child")->attribute("link");
    const FramePose<double> origin = detail::urdf_origin(joint->child("origin"), where);
    if (!type) throw std::invalid_argument(detail::urdf_who() + ": " + where + " has no type");
    if (*type == "fixed") {
      fixed = detail::compose(fixed, origin);
      if (!links.empty())
        links.back() +=
            detail::moved_parameters(detail::urdf_inertia(detail::urdf_link(robot, child)), fixed);
      continue;
    }
    if (*type != "revolute" && *type != "continuous")
      throw std::invalid_argument(detail::urdf_who() + ": " + where + " is " + *type +
                                  "; only revolute, continuous and fixed joints are supported");
    JointPlacement<double> placement;
    placement.before = detail::compose(fixed, origin);
    placement.axis = detail::urdf_triple(joint->child("axis"), "xyz", Vector3<double>::UnitX(),
                                         where + " <axis>");  // URDF's default axis is x
    joints.push_back(placement);
    links.push_back(standard_parameters(detail::urdf_inertia(detail::urdf_link(robot, child))));
    joint_names.push_back(name ? *name : std::string());
    link_names.push_back(child);
    fixed = FramePose<double>();
  }
  if (joints.empty())
    throw std::invalid_argument(detail::urdf_who() + ": no revolute joint between '" + base_link +
                                "' and '" + tip_link + "'");
  UrdfChain result{SerialChain<double>(joints, gravity), Eigen::VectorXd(), std::move(joint_names),
                   std::move(link_names)};
  const int n = static_cast<int>(links.size());
  result.theta = Eigen::VectorXd::Zero(chain_parameter_count(n));
  for (int i = 0; i < n; ++i)
    result.theta.segment<kLinkParameters>(kLinkParameters * i) = links[static_cast<std::size_t>(i)];
  return result;
}

}  // namespace sid
