#include "robot_description.hpp"

#include "app.hpp"

#include <sid/detail/xml.hpp>
#include <sid/model/urdf.hpp>
#include <sid/model/urdf_transmission.hpp>

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <locale>
#include <sstream>
#include <stdexcept>

namespace sid::app {
namespace {

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the file");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

bool is_xml(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r\n\xEF\xBB\xBF");
  return first != std::string::npos && text[first] == '<';
}

/// The root link (no joint leads to it) and the leaves (no joint leaves them) of a URDF.
void urdf_ends(const std::string& path, const std::string& text, std::string& base,
               std::vector<std::string>& leaves) {
  const sid::detail::XmlElement robot = sid::detail::XmlParser(text, path).parse_document();
  std::vector<std::string> links, parents, children;
  for (const auto& e : robot.children) {
    if (e.name == "link" && e.attribute("name")) links.push_back(*e.attribute("name"));
    if (e.name == "joint" && e.child("parent") && e.child("child") &&
        e.child("parent")->attribute("link") && e.child("child")->attribute("link")) {
      parents.push_back(*e.child("parent")->attribute("link"));
      children.push_back(*e.child("child")->attribute("link"));
    }
  }
  const auto has = [](const std::vector<std::string>& v, const std::string& s) {
    return std::find(v.begin(), v.end(), s) != v.end();
  };
  std::vector<std::string> roots;
  for (const auto& l : links) {
    if (!has(children, l)) roots.push_back(l);
    if (!has(parents, l)) leaves.push_back(l);
  }
  if (base.empty()) {
    if (roots.size() != 1)
      throw InputError(path + ": the description has " + std::to_string(roots.size()) +
                       " root links; name the chain's first link with --base");
    base = roots.front();
  }
}

/// A file named *.urdf or *.xml (any case) is read as XML whatever its first character.
bool has_xml_extension(const std::string& path) {
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos || path.find_first_of("/\\", dot) != std::string::npos) return false;
  std::string extension = path.substr(dot + 1);
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension == "urdf" || extension == "xml";
}

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

/// A DH table: "convention standard|modified", optional "gravity gx gy gz", then one line per
/// joint "name a alpha d offset [revolute|prismatic]" [m, rad]; '#' starts a comment. A
/// prismatic row slides along z by q + d at the constant angle offset (sid::dh_placement).
RobotDescription read_dh(const std::string& path, const std::string& text) {
  std::istringstream lines(text);
  std::string line;
  int number = 0;
  bool have_convention = false;
  sid::DhConvention convention = sid::DhConvention::Standard;
  sid::Vector3<double> gravity(0.0, 0.0, -9.81);
  std::vector<sid::DhJoint<double>> rows;
  std::vector<std::string> names;
  while (std::getline(lines, line)) {
    ++number;
    line = line.substr(0, line.find('#'));
    std::istringstream in(line);
    in.imbue(std::locale::classic());
    std::string word;
    if (!(in >> word)) continue;
    const std::string where = path + ", line " + std::to_string(number) + ": ";
    if (word == "convention") {
      std::string value;
      in >> value;
      if (value != "standard" && value != "modified")
        throw InputError(where + "the convention is 'standard' or 'modified', not '" + value + "'");
      convention = value == "standard" ? sid::DhConvention::Standard : sid::DhConvention::Modified;
      have_convention = true;
    } else if (word == "gravity") {
      if (!(in >> gravity[0] >> gravity[1] >> gravity[2]) || !gravity.allFinite())
        throw InputError(where + "gravity needs three finite numbers [m/s^2]");
    } else {
      sid::DhJoint<double> row;
      if (!(in >> row.a >> row.alpha >> row.d >> row.offset) ||
          !std::isfinite(row.a + row.alpha + row.d + row.offset))
        throw InputError(where +
                         "a joint line is 'name a alpha d offset [revolute|prismatic]' with "
                         "four finite numbers [m, rad]");
      std::string type;
      if (in >> type) {
        if (type != "revolute" && type != "prismatic")
          throw InputError(where + "joint '" + word +
                           "': the type is 'revolute' or 'prismatic', not '" + type + "'");
        if (type == "prismatic") row.type = sid::JointType::Prismatic;
      }
      if (std::find(names.begin(), names.end(), word) != names.end())
        throw InputError(where + "joint '" + word + "' is given twice");
      names.push_back(word);
      rows.push_back(row);
    }
    std::string extra;
    if (in >> extra) throw InputError(where + "unexpected '" + extra + "'");
  }
  if (!have_convention)
    throw InputError(path +
                     ": a DH table needs a line 'convention standard' or "
                     "'convention modified'");
  if (rows.empty()) throw InputError(path + ": the DH table has no joints");
  try {
    const auto n = static_cast<Eigen::Index>(rows.size());
    return {sid::SerialChain<double>(convention, rows, gravity),
            names,
            "",
            "",
            "",
            {},
            {},
            Eigen::VectorXd::Zero(n),
            Eigen::VectorXd::Zero(n),
            {}};
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": " + e.what());
  }
}

}  // namespace

sid::FramePose<double> fixed_link_pose(const RobotDescription& robot, const std::string& link,
                                       const std::string& option) {
  if (robot.urdf.empty() || robot.link_names.empty())
    throw InputError(option +
                     " needs a URDF as --robot: a DH table names no frames but its "
                     "links', and a load on it is in its last link's frame");
  const sid::detail::XmlElement document =
      sid::detail::XmlParser(robot.urdf, "urdf").parse_document();
  const sid::detail::UrdfTree tree(document);
  const std::string& moving = robot.link_names.back();
  const std::string attached =
      "; the frame must be fixed to " + moving + ", the chain's last moving link (e.g. " +
      (robot.tip == moving ? std::string() : robot.tip + " or ") + moving + " itself)";
  if (!tree.links.count(link))
    throw InputError(option + ": the URDF has no link '" + link + "'" + attached);
  std::vector<const sid::detail::XmlElement*> path;
  try {
    path = tree.path(moving, link);
  } catch (const std::invalid_argument&) {
    throw InputError(option + ": link '" + link + "' is not below " + moving + attached);
  }
  sid::FramePose<double> pose;
  try {
    for (const sid::detail::XmlElement* joint : path) {
      const std::string name = sid::detail::UrdfTree::joint_name(*joint);
      const std::string type = sid::detail::urdf_type(*joint);
      if (type != "fixed")
        throw InputError(option + ": link '" + link + "' is not rigidly attached to " + moving +
                         ": joint '" + name + "' between them is " + type + attached);
      pose = sid::detail::compose(
          pose, sid::detail::urdf_origin(joint->child("origin"), "joint '" + name + "'"));
    }
  } catch (const std::invalid_argument& e) {
    throw InputError(option + ": " + e.what());
  }
  return pose;
}

std::string payload_frame_name(const RobotDescription& robot, const std::string& frame,
                               const std::string& option) {
  if (!robot.urdf.empty()) return frame.empty() ? robot.tip : frame;
  if (!frame.empty())
    throw InputError(option +
                     " needs a URDF as --robot: with a DH table the load is in its last link's "
                     "frame, the only one it names");
  return {};
}

std::map<std::string, double> parse_held_joints(const std::string& text,
                                                const std::string& option) {
  std::map<std::string, double> held;
  if (text.empty()) return held;
  for (const auto& [name, value] : parse_assignments(text, option, "JOINT=VALUE")) {
    std::istringstream number(value);
    number.imbue(std::locale::classic());
    double v = 0.0;
    if (name.empty()) throw InputError(option + ": '=" + value + "' is not JOINT=VALUE");
    if (!(number >> v) || !(number >> std::ws).eof() || !std::isfinite(v))
      throw InputError(option + ": the value of '" + name + "' ('" + value +
                       "') is not a finite number");
    held.emplace(name, v);
  }
  return held;
}

RobotDescription read_robot_description(const std::string& path, const std::string& base,
                                        const std::string& tip,
                                        const std::map<std::string, double>& held) {
  const std::string text = read_text(path);
  if (!is_xml(text)) {
    if (!base.empty() || !tip.empty() || !held.empty())
      throw InputError(path + ": --base, --tip and --hold apply to a URDF, not to a DH table");
    return read_dh(path, text);
  }
  try {
    std::string from = base, to = tip;
    std::vector<std::string> leaves;
    urdf_ends(path, text, from, leaves);
    if (to.empty()) {
      if (leaves.size() != 1)
        throw InputError(path + ": the description has " + std::to_string(leaves.size()) +
                         " end links (" + join(leaves) + "); name the chain's last with --tip");
      to = leaves.front();
    }
    return sid::robot_description_from_urdf(text, from, to, held);
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": " + e.what());
  }
}

namespace {

int joint_index(const YAML::Node& node, const std::vector<std::string>& names,
                const std::string& where) {
  const std::string text = node.as<std::string>();
  const auto found = std::find(names.begin(), names.end(), text);
  if (found != names.end()) return static_cast<int>(found - names.begin());
  std::istringstream in(text);
  int k = 0;
  if (in >> k && (in >> std::ws).eof() && k >= 1 && k <= static_cast<int>(names.size()))
    return k - 1;
  throw InputError(where + ": '" + text + "' is neither a joint name (" + join(names) +
                   ") nor a joint number 1.." + std::to_string(names.size()));
}

Eigen::VectorXd number_list(const YAML::Node& node, std::size_t count, const std::string& where) {
  if (!node.IsSequence() || node.size() != count)
    throw InputError(where + " needs a list of " + std::to_string(count) + " numbers");
  Eigen::VectorXd v(static_cast<Eigen::Index>(count));
  for (std::size_t i = 0; i < count; ++i) v[static_cast<Eigen::Index>(i)] = node[i].as<double>();
  if (!v.allFinite()) throw InputError(where + " holds a value that is not finite");
  return v;
}

}  // namespace

sid::Transmission read_transmission(const std::string& path,
                                    const std::vector<std::string>& joint_names) {
  const std::size_t n = joint_names.size();
  const std::string text = read_text(path);
  if (is_xml(text) || has_xml_extension(path)) {
    try {
      return sid::transmission_from_urdf(text, joint_names);
    } catch (const std::invalid_argument& e) {
      throw InputError(path + ": " + e.what());
    }
  }
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(path + ": not valid YAML: " + e.what());
  }
  try {
    if (!root.IsMap())
      throw InputError(path + ": expected keys gear_ratios, couplings, joint_zero");
    for (const auto& entry : root) {
      const std::string key = entry.first.as<std::string>();
      if (key != "gear_ratios" && key != "couplings" && key != "joint_zero")
        throw InputError(path + ": unknown key '" + key +
                         "' (expected gear_ratios, couplings, joint_zero)");
    }
    if (!root["gear_ratios"]) throw InputError(path + ": gear_ratios is missing");
    const Eigen::VectorXd ratios = number_list(root["gear_ratios"], n, path + ": gear_ratios");
    Eigen::MatrixXd g = ratios.asDiagonal();
    if (const YAML::Node couplings = root["couplings"]) {
      if (!couplings.IsSequence()) throw InputError(path + ": couplings must be a list");
      for (std::size_t c = 0; c < couplings.size(); ++c) {
        const YAML::Node item = couplings[c];
        const std::string where = path + ": couplings[" + std::to_string(c) + "]";
        if (!item.IsMap() || !item["motor"] || !item["joint"] || !item["ratio"])
          throw InputError(where + " needs motor, joint and ratio");
        const int motor = joint_index(item["motor"], joint_names, where + ".motor");
        const int joint = joint_index(item["joint"], joint_names, where + ".joint");
        if (motor == joint)
          throw InputError(where + ": a motor's own joint takes its ratio from gear_ratios");
        const double ratio = item["ratio"].as<double>();
        if (!std::isfinite(ratio)) throw InputError(where + ".ratio is not finite");
        g(motor, joint) = ratio;
      }
    }
    const Eigen::VectorXd zero = root["joint_zero"]
                                     ? number_list(root["joint_zero"], n, path + ": joint_zero")
                                     : Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n));
    return sid::Transmission(g, zero);
  } catch (const YAML::Exception& e) {
    throw InputError(path + ": " + e.what());
  } catch (const std::invalid_argument& e) {
    throw InputError(path + ": " + e.what());
  }
}

std::vector<std::string> chain_columns(const std::string& map, int joints,
                                       const std::string& option) {
  std::vector<std::string> keys = {"t"};
  for (const char* stem : {"q", "tau"})
    for (int j = 1; j <= joints; ++j) keys.push_back(stem + std::to_string(j));
  std::vector<std::string> names = keys;
  if (map.empty()) return names;
  for (const auto& [key, name] : parse_assignments(map, option, "KEY=NAME")) {
    const auto at = std::find(keys.begin(), keys.end(), key);
    if (at == keys.end())
      throw InputError(option + ": unknown key '" + key + "' (expected t, q1..q" +
                       std::to_string(joints) + ", tau1..tau" + std::to_string(joints) + ")");
    if (name.empty()) throw InputError(option + ": '" + key + "' maps to an empty name");
    names[static_cast<std::size_t>(at - keys.begin())] = name;
  }
  return names;
}

sid::ChainTrajectory<double> chain_trajectory_from_table(const CsvTable& table, int joints,
                                                         const std::vector<std::string>& names) {
  // Every column is looked up first, so a missing one is reported before any row problem.
  const Eigen::VectorXd& t = table.column(names[0]);
  std::vector<const Eigen::VectorXd*> columns;
  for (std::size_t k = 1; k < names.size(); ++k) columns.push_back(&table.column(names[k]));
  require_strictly_increasing(table, names[0]);
  sid::ChainTrajectory<double> run;
  run.t = t;
  run.q.resize(t.size(), joints);
  run.tau.resize(t.size(), joints);
  for (int j = 0; j < joints; ++j) {
    run.q.col(j) = *columns[static_cast<std::size_t>(j)];
    run.tau.col(j) = *columns[static_cast<std::size_t>(joints + j)];
  }
  return run;
}

}  // namespace sid::app
