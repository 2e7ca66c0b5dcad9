#include "urdf_writer.hpp"

#include <sid/detail/xml.hpp>
#include <sid/model/urdf.hpp>

#include "csv.hpp"

#include <Eigen/Eigenvalues>

#include <cstdio>
#include <stdexcept>

namespace sid::app {
namespace {

std::string number(double v) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

/// The <inertial> element of a link's own ten parameters: its centre of mass as the origin, the
/// inertia about it in the link's axes.
std::string inertial_element(const sid::LinkParameters<double>& phi, const std::string& indent) {
  const sid::LinkInertia<double> body = sid::link_inertia(phi);
  const double m = body.mass;
  const Eigen::Vector3d& c = body.com;
  const Eigen::Matrix3d& ic = body.inertia_com;
  return "<inertial>\n" + indent + "  <origin xyz=\"" + number(c[0]) + " " + number(c[1]) + " " +
         number(c[2]) + "\" rpy=\"0 0 0\"/>\n" + indent + "  <mass value=\"" + number(m) +
         "\"/>\n" + indent + "  <inertia ixx=\"" + number(ic(0, 0)) + "\" ixy=\"" +
         number(ic(0, 1)) + "\" ixz=\"" + number(ic(0, 2)) + "\" iyy=\"" + number(ic(1, 1)) +
         "\" iyz=\"" + number(ic(1, 2)) + "\" izz=\"" + number(ic(2, 2)) + "\"/>\n" + indent +
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

}  // namespace

std::string urdf_with_link_parameters(const std::string& urdf, const std::string& base,
                                      const std::string& tip, const std::vector<std::string>& links,
                                      const std::vector<sid::LinkParameters<double>>& phi) {
  const sid::UrdfChain described = sid::chain_from_urdf(urdf, base, tip);
  const sid::detail::XmlElement robot = sid::detail::XmlParser(urdf, "urdf").parse_document();
  std::string out = urdf;
  for (std::size_t k = 0; k < links.size(); ++k) {
    const sid::detail::XmlElement* element = nullptr;
    for (const auto& e : robot.children)
      if (e.name == "link" && e.attribute("name") && *e.attribute("name") == links[k]) element = &e;
    if (!element) throw InputError("--write-urdf: no link '" + links[k] + "' in the description");
    const sid::LinkParameters<double> own_cad =
        sid::standard_parameters(sid::detail::urdf_inertia(*element));
    const sid::LinkParameters<double> carried =
        described.theta.segment<10>(10 * static_cast<Eigen::Index>(k)) - own_cad;
    const sid::LinkParameters<double> own = phi[k] - carried;
    // A real body has a positive semidefinite pseudo-inertia (Wensing et al. 2018); the fit's
    // links may lie at its boundary (a body flat along one axis), so round-off is allowed for.
    const Eigen::Matrix4d pseudo = sid::pseudo_inertia(own);
    const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(pseudo).eigenvalues()[0];
    if (!(own[0] > 0.0) || smallest < -1e-12 * pseudo.trace())
      throw InputError("--write-urdf: link '" + links[k] +
                       "' less the bodies it carries in the description is not a real body");
    std::size_t begin = 0, end = 0;
    bool self_closing = false;
    if (!find_element(out, "link", links[k], begin, end, self_closing))
      throw InputError("--write-urdf: cannot find the text of link '" + links[k] + "'");
    const std::string indent = "    ";
    std::string element_text = out.substr(begin, end - begin);
    if (self_closing) {
      element_text.erase(element_text.size() - 2);
      element_text += ">\n" + indent + inertial_element(own, indent) + "\n  </link>";
    } else {
      const std::size_t i0 = element_text.find("<inertial");
      if (i0 == std::string::npos) {
        const std::size_t open = element_text.find('>');
        element_text.insert(open + 1, "\n" + indent + inertial_element(own, indent));
      } else {
        std::size_t i1 = element_text.find("</inertial>", i0);
        const std::size_t tag_end = element_text.find('>', i0);
        if (element_text[tag_end - 1] == '/')
          i1 = tag_end + 1;
        else if (i1 == std::string::npos)
          throw InputError("--write-urdf: link '" + links[k] + "' has an unterminated <inertial>");
        else
          i1 += 11;
        element_text.replace(i0, i1 - i0, inertial_element(own, indent));
      }
    }
    out.replace(begin, end - begin, element_text);
  }
  // What was written must read back as what was identified.
  const sid::UrdfChain written = sid::chain_from_urdf(out, base, tip);
  for (std::size_t k = 0; k < links.size(); ++k) {
    const sid::LinkParameters<double> back =
        written.theta.segment<10>(10 * static_cast<Eigen::Index>(k));
    if ((back - phi[k]).cwiseAbs().maxCoeff() > 1e-9 * (1.0 + phi[k].cwiseAbs().maxCoeff()))
      throw std::runtime_error("--write-urdf: link '" + links[k] +
                               "' does not read back as identified");
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
                              "<dynamics damping=\"" + number(damping[at]) + "\" friction=\"" +
                                  number(friction[at]) + "\"/>"));
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
