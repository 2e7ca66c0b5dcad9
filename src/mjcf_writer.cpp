#include "mjcf_writer.hpp"

#include <sid/detail/xml.hpp>
#include <sid/model/urdf.hpp>

#include "app.hpp"
#include "svg_plot.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace sid::app {
namespace {

namespace fs = std::filesystem;
using sid::detail::XmlElement;

std::string triple(const Eigen::Vector3d& v) {
  return shortest_number(v[0]) + " " + shortest_number(v[1]) + " " + shortest_number(v[2]);
}

std::string quoted(const std::string& text) { return "\"" + xml_escaped(text) + "\""; }

/// MuJoCo's pos and quat (w x y z) of a URDF pose, each left out where it is the identity.
std::string placement(const sid::FramePose<double>& pose) {
  std::string out;
  if (!pose.translation.isZero(0.0)) out += " pos=\"" + triple(pose.translation) + "\"";
  if (!pose.rotation.isIdentity(0.0)) {
    const Eigen::Quaterniond q(pose.rotation);
    out += " quat=\"" + shortest_number(q.w()) + " " + triple(q.vec()) + "\"";
  }
  return out;
}

std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

/// The file a URDF mesh names: file://, package:// (a directory of that name at or above the
/// URDF's, or under ROS_PACKAGE_PATH), or a path relative to the URDF.
std::optional<fs::path> mesh_file(const std::string& uri, const fs::path& urdf_directory) {
  const std::string file = "file://", package = "package://";
  std::vector<fs::path> candidates;
  if (uri.rfind(file, 0) == 0) {
    candidates.emplace_back(uri.substr(file.size()));
  } else if (uri.rfind(package, 0) == 0) {
    const std::string rest = uri.substr(package.size());
    const std::size_t slash = rest.find('/');
    const std::string name = rest.substr(0, slash);
    const std::string inside = slash == std::string::npos ? "" : rest.substr(slash + 1);
    for (fs::path at = fs::absolute(urdf_directory); !at.empty(); at = at.parent_path()) {
      if (at.filename() == name) candidates.push_back(at / inside);
      candidates.push_back(at / name / inside);
      if (at == at.parent_path()) break;
    }
    if (const char* roots = std::getenv("ROS_PACKAGE_PATH")) {
      std::stringstream in(roots);
      std::string root;
      while (std::getline(in, root, ':'))
        if (!root.empty()) candidates.push_back(fs::path(root) / name / inside);
    }
  } else {
    candidates.push_back(urdf_directory / uri);
  }
  for (const fs::path& candidate : candidates) {
    std::error_code error;
    if (fs::is_regular_file(candidate, error)) return candidate;
  }
  return std::nullopt;
}

std::string joint_type(const std::string& urdf_type) {
  return urdf_type == "prismatic" ? "slide" : "hinge";
}

/// Writes the bodies of a URDF tree as MJCF, collecting its assets, equalities and motors.
class MjcfBuilder {
 public:
  MjcfBuilder(const sid::detail::UrdfTree& tree, const MjcfJointDrives& drives,
              const MjcfPaths& paths)
      : tree_(tree), drives_(drives), paths_(paths) {}

  /// The base link is MuJoCo's world body (whose mass does not matter); every other link is a
  /// body placed by the joint into it.
  void body(const std::string& link, const XmlElement* joint, const std::string& indent) {
    const std::string where = "link '" + link + "'";
    std::string inside = indent;
    if (joint) {
      bodies_ += indent + "<body name=" + quoted(link) +
                 placement(sid::detail::urdf_origin(joint->child("origin"), where)) + ">\n";
      inside += "  ";
      this->joint(*joint, inside);
      inertial(tree_.link(link), inside);
    }
    for (const auto& e : tree_.link(link).children)
      if (e.name == "collision" || e.name == "visual") geom(e, link, inside);
    const auto children = tree_.joints_from.find(link);
    if (children != tree_.joints_from.end())
      for (const XmlElement* child : children->second)
        body(*child->child("child")->attribute("link"), child, inside);
    if (joint) bodies_ += indent + "</body>\n";
  }

  std::string bodies_, assets_, equalities_, motors_;
  std::vector<std::string> left_out_;
  std::vector<std::string> written_joints_;
  bool unbalanced_ = false;

 private:
  void joint(const XmlElement& joint, const std::string& indent) {
    const std::string name = sid::detail::UrdfTree::joint_name(joint);
    const std::string type = sid::detail::urdf_type(joint);
    if (type == "fixed") return;
    if (!sid::detail::urdf_moves(type)) {
      left_out_.push_back("joint '" + name + "' (" + type + ": its child is welded)");
      return;
    }
    const sid::UrdfJoint info = sid::detail::urdf_joint_info(joint, type);
    std::string text = indent + "<joint name=" + quoted(name) + " type=\"" + joint_type(type) +
                       "\" axis=\"" +
                       triple(sid::detail::urdf_axis(joint, "joint '" + name + "'")) + "\"";
    if (type != "continuous" && info.limit.lower < info.limit.upper)
      text += " range=\"" + shortest_number(info.limit.lower) + " " +
              shortest_number(info.limit.upper) + "\"";
    double damping = info.damping, friction = info.friction, armature = 0.0, stiffness = 0.0;
    const auto drive = std::find(drives_.joints.begin(), drives_.joints.end(), name);
    if (drive != drives_.joints.end()) {
      const auto j = static_cast<Eigen::Index>(drive - drives_.joints.begin());
      damping = drives_.damping[j];
      friction = drives_.friction[j];
      armature = drives_.armature[j];
      stiffness = drives_.stiffness[j];
      motors_ += "    <motor name=" + quoted(name) + " joint=" + quoted(name);
      if (std::isfinite(info.limit.effort) && info.limit.effort > 0.0)
        motors_ += " ctrlrange=\"" + shortest_number(-info.limit.effort) + " " +
                   shortest_number(info.limit.effort) + "\"";
      motors_ += "/>\n";
    }
    text += attribute(name, "damping", damping) + attribute(name, "frictionloss", friction) +
            attribute(name, "armature", armature) + attribute(name, "stiffness", stiffness);
    bodies_ += text + "/>\n";
    written_joints_.push_back(name);
    if (info.mimic)
      equalities_ += "    <joint joint1=" + quoted(name) + " joint2=" + quoted(info.mimic->joint) +
                     " polycoef=\"" + shortest_number(info.mimic->offset) + " " +
                     shortest_number(info.mimic->multiplier) + " 0 0 0\"/>\n";
  }

  /// A drive value as a joint attribute: none when zero; a negative one is not physical, and
  /// MuJoCo would refuse it.
  std::string attribute(const std::string& joint, const char* key, double value) {
    if (value == 0.0) return "";
    if (!(value > 0.0)) {
      left_out_.push_back("joint '" + joint + "' " + key + " " + shortest_number(value) +
                          " (negative)");
      return "";
    }
    return std::string(" ") + key + "=\"" + shortest_number(value) + "\"";
  }

  void inertial(const XmlElement& link, const std::string& indent) {
    if (!link.child("inertial")) return;
    const sid::LinkInertia<double> body = sid::detail::urdf_inertia(link);
    if (!(body.mass > 0.0)) return;
    Eigen::Matrix3d i = body.inertia_com;
    // MuJoCo refuses principal moments that break the triangle inequality. A body at the edge of
    // real ones (a fit's flat link) breaks it by round-off: the same inertia added about every
    // axis closes that gap. A description's body that breaks it for real is balanced by MuJoCo
    // (balanceinertia), and said so.
    const Eigen::Vector3d moments = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(i).eigenvalues();
    const double gap = moments[2] - moments[0] - moments[1];
    if (gap > 1e-9 * moments[2]) {
      unbalanced_ = true;
      left_out_.push_back("link '" + *link.attribute("name") +
                          "' inertia as given (no real body has it: MuJoCo balances it)");
    } else if (gap >= 0.0) {
      i.diagonal().array() += gap + 1e-12 * moments[2];
    }
    // Nor does it take a point mass or a rod (a moment of zero).
    const double least = std::max(1e-9 * moments[2], 1e-12);
    if (moments[0] < least) {
      i.diagonal().array() += least - moments[0];
      left_out_.push_back("link '" + *link.attribute("name") + "' inertia as given (a moment of " +
                          shortest_number(moments[0]) + " kg m^2: raised to " +
                          shortest_number(least) + ")");
    }
    bodies_ += indent + "<inertial pos=\"" + triple(body.com) + "\" mass=\"" +
               shortest_number(body.mass) + "\" fullinertia=\"" + shortest_number(i(0, 0)) + " " +
               shortest_number(i(1, 1)) + " " + shortest_number(i(2, 2)) + " " +
               shortest_number(i(0, 1)) + " " + shortest_number(i(0, 2)) + " " +
               shortest_number(i(1, 2)) + "\"/>\n";
  }

  void geom(const XmlElement& shape, const std::string& link, const std::string& indent) {
    const XmlElement* geometry = shape.child("geometry");
    if (!geometry || geometry->children.empty()) return;
    const XmlElement& g = geometry->children.front();
    const std::string where = "link '" + link + "' <" + shape.name + ">";
    std::string kind;
    if (g.name == "box") {
      kind = "type=\"box\" size=\"" +
             triple(0.5 * sid::detail::urdf_triple(&g, "size", Eigen::Vector3d::Zero(), where)) +
             "\"";
    } else if (g.name == "cylinder") {
      kind = "type=\"cylinder\" size=\"" +
             shortest_number(sid::detail::urdf_number(g, "radius", where)) + " " +
             shortest_number(0.5 * sid::detail::urdf_number(g, "length", where)) + "\"";
    } else if (g.name == "sphere") {
      kind = "type=\"sphere\" size=\"" +
             shortest_number(sid::detail::urdf_number(g, "radius", where)) + "\"";
    } else if (g.name == "mesh") {
      kind = mesh(g, where);
      if (kind.empty()) return;
    } else {
      left_out_.push_back(where + " " + g.name);
      return;
    }
    std::string text = indent + "<geom " + kind +
                       placement(sid::detail::urdf_origin(shape.child("origin"), where));
    // A <visual> shape is drawn (group 1, MuJoCo's default view) but does not collide.
    if (shape.name == "visual") text += " contype=\"0\" conaffinity=\"0\" group=\"1\"";
    bodies_ += text + "/>\n";
  }

  std::string mesh(const XmlElement& g, const std::string& where) {
    const std::string* uri = g.attribute("filename");
    if (!uri) throw InputError("--write-mjcf: " + where + " has a <mesh> without a filename");
    const std::optional<fs::path> file = mesh_file(*uri, paths_.urdf_directory);
    const std::string extension = file ? lowercase(file->extension().string()) : "";
    if (!file || (extension != ".stl" && extension != ".obj" && extension != ".msh")) {
      left_out_.push_back(where + " mesh " + *uri +
                          (file ? " (MuJoCo reads STL, OBJ and MSH meshes)" : " (not found)"));
      return "";
    }
    const std::string name = "mesh" + std::to_string(meshes_++);
    std::error_code error;
    fs::path written = fs::absolute(*file);
    const fs::path from = fs::absolute(
        paths_.mjcf_directory.empty() ? fs::path(".") : fs::path(paths_.mjcf_directory));
    const fs::path relative = fs::relative(written, from, error);
    if (!error && !relative.empty()) written = relative;
    assets_ += "    <mesh name=\"" + name + "\" file=" + quoted(written.generic_string());
    if (g.attribute("scale"))
      assets_ += " scale=\"" +
                 triple(sid::detail::urdf_triple(&g, "scale", Eigen::Vector3d::Ones(), where)) +
                 "\"";
    assets_ += "/>\n";
    return "type=\"mesh\" mesh=\"" + name + "\"";
  }

  const sid::detail::UrdfTree& tree_;
  const MjcfJointDrives& drives_;
  const MjcfPaths& paths_;
  int meshes_ = 0;
};

/// The XML comment at the top: what sid identified, what the MJCF has no place for.
std::string note(const std::string& base, const std::vector<std::string>& not_written,
                 const std::vector<std::string>& left_out) {
  std::string text =
      "Identified by sid: the chain's links (inertial) and its joints' damping, "
      "frictionloss,\n       armature and stiffness. The world body is link '" +
      base + "'.\n";
  if (!not_written.empty()) {
    text += "       MJCF has no place for";
    for (std::size_t i = 0; i < not_written.size(); ++i)
      text += (i == 0 ? " " : ", ") + not_written[i];
    text += " (the identification's JSON keeps them).\n";
  }
  if (!left_out.empty()) {
    text += "       Left out of the description:\n";
    for (const std::string& item : left_out) text += "         " + item + "\n";
  }
  // "--" may not appear inside an XML comment.
  for (std::size_t at = text.find("--"); at != std::string::npos; at = text.find("--", at))
    text.replace(at, 2, "- -");
  return "  <!-- " + text + "  -->\n";
}

}  // namespace

Mjcf mjcf_from_urdf(const std::string& urdf, const std::string& base,
                    const Eigen::Vector3d& gravity, const MjcfJointDrives& drives,
                    const std::vector<std::string>& not_written, const MjcfPaths& paths) {
  try {
    const XmlElement robot = sid::detail::XmlParser(urdf, "--write-mjcf").parse_document();
    if (robot.name != "robot")
      throw InputError("--write-mjcf: the root element is <" + robot.name + ">, not <robot>");
    const sid::detail::UrdfTree tree(robot);
    (void)tree.link(base);
    MjcfBuilder builder(tree, drives, paths);
    builder.body(base, nullptr, "    ");
    for (const std::string& joint : drives.joints)
      if (std::find(builder.written_joints_.begin(), builder.written_joints_.end(), joint) ==
          builder.written_joints_.end())
        throw InputError("--write-mjcf: joint '" + joint + "' is not a moving joint below '" +
                         base + "'");
    const std::string* name = robot.attribute("name");
    Mjcf out;
    out.left_out = builder.left_out_;
    out.text = "<mujoco model=" + quoted(name ? *name : base) + ">\n" +
               note(base, not_written, out.left_out) +
               "  <compiler angle=\"radian\" autolimits=\"true\" inertiafromgeom=\"false\"" +
               (builder.unbalanced_ ? " balanceinertia=\"true\"" : "") + "/>\n" +
               "  <option gravity=\"" + triple(gravity) + "\"/>\n";
    if (!builder.assets_.empty()) out.text += "  <asset>\n" + builder.assets_ + "  </asset>\n";
    out.text += "  <worldbody>\n" + builder.bodies_ + "  </worldbody>\n";
    if (!builder.equalities_.empty())
      out.text += "  <equality>\n" + builder.equalities_ + "  </equality>\n";
    if (!builder.motors_.empty())
      out.text += "  <actuator>\n" + builder.motors_ + "  </actuator>\n";
    out.text += "</mujoco>\n";
    return out;
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("--write-mjcf: ") + e.what());
  }
}

}  // namespace sid::app
