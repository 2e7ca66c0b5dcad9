#pragma once
/// @file
/// @brief sid::transmission_from_urdf: a chain's sid::Transmission from the `<transmission>`
/// elements ros_control (ROS 1) and ros2_control (ROS 2) read from a robot description (its
/// text: the library reads no files).
///
/// Both implement a SimpleTransmission (one actuator, one joint, reduction n, joint offset x0)
/// as x_joint = x_actuator / n + x0 and tau_joint = n tau_actuator (ros2_control,
/// transmission_interface/simple_transmission.hpp), which is sid's q = G^-1 q_motor + zero and
/// tau = G^T tau_motor with G = n and zero = x0. A DifferentialTransmission (actuator reductions
/// na1, na2, joint reductions nj1, nj2, joint offsets x1, x2) maps
/// x_j1 = (x_a1 / na1 + x_a2 / na2) / (2 nj1) + x1, x_j2 = (x_a1 / na1 - x_a2 / na2) / (2 nj2) + x2
/// and tau_j1 = nj1 (na1 tau_a1 + na2 tau_a2), tau_j2 = nj2 (na1 tau_a1 - na2 tau_a2)
/// (differential_transmission.hpp there): that is G = [[na1 nj1, na1 nj2], [na2 nj1, -na2 nj2]]
/// on the rows and columns of joint1 and joint2, actuator1 being joint1's motor, with the same
/// power balance as sid's tau = G^T tau_motor.

#include <sid/detail/xml.hpp>
#include <sid/model/transmission.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <locale>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {
namespace detail {

inline std::string transmission_who() { return "sid::transmission_from_urdf"; }

inline std::string trim_space(const std::string& text) {
  const char* space = " \t\r\n";
  const std::size_t first = text.find_first_not_of(space);
  if (first == std::string::npos) return "";
  return text.substr(first, text.find_last_not_of(space) + 1 - first);
}

/// Every <transmission> in the document, in document order (not those inside another one): at
/// the top of a <robot>, inside <ros2_control>, or the document itself.
inline void collect_transmissions(const XmlElement& e, std::vector<const XmlElement*>& out) {
  if (e.name == "transmission") {
    out.push_back(&e);
    return;
  }
  for (const XmlElement& c : e.children) collect_transmissions(c, out);
}

/// One <joint> or <actuator> of a transmission, read in the form of ROS 1 (<mechanicalReduction>
/// and <role> as child elements) or ROS 2 (<mechanical_reduction> child, role attribute).
class TransmissionPart {
 public:
  TransmissionPart(const XmlElement& e, bool ros2, const std::string& where) : e_(e), ros2_(ros2) {
    const std::string* name = e.attribute("name");
    if (!name || name->empty())
      throw std::invalid_argument(transmission_who() + ": " + where + ": a <" + e.name +
                                  "> has no name");
    name_ = *name;
    where_ = where + ", " + e.name + " '" + name_ + "'";
    const char* other = ros2 ? "mechanicalReduction" : "mechanical_reduction";
    if (e.child(other))
      throw std::invalid_argument(transmission_who() + ": " + where_ + ": <" + other + "> is " +
                                  (ros2 ? "ROS 1's; ros2_control reads <mechanical_reduction>"
                                        : "ros2_control's; ros_control reads "
                                          "<mechanicalReduction>"));
  }

  const std::string& name() const { return name_; }
  const std::string& where() const { return where_; }

  /// The role ("joint1", "actuator2", ...), or "" when not given.
  std::string role() const {
    if (ros2_) {
      const std::string* role = e_.attribute("role");
      return role ? trim_space(*role) : std::string();
    }
    const XmlElement* role = e_.child("role");
    return role ? trim_space(role->text) : std::string();
  }

  /// The mechanical reduction: fallback when absent (refused when fallback is NaN), never 0.
  double reduction(double fallback) const {
    const char* tag = ros2_ ? "mechanical_reduction" : "mechanicalReduction";
    const double n = number(tag, fallback);
    if (std::isnan(n))
      throw std::invalid_argument(transmission_who() + ": " + where_ + " has no <" + tag + ">");
    if (n == 0.0)
      throw std::invalid_argument(transmission_who() + ": " + where_ + ": <" + tag +
                                  "> is 0; a reduction may be any number but 0");
    return n;
  }

  double offset() const { return number("offset", 0.0); }

  bool has_reduction() const {
    return e_.child(ros2_ ? "mechanical_reduction" : "mechanicalReduction") != nullptr;
  }

 private:
  double number(const char* tag, double fallback) const {
    const XmlElement* child = e_.child(tag);
    if (!child) return fallback;
    const std::string text = trim_space(child->text);
    std::istringstream in(text);
    in.imbue(std::locale::classic());
    double v = 0.0;
    if (!(in >> v) || !(in >> std::ws).eof() || !std::isfinite(v))
      throw std::invalid_argument(transmission_who() + ": " + where_ + ": <" + tag + ">" + text +
                                  "</" + tag + "> is not a finite number");
    return v;
  }

  const XmlElement& e_;
  bool ros2_;
  std::string name_, where_;
};

/// The order of a differential's two joints (stem "joint") or actuators ("actuator") by their
/// roles stem1, stem2: by role in ROS 1 (required there), as written in ROS 2 (as
/// ros2_control's loader takes them), where a role, if given, must agree with that order.
inline std::array<std::size_t, 2> role_order(const std::vector<TransmissionPart>& parts,
                                             const std::string& stem, bool ros2,
                                             const std::string& where) {
  const std::string first = stem + "1", second = stem + "2";
  const std::string r0 = parts[0].role(), r1 = parts[1].role();
  if (ros2) {
    if ((r0.empty() || r0 == first) && (r1.empty() || r1 == second)) return {0, 1};
    throw std::invalid_argument(transmission_who() + ": " + where + ": the roles of the " + stem +
                                "s are '" + r0 + "' and '" + r1 + "'; ros2_control takes them in " +
                                "the order written, so give role=\"" + first + "\" then \"" +
                                second + "\" (or none)");
  }
  for (const auto& part : parts)
    if (part.role() != first && part.role() != second)
      throw std::invalid_argument(transmission_who() + ": " + part.where() + ": <role> is '" +
                                  part.role() + "', expected '" + first + "' or '" + second + "'");
  if (r0 == r1)
    throw std::invalid_argument(transmission_who() + ": " + where + ": both " + stem +
                                "s have the role '" + r0 + "'");
  if (r0 == first) return {0, 1};
  return {1, 0};
}

/// The joints of the document's <robot>, on the chain or not.
inline std::set<std::string> robot_joints(const XmlElement& root) {
  std::set<std::string> defined;
  if (root.name == "robot")
    for (const auto& e : root.children)
      if (e.name == "joint" && e.attribute("name")) defined.insert(*e.attribute("name"));
  return defined;
}

/// The chain's index of each joint of transmission e, or -1 for a joint the document defines
/// off the chain.
inline std::vector<Eigen::Index> transmission_joint_indices(
    const XmlElement& e, const std::string& where, const std::vector<std::string>& joint_names,
    const std::set<std::string>& defined) {
  const std::string who = transmission_who();
  std::vector<Eigen::Index> at;
  for (const auto& c : e.children) {
    if (c.name != "joint") continue;
    const std::string* joint = c.attribute("name");
    if (!joint || joint->empty())
      throw std::invalid_argument(who + ": " + where + ": a <joint> has no name");
    const auto found = std::find(joint_names.begin(), joint_names.end(), *joint);
    if (found != joint_names.end()) {
      at.push_back(static_cast<Eigen::Index>(found - joint_names.begin()));
      continue;
    }
    if (!defined.count(*joint)) {
      std::string chain;
      for (const auto& j : joint_names) chain += (chain.empty() ? "" : ", ") + j;
      throw std::invalid_argument(who + ": " + where + ", joint '" + *joint +
                                  "': not a joint of the chain (" + chain + ")");
    }
    at.push_back(-1);
  }
  return at;
}

/// A transmission's form (ROS 2's <plugin> or ROS 1's <type>) and type.
struct TransmissionKind {
  bool ros2 = false;
  bool simple = false;
};

inline TransmissionKind transmission_kind(const XmlElement& e, const std::string& where) {
  const std::string who = transmission_who();
  const XmlElement* plugin = e.child("plugin");
  const XmlElement* type_element = plugin ? plugin : e.child("type");
  const bool ros2 = plugin != nullptr;
  if (!type_element)
    throw std::invalid_argument(who + ": " + where + " has no <type> (ROS 1) or <plugin> " +
                                "(ROS 2)");
  const std::string type = trim_space(type_element->text);
  const bool simple = type == "transmission_interface/SimpleTransmission";
  if (!simple && type != "transmission_interface/DifferentialTransmission")
    throw std::invalid_argument(who + ": " + where + " is of type '" + type +
                                "'; transmission_interface/SimpleTransmission and "
                                "transmission_interface/DifferentialTransmission are read");
  return {ros2, simple};
}

/// A transmission's joints and actuators, as many of each as its type has.
struct TransmissionParts {
  std::vector<TransmissionPart> joints, actuators;
};

inline TransmissionParts transmission_parts(const XmlElement& e, const TransmissionKind& kind,
                                            const std::string& where) {
  const std::string who = transmission_who();
  const bool ros2 = kind.ros2, simple = kind.simple;
  TransmissionParts parts;
  std::vector<TransmissionPart>& joints = parts.joints;
  std::vector<TransmissionPart>& actuators = parts.actuators;
  for (const auto& c : e.children) {
    if (c.name == "joint") joints.emplace_back(c, ros2, where);
    if (c.name == "actuator") actuators.emplace_back(c, ros2, where);
  }
  const std::size_t count = simple ? 1 : 2;
  if (joints.size() != count || actuators.size() != count)
    throw std::invalid_argument(who + ": " + where + " has " + std::to_string(joints.size()) +
                                " joints and " + std::to_string(actuators.size()) +
                                " actuators; a " + (simple ? "Simple" : "Differential") +
                                "Transmission has " + std::to_string(count) + " of each");
  return parts;
}

/// A SimpleTransmission's reduction n, read where ros_control (the actuator's) or ros2_control
/// (the joint's) reads it.
inline double simple_transmission_ratio(const TransmissionPart& joint,
                                        const TransmissionPart& actuator, bool ros2) {
  const std::string who = transmission_who();
  double ratio = 0.0;
  if (ros2) {
    ratio = joint.reduction(1.0);
    if (actuator.has_reduction()) {
      const double a = actuator.reduction(1.0);
      if (a != 1.0 && a != ratio)
        throw std::invalid_argument(
            who + ": " + actuator.where() + ": <mechanical_reduction> " + std::to_string(a) +
            " differs from the joint's (" + std::to_string(ratio) +
            "); ros2_control's SimpleTransmission reads only the joint's, so state it there");
    }
  } else {
    ratio = actuator.reduction(std::numeric_limits<double>::quiet_NaN());
    if (joint.has_reduction() && joint.reduction(1.0) != 1.0)
      throw std::invalid_argument(who + ": " + joint.where() +
                                  ": ros_control's SimpleTransmission reads the reduction " +
                                  "from the actuator's <mechanicalReduction>, not the joint's");
  }
  return ratio;
}

/// A DifferentialTransmission's 2 x 2 block of G and its joints' offsets (the file comment).
inline void set_differential_transmission(const TransmissionParts& parts,
                                          const std::vector<Eigen::Index>& at, bool ros2,
                                          const std::string& where, Eigen::MatrixXd& g,
                                          Eigen::VectorXd& zero) {
  const std::vector<TransmissionPart>& joints = parts.joints;
  const std::vector<TransmissionPart>& actuators = parts.actuators;
  const std::array<std::size_t, 2> j = role_order(joints, "joint", ros2, where);
  const std::array<std::size_t, 2> a = role_order(actuators, "actuator", ros2, where);
  const double required = ros2 ? 1.0 : std::numeric_limits<double>::quiet_NaN();
  const double a1 = actuators[a[0]].reduction(required);
  const double a2 = actuators[a[1]].reduction(required);
  const double n1 = joints[j[0]].reduction(1.0), n2 = joints[j[1]].reduction(1.0);
  const Eigen::Index j1 = at[j[0]], j2 = at[j[1]];
  g(j1, j1) = a1 * n1;  // q_a1 = na1 (nj1 (q_j1 - x1) + nj2 (q_j2 - x2))
  g(j1, j2) = a1 * n2;
  g(j2, j1) = a2 * n1;  // q_a2 = na2 (nj1 (q_j1 - x1) - nj2 (q_j2 - x2))
  g(j2, j2) = -a2 * n2;
  zero[j1] = joints[j[0]].offset();
  zero[j2] = joints[j[1]].offset();
}

}  // namespace detail

/// @brief The transmission of a chain from the ros_control / ros2_control `<transmission>`
/// elements of a robot description (a URDF, or any XML holding them: at the top of `<robot>`,
/// inside `<ros2_control>`, or a lone `<transmission>`).
///
/// Two forms are read. ROS 1 (ros_control): `<type>transmission_interface/SimpleTransmission
/// </type>`, the actuator's `<mechanicalReduction>` (required), the joint's `<offset>`
/// (optional, 0) and, for a differential, `<role>` elements (actuator1/actuator2,
/// joint1/joint2; required) and the joints' optional `<mechanicalReduction>` (1). ROS 2
/// (ros2_control): `<plugin>transmission_interface/SimpleTransmission</plugin>`, the joint's
/// `<mechanical_reduction>` (1 when absent, as ros2_control) and `<offset>` (0); an actuator's
/// `<mechanical_reduction>`, which ros2_control's SimpleTransmission ignores, must be 1 or the
/// joint's; for a differential the actuators' and joints' `<mechanical_reduction>` (1) in the
/// order written (roles, if given, must say the same). Hardware interfaces are not read.
/// SimpleTransmission gives G(j, j) = n and zero(j) = offset; DifferentialTransmission the
/// 2 x 2 block of the file comment. Joints no transmission drives keep ratio 1 and zero 0.
/// A transmission none of whose joints is on the chain is skipped when the document defines
/// those joints (a `<joint>` of its `<robot>`: a gripper finger off the chain).
/// @param joint_names the chain's joints, base first (UrdfChain::joint_names): G's order.
/// @throws std::invalid_argument naming the transmission and element: malformed XML, no
///         `<transmission>`, none that drives a joint of the chain, a missing or unsupported
///         type, a wrong number of joints or actuators, a missing name, a reduction that is 0,
///         not a number or (a ROS 1 actuator's) missing, an offset that is not a number, the
///         other ROS version's reduction tag, a joint neither on the chain nor defined by the
///         document, a differential with one joint off the chain or one joint twice, a joint
///         driven by two transmissions, roles that do not fit.
inline Transmission transmission_from_urdf(const std::string& text,
                                           const std::vector<std::string>& joint_names) {
  const std::string who = detail::transmission_who();
  const detail::XmlElement root = detail::XmlParser(text, who).parse_document();
  std::vector<const detail::XmlElement*> transmissions;
  detail::collect_transmissions(root, transmissions);
  if (transmissions.empty())
    throw std::invalid_argument(who + ": the document has no <transmission> element");
  const std::set<std::string> defined = detail::robot_joints(root);

  const auto n = static_cast<Eigen::Index>(joint_names.size());
  Eigen::MatrixXd g = Eigen::MatrixXd::Identity(n, n);
  Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  std::vector<std::string> driven_by(joint_names.size());
  bool any = false;
  for (std::size_t t = 0; t < transmissions.size(); ++t) {
    const detail::XmlElement& e = *transmissions[t];
    const std::string* name = e.attribute("name");
    const std::string where =
        "transmission " + (name ? "'" + *name + "'" : "#" + std::to_string(t + 1));
    const std::vector<Eigen::Index> at =
        detail::transmission_joint_indices(e, where, joint_names, defined);
    const auto off_chain = static_cast<std::size_t>(std::count(at.begin(), at.end(), -1));
    if (!at.empty() && off_chain == at.size()) continue;  // it drives joints off the chain

    const detail::TransmissionKind kind = detail::transmission_kind(e, where);
    const bool ros2 = kind.ros2, simple = kind.simple;
    const detail::TransmissionParts parts = detail::transmission_parts(e, kind, where);
    const std::vector<detail::TransmissionPart>& joints = parts.joints;
    const std::vector<detail::TransmissionPart>& actuators = parts.actuators;
    if (off_chain > 0)
      throw std::invalid_argument(who + ": " + where + " couples a joint of the chain with one " +
                                  "off it; both of a differential's joints must be on the chain");
    if (!simple && at[0] == at[1])
      throw std::invalid_argument(who + ": " + where + " names joint '" + joints[0].name() +
                                  "' twice");
    for (std::size_t k = 0; k < joints.size(); ++k) {
      std::string& by = driven_by[static_cast<std::size_t>(at[k])];
      if (!by.empty())
        throw std::invalid_argument(who + ": joint '" + joints[k].name() + "' is driven by " + by +
                                    " and by " + where);
      by = where;
    }
    any = true;

    if (simple) {
      g(at[0], at[0]) = detail::simple_transmission_ratio(joints[0], actuators[0], ros2);
      zero[at[0]] = joints[0].offset();
      continue;
    }
    detail::set_differential_transmission(parts, at, ros2, where, g, zero);
  }
  if (!any) throw std::invalid_argument(who + ": no <transmission> drives a joint of the chain");
  return Transmission(g, zero);
}

}  // namespace sid
