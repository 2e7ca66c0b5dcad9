#include "payload_app.hpp"

#include <sid/detail/xml.hpp>
#include <sid/model/urdf.hpp>
#include <sid/payload.hpp>

#include "app.hpp"
#include "chain_identify_app.hpp"
#include "csv.hpp"
#include "identified_arm.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <iostream>
#include <set>
#include <sstream>

namespace sid::app {

namespace {

std::string number(const char* format, double v) { return format_number(format, v); }

/// χ² with 10 degrees of freedom stays below this (mean + 3 standard deviations) for a real load
/// plus noise: a projection that moves further says the least-squares estimate is not noise
/// around a real body (an arm that does not hold, a load that is not rigid).
constexpr double kProjectionMisfitLimit = 10.0 + 3.0 * 4.47213595499958;

const char* const kInertiaNames[6] = {"ixx", "iyy", "izz", "ixy", "ixz", "iyz"};

std::string report_text(const PayloadResult& r, const IdentifiedArm& arm,
                        const std::vector<ChainRunFile>& runs, bool dh_table) {
  const sid::PayloadIdentification& p = r.id;
  std::ostringstream out;
  out << "payload on " << r.frame << " (the arm held at " << arm.source << "): " << runs.size()
      << (runs.size() == 1 ? " run, " : " runs, ") << p.equations << " equations, condition number "
      << number("%.4g", p.condition_number) << "\n";
  if (dh_table)
    out << "  (a DH table: the frame is its last link's; --payload-frame needs a URDF)\n";
  if (arm.torque_delay != 0.0)
    out << "  " << torque_pairing(arm.torque_delay) << " (the arm's torque delay)\n";
  out << "  mass " << number("%.6g", p.body.mass) << " kg (std " << number("%.2g", p.mass_std)
      << ")\n";
  out << "  centre of mass (" << number("%.5g", p.body.com[0]) << ", "
      << number("%.5g", p.body.com[1]) << ", " << number("%.5g", p.body.com[2]) << ") m (std "
      << number("%.2g", p.com_std[0]) << ", " << number("%.2g", p.com_std[1]) << ", "
      << number("%.2g", p.com_std[2]) << ") in the frame of " << r.frame << "\n";
  const Eigen::Matrix<double, 6, 1> inertia = sid::detail::inertia_six(p.body.inertia_com);
  out << "  inertia about the centre of mass [kg m^2], " << r.frame << "'s axes:\n";
  for (int k = 0; k < 6; ++k)
    out << "    " << kInertiaNames[k] << " " << number("%11.4e", inertia[k]) << "  (std "
        << number("%.2g", p.inertia_std[k]) << ")\n";
  out << "  (std: HAC, for residuals correlated in time)\n";
  out << "relative residual: " << number("%.2f", 100.0 * p.relative_residual_before)
      << " % of the torque with the arm alone, "
      << number("%.2f", 100.0 * p.relative_residual_after) << " % with the payload";
  if (p.projected)
    out << " (least squares " << number("%.2f", 100.0 * p.relative_residual_least_squares) << " %)";
  out << "\n";
  if (p.projected)
    out << "physically consistent: the least-squares estimate is not a real body ("
        << p.least_squares_inconsistency
        << "); the nearest real body in the least-squares metric is reported (it moves "
        << number("%.3g", p.projection_misfit)
        << " in the estimate's own uncertainty, chi-square with 10 degrees of freedom"
        << (p.converged ? "" : "; NOT CONVERGED") << ")\n";
  else
    out << "physically consistent: the least-squares estimate is a real body (mass > 0, inertia "
           "positive definite, triangle inequality)\n";
  return out.str();
}

nlohmann::json report_json(const PayloadResult& r, const IdentifiedArm& arm,
                           const std::vector<ChainRunFile>& runs) {
  const sid::PayloadIdentification& p = r.id;
  nlohmann::json j;
  j["arm"] = arm.source;
  j["torque_delay"] = arm.torque_delay;
  j["runs"] = nlohmann::json::array();
  for (const auto& run : runs) j["runs"].push_back(run.file);
  j["cutoff_hz"] = to_json_array(arm.cutoff_hz);
  nlohmann::json load;
  load["frame"] = r.frame;
  load["mass"] = p.body.mass;
  load["mass_std"] = p.mass_std;
  load["com"] = to_json_array(p.body.com);
  load["com_std"] = to_json_array(p.com_std);
  load["inertia"] = to_json_array(sid::detail::inertia_six(p.body.inertia_com));
  load["inertia_std"] = to_json_array(p.inertia_std);
  load["inertia_order"] =
      std::vector<std::string>(std::begin(kInertiaNames), std::end(kInertiaNames));
  load["parameter_names"] = std::vector<std::string>(sid::payload_parameter_names().begin(),
                                                     sid::payload_parameter_names().end());
  load["standard_parameters"] = to_json_array(p.phi);
  load["least_squares"] = to_json_array(p.least_squares);
  load["covariance"] = to_json_rows(p.covariance);
  load["std_dev_uncorrelated"] = to_json_array(p.covariance_uncorrelated.diagonal().cwiseSqrt());
  load["projected"] = p.projected;
  load["least_squares_inconsistency"] = p.least_squares_inconsistency;
  load["projection_misfit"] = p.projection_misfit;
  load["converged"] = p.converged;
  load["relative_residual_before"] = p.relative_residual_before;
  load["relative_residual_after"] = p.relative_residual_after;
  load["relative_residual_least_squares"] = p.relative_residual_least_squares;
  load["equations"] = p.equations;
  load["condition_number"] = p.condition_number;
  j["payload"] = load;
  return j;
}

std::string urdf_number(double v) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

}  // namespace

PayloadResult identify_payload(const IdentifiedArm& arm, const std::vector<ChainRunFile>& runs,
                               const PayloadReportOptions& options) {
  require(!runs.empty(), "no run given");
  const int n = arm.model.joints();
  for (const auto& r : runs)
    require(r.data.joints() == n, r.file + ": the run has " + std::to_string(r.data.joints()) +
                                      " joints, the arm of " + arm.source + " " +
                                      std::to_string(n));
  std::vector<sid::ChainTrajectory<double>> data;
  for (const auto& r : runs) data.push_back(r.data);
  PayloadResult r;
  const bool dh_table = options.frame.empty();
  r.frame = dh_table ? "link " + std::to_string(n) : options.frame;
  r.warnings = arm.warnings;
  sid::PayloadOptions payload = options.payload;
  require(std::abs(arm.torque_delay) <= std::min(payload.rows.skip, payload.rows.skip_end),
          "the torque delay of " + arm.source + " (" + number("%.3g", 1e3 * arm.torque_delay) +
              " ms) is longer than the skips at the runs' ends");
  payload.rows.torque_delay = arm.torque_delay;
  try {
    r.id = sid::identify_payload(arm.model, arm.theta, data, arm.cutoff_hz, payload);
  } catch (const sid::PayloadNotIdentifiable& e) {
    const std::string robot = options.robot.empty() ? "FILE" : options.robot;
    const sid::FramePose<double>& frame = options.payload.frame;
    const bool moved = frame.rotation != Eigen::Matrix3d::Identity() ||
                       frame.translation != Eigen::Vector3d::Zero();
    throw InputError(std::string(e.what()) +
                     (moved ? " (the parameters named in the frame of the chain's last moving "
                              "link, where the motion is judged)"
                            : "") +
                     ". sid_excite --robot " + robot +
                     " [--base --tip] -o excitation.csv designs a motion that shows them; "
                     "record the loaded arm following it");
  } catch (const std::invalid_argument& e) {
    throw InputError((runs.size() == 1 ? runs.front().file + ": " : std::string()) + e.what());
  }
  if (r.id.projected && !r.id.converged)
    r.warnings.push_back("the nearest real body to the least-squares estimate was not reached in " +
                         std::to_string(r.id.iterations) + " Newton steps");
  if (r.id.projected && r.id.projection_misfit > kProjectionMisfitLimit)
    r.warnings.push_back(
        "the least-squares load is far from every real body (misfit " +
        number("%.3g", r.id.projection_misfit) + " where noise gives at most about " +
        number("%.3g", kProjectionMisfitLimit) +
        "): the arm held may not match this arm, or the load is not fixed rigidly");
  r.text = report_text(r, arm, runs, dh_table);
  r.json = report_json(r, arm, runs);
  return r;
}

PayloadReportOptions payload_report_options(const LoadedChain& loaded, const std::string& robot,
                                            const std::string& frame, const std::string& option) {
  PayloadReportOptions options;
  options.robot = robot;
  options.frame = payload_frame_name(loaded.robot, frame, option);
  if (!options.frame.empty())
    options.payload.frame = fixed_link_pose(loaded.robot, options.frame, option);
  options.payload.rows = loaded.options;
  return options;
}

std::string urdf_with_payload(const RobotDescription& robot, const sid::LinkParameters<double>& phi,
                              const std::string& frame) {
  require(!robot.urdf.empty(), "--write-urdf needs a URDF as --robot, not a DH table");
  const std::string inconsistency = sid::link_inconsistency(phi);
  if (!inconsistency.empty())
    throw InputError("--write-urdf: the payload is not a real body (" + inconsistency + ")");
  const sid::detail::XmlElement document =
      sid::detail::XmlParser(robot.urdf, "urdf").parse_document();
  const sid::detail::UrdfTree tree(document);
  // The tip link (robot.tip) may be fixed below the last moving link (a flange): the load is
  // hung from it, its inertial written in its frame.
  const sid::FramePose<double> frame_in_moving =
      fixed_link_pose(robot, frame.empty() ? robot.tip : frame, "--payload-frame");
  const sid::FramePose<double> frame_in_tip = sid::detail::compose(
      sid::inverse_pose(fixed_link_pose(robot, robot.tip, "--tip")), frame_in_moving);
  const sid::LinkInertia<double> body =
      sid::expressed_in_parent(sid::link_inertia(phi), frame_in_tip);
  const Eigen::Vector3d& c = body.com;
  const Eigen::Matrix3d& i = body.inertia_com;
  std::string link = "payload", joint = "payload_joint";
  for (int k = 2; tree.links.count(link) || tree.joints.count(joint); ++k) {
    link = "payload_" + std::to_string(k);
    joint = "payload_joint_" + std::to_string(k);
  }
  const std::string text =
      "  <joint name=\"" + joint + "\" type=\"fixed\">\n    <parent link=\"" + robot.tip +
      "\"/>\n    <child link=\"" + link +
      "\"/>\n    <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/>\n  </joint>\n  <link name=\"" + link +
      "\">\n    <inertial>\n      <origin xyz=\"" + urdf_number(c[0]) + " " + urdf_number(c[1]) +
      " " + urdf_number(c[2]) + "\" rpy=\"0 0 0\"/>\n      <mass value=\"" +
      urdf_number(body.mass) + "\"/>\n      <inertia ixx=\"" + urdf_number(i(0, 0)) + "\" ixy=\"" +
      urdf_number(i(0, 1)) + "\" ixz=\"" + urdf_number(i(0, 2)) + "\" iyy=\"" +
      urdf_number(i(1, 1)) + "\" iyz=\"" + urdf_number(i(1, 2)) + "\" izz=\"" +
      urdf_number(i(2, 2)) + "\"/>\n    </inertial>\n  </link>\n";
  const std::size_t end = robot.urdf.rfind("</robot>");
  if (end == std::string::npos) throw InputError("--write-urdf: the URDF has no </robot>");
  std::string out = robot.urdf;
  out.insert(end, text);
  // What was written must read back as the description plus the load on the tip link.
  const sid::UrdfChain before = sid::chain_from_urdf(robot.urdf, robot.base, robot.tip);
  const sid::UrdfChain after = sid::chain_from_urdf(out, robot.base, robot.tip);
  const Eigen::Index tip = 10 * static_cast<Eigen::Index>(before.chain.joints() - 1);
  const sid::LinkParameters<double> added =
      after.theta.segment<10>(tip) - before.theta.segment<10>(tip);
  const sid::LinkParameters<double> expected = sid::expressed_in_parent(phi, frame_in_moving);
  if ((added - expected).cwiseAbs().maxCoeff() > 1e-9 * (1.0 + expected.cwiseAbs().maxCoeff()) ||
      (after.theta.head(tip) - before.theta.head(tip)).cwiseAbs().maxCoeff() > 0.0)
    throw std::runtime_error("--write-urdf: the payload does not read back as identified");
  return out;
}

int identify_payload_robot(const ChainIdentifyAppOptions& o, const std::string& payload_of,
                           const std::string& payload_frame, const char* app_name) {
  require(!o.inputs.empty(), "no run given");
  require(o.effects.empty() && !o.no_default_effects && !o.coulomb_epsilon && o.cutoff.empty() &&
              !o.torque_delay && !o.estimate_torque_delay,
          "--payload-of: the drive terms, the smoothing and the torque's delay are the arm's (" +
              payload_of +
              "); --effects, --no-default-effects, --coulomb-epsilon, --cutoff, --torque-delay "
              "and --estimate-torque-delay do not apply");
  require(o.validate.empty() && !o.validate_fraction && o.estimator == "ls",
          "--payload-of: --validate, --validate-fraction and --estimator do not apply");
  if (!o.json.empty()) ensure_writable(o.json, o.force);
  if (!o.write_urdf.empty()) ensure_writable(o.write_urdf, o.force);
  LoadedChain loaded = load_chain(o, {});
  require(o.write_urdf.empty() || !loaded.robot.urdf.empty(),
          "--write-urdf needs a URDF as --robot, not a DH table");
  const PayloadReportOptions options =
      payload_report_options(loaded, o.robot, payload_frame, "--payload-frame");
  const IdentifiedArm arm = read_identified_arm(payload_of, loaded.robot, loaded.transmission);
  const PayloadResult r = identify_payload(arm, loaded.runs, options);
  // Refuse before anything is written: a load that cannot go into the URDF writes nothing.
  std::string urdf;
  if (!o.write_urdf.empty()) urdf = urdf_with_payload(loaded.robot, r.id.phi, r.frame);
  (o.json == "-" ? std::cerr : std::cout) << r.text << std::flush;
  for (const auto& w : r.warnings) std::cerr << app_name << ": warning: " << w << "\n";
  if (!o.json.empty()) write_json(o.json, r.json);
  if (!o.write_urdf.empty()) write_text(o.write_urdf, urdf);
  return kExitOk;
}

}  // namespace sid::app
