#include "urdf_writer.hpp"

#include <sid/detail/xml.hpp>
#include <sid/model/urdf.hpp>

#include "csv.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cstdio>
#include <stdexcept>

namespace sid::app {
namespace {

/// The <inertial> element of a link's own ten parameters: its centre of mass as the origin, the
/// inertia about it in the link's axes.
std::string inertial_element(const sid::LinkParameters<double>& phi, const std::string& indent) {
  const sid::LinkInertia<double> body = sid::link_inertia(phi);
  const double m = body.mass;
  const Eigen::Vector3d& c = body.com;
  const Eigen::Matrix3d& ic = body.inertia_com;
  return "<inertial>\n" + indent + "  <origin xyz=\"" + format_double(c[0]) + " " +
         format_double(c[1]) + " " + format_double(c[2]) + "\" rpy=\"0 0 0\"/>\n" + indent +
         "  <mass value=\"" + format_double(m) + "\"/>\n" + indent + "  <inertia ixx=\"" +
         format_double(ic(0, 0)) + "\" ixy=\"" + format_double(ic(0, 1)) + "\" ixz=\"" +
         format_double(ic(0, 2)) + "\" iyy=\"" + format_double(ic(1, 1)) + "\" iyz=\"" +
         format_double(ic(1, 2)) + "\" izz=\"" + format_double(ic(2, 2)) + "\"/>\n" + indent +
         "</inertial>";
}

/// [begin, end) of the <tag> element named name in the text, and whether it is self-closing.
bool find_element(const std::string& text, const std::string& tag, const std::string& name,
                  std::size_t& begin, std::size_t& end, bool& self_closing) {
  const std::string open = "<" + tag, close_tag = "</" + tag + ">";
  for (std::size_t at = text.find(open); at != std::string::npos; at = text.find(open, at + 1)) {
    const std::size_t after = at + open.size();
    const char next = after < text.size() ? text[after] : '\0';
    if (next != ' ' && next != '\t' && next != '\n' && next != '\r') continue;
    const std::size_t close = text.find('>', at);
    if (close == std::string::npos) return false;
    const std::string head = text.substr(at, close - at + 1);
    if (head.find("name=\"" + name + "\"") == std::string::npos &&
        head.find("name='" + name + "'") == std::string::npos)
      continue;
    // A robot's <joint> has a type; a <transmission>'s <joint> only names one.
    if (tag == "joint" && head.find("type=") == std::string::npos) continue;
    begin = at;
    self_closing = text[close - 1] == '/';
    if (self_closing) {
      end = close + 1;
      return true;
    }
    const std::size_t finish = text.find(close_tag, close);
    if (finish == std::string::npos) return false;
    end = finish + close_tag.size();
    return true;
  }
  return false;
}

/// The joint element's text with its <dynamics> replaced by (or given) `dynamics`.
std::string with_dynamics(std::string joint, const std::string& dynamics) {
  const std::size_t d0 = joint.find("<dynamics");
  if (d0 == std::string::npos) {
    const std::size_t finish = joint.rfind("</joint>");
    joint.insert(finish, "  " + dynamics + "\n  ");
    return joint;
  }
  const std::size_t tag_end = joint.find('>', d0);
  std::size_t d1 = tag_end + 1;
  if (joint[tag_end - 1] != '/') d1 = joint.find("</dynamics>", d0) + 11;
  joint.replace(d0, d1 - d0, dynamics);
  return joint;
}

/// A real body has a positive semidefinite pseudo-inertia (Wensing et al. 2018); the fit's links
/// may lie at its boundary (a body flat along one axis), so round-off is allowed for.
bool real_body(const sid::LinkParameters<double>& phi) {
  const Eigen::Matrix4d pseudo = sid::pseudo_inertia(phi);
  const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(pseudo).eigenvalues()[0];
  return phi[0] > 0.0 && smallest >= -1e-12 * pseudo.trace();
}

/// The real body nearest to phi: its pseudo-inertia with the negative eigenvalues raised to
/// (nearly) zero, the nearest positive semidefinite matrix in the Frobenius norm. The floor
/// keeps the body strictly inside (simulators refuse principal moments that break the triangle
/// inequality by round-off).
sid::LinkParameters<double> nearest_real_body(const sid::LinkParameters<double>& phi) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eigen(sid::pseudo_inertia(phi));
  const double floor = 1e-9 * eigen.eigenvalues().cwiseAbs().maxCoeff();
  const Eigen::Matrix4d j = eigen.eigenvectors() *
                            eigen.eigenvalues().cwiseMax(floor).asDiagonal() *
                            eigen.eigenvectors().transpose();
  const Eigen::Matrix3d sigma = j.topLeftCorner<3, 3>();
  const Eigen::Matrix3d i = sigma.trace() * Eigen::Matrix3d::Identity() - sigma;
  sid::LinkParameters<double> out;
  out << j(3, 3), j(0, 3), j(1, 3), j(2, 3), i(0, 0), i(0, 1), i(1, 1), i(0, 2), i(1, 2), i(2, 2);
  return out;
}

std::string format_percent(double fraction) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.2g %%", 100.0 * fraction);
  return buffer;
}

/// The links with a body fixed below `link` (through fixed joints only), and the sum of their
/// bodies in link's frame.
std::pair<std::vector<std::string>, sid::LinkParameters<double>> fixed_bodies(
    const sid::detail::UrdfTree& tree, const std::string& link) {
  std::vector<std::string> names;
  sid::LinkParameters<double> sum = sid::LinkParameters<double>::Zero();
  std::vector<std::pair<std::string, sid::FramePose<double>>> pending{{link, {}}};
  while (!pending.empty()) {
    const auto [parent, at] = pending.back();
    pending.pop_back();
    const auto from = tree.joints_from.find(parent);
    if (from == tree.joints_from.end()) continue;
    for (const sid::detail::XmlElement* joint : from->second) {
      if (sid::detail::urdf_type(*joint) != "fixed") continue;
      const std::string child = sid::detail::UrdfTree::end_link(*joint, "child");
      const sid::FramePose<double> pose =
          sid::detail::compose(at, sid::detail::urdf_joint_pose(*joint, "fixed", 0.0));
      const sid::LinkInertia<double> body = sid::detail::urdf_inertia(tree.link(child));
      if (body.mass > 0.0) {
        names.push_back(child);
        sum += sid::detail::moved_parameters(body, pose);
      }
      pending.emplace_back(child, pose);
    }
  }
  return {names, sum};
}

/// The link element's text with its <inertial> replaced by `inertial` (or given it).
std::string with_inertial(std::string element_text, const std::string& inertial,
                          const std::string& link) {
  if (element_text.size() >= 2 && element_text.compare(element_text.size() - 2, 2, "/>") == 0) {
    element_text.erase(element_text.size() - 2);
    return element_text + ">\n    " + inertial + "\n  </link>";
  }
  const std::size_t i0 = element_text.find("<inertial");
  if (i0 == std::string::npos) {
    const std::size_t open = element_text.find('>');
    element_text.insert(open + 1, "\n    " + inertial);
    return element_text;
  }
  std::size_t i1 = element_text.find("</inertial>", i0);
  const std::size_t tag_end = element_text.find('>', i0);
  if (element_text[tag_end - 1] == '/')
    i1 = tag_end + 1;
  else if (i1 == std::string::npos)
    throw InputError("link '" + link + "' has an unterminated <inertial>");
  else
    i1 += 11;
  element_text.replace(i0, i1 - i0, inertial);
  return element_text;
}

}  // namespace

std::string urdf_with_link_parameters(const std::string& urdf, const std::string& base,
                                      const std::string& tip, const std::vector<std::string>& links,
                                      const std::vector<sid::LinkParameters<double>>& phi,
                                      const std::string& what) {
  const sid::UrdfChain described = sid::chain_from_urdf(urdf, base, tip);
  const sid::detail::XmlElement robot = sid::detail::XmlParser(urdf, "urdf").parse_document();
  const sid::detail::UrdfTree tree(robot);
  std::string out = urdf;
  std::vector<sid::LinkParameters<double>> written = phi;  // what each link's bodies sum to
  const auto replace_link = [&](const std::string& link, const std::string& inertial) {
    std::size_t begin = 0, end = 0;
    bool self_closing = false;
    if (!find_element(out, "link", link, begin, end, self_closing))
      throw InputError(what + ": cannot find the text of link '" + link + "'");
    try {
      out.replace(begin, end - begin,
                  with_inertial(out.substr(begin, end - begin), inertial, link));
    } catch (const InputError& e) {
      throw InputError(what + ": " + e.what());
    }
  };
  for (std::size_t k = 0; k < links.size(); ++k) {
    if (!tree.links.count(links[k]))
      throw InputError(what + ": no link '" + links[k] + "' in the description");
    const sid::LinkParameters<double> own_cad =
        sid::standard_parameters(sid::detail::urdf_inertia(tree.link(links[k])));
    const sid::LinkParameters<double> carried =
        described.theta.segment<10>(10 * static_cast<Eigen::Index>(k)) - own_cad;
    sid::LinkParameters<double> own = phi[k] - carried;
    std::vector<std::string> lumped;
    std::string note;
    if (!real_body(own)) {
      // What is fixed to the link moves with it as one body: the data see only their sum, so
      // when the description's share of it leaves no real body for the link, the link takes it
      // all.
      const auto [fixed, fixed_sum] = fixed_bodies(tree, links[k]);
      if (!fixed.empty()) {
        own += fixed_sum;
        lumped = fixed;
        for (const std::string& other : lumped) note += (note.empty() ? "" : ", ") + other;
        note = "with the bodies of " + note + ", fixed to it: the data see one body";
      }
      if (!real_body(own)) {
        // A consistent fit may lie on the boundary of real bodies, where the description's
        // carried bodies do not fit inside it: the nearest real body is written instead.
        if (!(own[0] > 0.0))
          throw InputError(what + ": link '" + links[k] +
                           "' is lighter than the bodies it carries in the description");
        const sid::LinkParameters<double> nearest = nearest_real_body(own);
        const double change = (nearest - own).cwiseAbs().maxCoeff() /
                              std::max(phi[k].segment<6>(4).cwiseAbs().maxCoeff(), 1e-300);
        note += std::string(note.empty() ? "" : "; ") +
                "the nearest real body to the identified one less the bodies it carries (its "
                "inertia differs by " +
                format_percent(change) + " of the largest moment)";
        written[k] += nearest - own;
        own = nearest;
      }
    }
    for (const std::string& other : lumped)
      replace_link(other, "<!-- its body is in the <inertial> of link '" + links[k] + "' -->");
    const std::string indent = "    ";
    replace_link(links[k], (note.empty() ? "" : "<!-- " + note + " -->\n" + indent) +
                               inertial_element(own, indent));
  }
  // What was written must read back as what was identified (or its nearest real bodies).
  const sid::UrdfChain back_chain = sid::chain_from_urdf(out, base, tip);
  for (std::size_t k = 0; k < links.size(); ++k) {
    const sid::LinkParameters<double> back =
        back_chain.theta.segment<10>(10 * static_cast<Eigen::Index>(k));
    if ((back - written[k]).cwiseAbs().maxCoeff() > 1e-9 * (1.0 + written[k].cwiseAbs().maxCoeff()))
      throw std::runtime_error(what + ": link '" + links[k] + "' does not read back as identified");
  }
  return out;
}

std::string urdf_with_joint_dynamics(const std::string& urdf,
                                     const std::vector<std::string>& joints,
                                     const Eigen::VectorXd& damping,
                                     const Eigen::VectorXd& friction,
                                     const std::vector<std::string>& left_out) {
  std::string out = urdf;
  for (std::size_t j = 0; j < joints.size(); ++j) {
    std::size_t begin = 0, end = 0;
    bool self_closing = false;
    if (!find_element(out, "joint", joints[j], begin, end, self_closing) || self_closing)
      throw InputError("--write-urdf: cannot find the text of joint '" + joints[j] + "'");
    const auto at = static_cast<Eigen::Index>(j);
    out.replace(begin, end - begin,
                with_dynamics(out.substr(begin, end - begin),
                              "<dynamics damping=\"" + format_double(damping[at]) +
                                  "\" friction=\"" + format_double(friction[at]) + "\"/>"));
  }
  std::string note =
      "<!-- Identified by sid: the links' inertials and the joints' viscous and Coulomb friction "
      "(damping, friction).";
  if (!left_out.empty()) {
    note += " A URDF has no place for";
    for (std::size_t i = 0; i < left_out.size(); ++i) note += (i == 0 ? " " : ", ") + left_out[i];
    note += "; the identification's JSON keeps them.";
  }
  note += " -->";
  const std::size_t robot = out.find("<robot");
  const std::size_t open_end = robot == std::string::npos ? robot : out.find('>', robot);
  if (open_end == std::string::npos) throw InputError("--write-urdf: the URDF has no <robot>");
  out.insert(open_end + 1, "\n  " + note);
  return out;
}

}  // namespace sid::app
