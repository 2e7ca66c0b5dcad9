#include "identified_arm.hpp"

#include "app.hpp"
#include "csv.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <sstream>

namespace sid::app {

namespace {

const nlohmann::json& member(const nlohmann::json& j, const char* key, const std::string& where) {
  if (!j.is_object() || !j.contains(key))
    throw InputError(where + " has no '" + key + "': is it sid_identify --robot's --json output?");
  return j.at(key);
}

Eigen::VectorXd numbers(const nlohmann::json& j, const char* key, const std::string& where) {
  const nlohmann::json& a = member(j, key, where);
  if (!a.is_array()) throw InputError(where + ": '" + key + "' is not an array of numbers");
  Eigen::VectorXd v(static_cast<Eigen::Index>(a.size()));
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!a[i].is_number() || !std::isfinite(a[i].get<double>()))
      throw InputError(where + ": '" + key + "'[" + std::to_string(i) + "] is not a finite number");
    v[static_cast<Eigen::Index>(i)] = a[i].get<double>();
  }
  return v;
}

std::vector<std::string> strings(const nlohmann::json& j, const char* key,
                                 const std::string& where) {
  const nlohmann::json& a = member(j, key, where);
  std::vector<std::string> v;
  if (a.is_array())
    for (const auto& e : a)
      if (e.is_string()) v.push_back(e.get<std::string>());
  if (!a.is_array() || v.size() != a.size())
    throw InputError(where + ": '" + key + "' is not an array of strings");
  return v;
}

std::string joined(const std::vector<std::string>& words) {
  std::string s;
  for (const auto& w : words) s += (s.empty() ? "" : ",") + w;
  return s;
}

}  // namespace

IdentifiedArm read_identified_arm(const std::string& path, const RobotDescription& robot,
                                  const sid::Transmission& transmission) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw InputError("cannot read '" + path + "'");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(file);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path + " is not JSON (" + e.what() + ")");
  }
  return identified_arm(j, path, robot, transmission);
}

IdentifiedArm identified_arm(const nlohmann::json& j, const std::string& where,
                             const RobotDescription& robot, const sid::Transmission& transmission) {
  const std::vector<std::string> kinds = strings(j, "drive_terms", where);
  const nlohmann::json& epsilon = member(j, "coulomb_epsilon", where);
  if (!epsilon.is_number() || !(epsilon.get<double>() >= 0.0))
    throw InputError(where + ": 'coulomb_epsilon' is not a number >= 0");
  std::vector<sid::DriveTermKind> drive_kinds;
  try {
    if (!kinds.empty()) drive_kinds = sid::parse_drive_term_kinds(joined(kinds));
  } catch (const std::invalid_argument& e) {
    throw InputError(where + ": 'drive_terms': " + e.what());
  }
  sid::ChainModel model(robot.chain, robot.joint_names, sid::drive_terms(drive_kinds, transmission),
                        transmission, epsilon.get<double>());
  // Parameter names are positional (m_1, fv_1, ...): two robots with as many joints and the same
  // drive terms share them, so the joints' names tell a fit of another robot.
  const std::vector<std::string> joints = strings(j, "joint_names", where);
  if (joints != model.joint_names())
    throw InputError(where + " is the fit of another robot: its joints are " +
                     joined(joints).substr(0, 120) + ", this robot's " +
                     joined(model.joint_names()).substr(0, 120) +
                     " (give the --robot, --base and --tip of the fit)");
  const std::vector<std::string> fitted = strings(j, "model_parameters", where);
  if (fitted != model.parameter_names())
    throw InputError(where + " is the fit of another model: its parameters are " +
                     std::to_string(fitted.size()) + " (" + joined(fitted).substr(0, 120) +
                     "...), this robot with its drive terms has " +
                     std::to_string(model.parameters()) +
                     " (give the --robot, --base, --tip and --transmission of the fit)");
  const nlohmann::json& consistent = member(j, "physically_consistent", where);
  IdentifiedArm arm{where,
                    std::move(model),
                    numbers(consistent, "theta", where + ": physically_consistent"),
                    numbers(j, "cutoff_hz", where),
                    0.0,
                    numbers(j, "residual_rms", where),
                    numbers(j, "residual_rms_measured", where),
                    {},
                    {}};
  const int n = arm.model.joints();
  if (arm.theta.size() != arm.model.parameters())
    throw InputError(where + ": physically_consistent.theta has " +
                     std::to_string(arm.theta.size()) + " values for " +
                     std::to_string(arm.model.parameters()) + " parameters");
  for (const Eigen::VectorXd* v : {&arm.cutoff_hz, &arm.residual_rms, &arm.residual_rms_measured})
    if (v->size() != n)
      throw InputError(where + ": a per-joint list (cutoff_hz, residual_rms) does not have " +
                       std::to_string(n) + " values");
  if (j.contains("torque_delay")) {
    const nlohmann::json& delay = j["torque_delay"];
    if (!delay.is_number() || !std::isfinite(delay.get<double>()))
      throw InputError(where + ": 'torque_delay' is not a finite number [s]");
    arm.torque_delay = delay.get<double>();
  }
  const auto flag = [&](const char* key) {
    const nlohmann::json& v = member(consistent, key, where + ": physically_consistent");
    if (!v.is_boolean())
      throw InputError(where + ": physically_consistent." + key + " is not true or false");
    return v.get<bool>();
  };
  if (robot.limits.size() == std::size_t(n)) {
    arm.effort_limit.resize(n);
    for (int joint = 0; joint < n; ++joint)
      arm.effort_limit[joint] = robot.limits[std::size_t(joint)].effort;
  }
  const bool converged = flag("converged");
  if (!converged)
    throw InputError(where +
                     ": its physically consistent fit did not converge, so it holds no "
                     "usable arm; identify again (more runs, or sid_excite's motion)");
  if (!flag("fits_estimate"))
    arm.warnings.push_back(
        where +
        ": real bodies do not reproduce its estimate (the fit's model probably lacks a "
        "drive term the data have): the arm used is the nearest real one");
  return arm;
}

}  // namespace sid::app
