#include "drive_gains_app.hpp"

#include <sid/cvode/identify_robot_currents.hpp>
#include <sid/drive_gains.hpp>

#include "app.hpp"
#include "chain_identify_app.hpp"
#include "csv.hpp"
#include "robot_description.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>

namespace sid::app {

namespace {

/// A run as logged (motor side with --transmission) and as the gain fit takes it: joint-side
/// angles, the motor currents kept.
sid::NamedChainRun read_current_run(const std::string& path, const LoadedChain& chain,
                                    const std::vector<std::string>& columns) {
  const CsvTable table = read_csv(path);
  const int n = chain.model.joints();
  sid::ChainTrajectory<double> raw = chain_trajectory_from_table(table, n, columns);
  require(raw.size() >= 4, table.source + ": identification needs at least 4 data rows, got " +
                               std::to_string(raw.size()));
  if (!chain.motor_side) return {table.source, std::move(raw)};
  sid::ChainTrajectory<double> joint;
  try {
    joint = chain.transmission.joint_side(raw);
  } catch (const std::invalid_argument& e) {
    throw InputError(table.source + ": " + e.what());
  }
  joint.tau = raw.tau;
  return {table.source, std::move(joint)};
}

std::string number(const char* format, double v) { return format_number(format, v); }

std::string gain_text(const sid::ChainModel& model, const sid::DriveGainIdentification& g,
                      const sid::LinkInertia<double>& payload, const std::string& frame_text,
                      const std::string& loaded_file, std::size_t unloaded, bool motor_side,
                      double first_cutoff) {
  std::ostringstream out;
  out << "drive gains (current to torque) from the known payload on " << loaded_file << ": "
      << number("%.4g", payload.mass) << " kg, centre of mass (" << number("%.4g", payload.com[0])
      << ", " << number("%.4g", payload.com[1]) << ", " << number("%.4g", payload.com[2])
      << ") m in " << frame_text << "; " << unloaded << " run" << (unloaded == 1 ? "" : "s")
      << " without it\n";
  out << "  fitted with " << g.arm_parameters << " base parameters of the arm on " << g.equations
      << " equations (condition number " << number("%.4g", g.fit.condition_number)
      << "), smoothing cutoff per joint [Hz]:";
  for (Eigen::Index j = 0; j < g.cutoff_hz.size(); ++j)
    out << " " << number("%.3g", g.cutoff_hz[j]);
  if (!std::isnan(first_cutoff))
    out << " (chosen by held-out torque prediction on the runs converted by a first fit of the "
           "gains at "
        << number("%.3g", first_cutoff) << " Hz; the arm below is fitted at them too)";
  out << "\n";
  std::size_t width = 5;
  for (const auto& name : model.joint_names()) width = std::max(width, name.size());
  char line[512];
  std::snprintf(line, sizeof line, "  %-*s %14s %11s %9s %16s\n", int(width),
                motor_side ? "motor" : "joint", "gain [N m/A]", "std", "std %", "payload [N m]");
  out << line;
  for (Eigen::Index j = 0; j < g.gain.size(); ++j) {
    std::snprintf(line, sizeof line, "  %-*s %14.6g %11.3g %9s %16.3g\n", int(width),
                  model.joint_names()[static_cast<std::size_t>(j)].c_str(), g.gain[j], g.std_dev[j],
                  number("%.3f", 100.0 * g.std_dev[j] / std::abs(g.gain[j])).c_str(),
                  g.payload_torque_rms[j]);
    out << line;
  }
  out << "  (std: HAC, for residuals correlated in time; payload: the RMS of its torque on each "
         "motor in the loaded run. Below, the runs converted to torques by these gains, the "
         "payload's torque taken off the loaded run; the parameters' std leave out the gains' "
         "own uncertainty)\n\n";
  return out.str();
}

nlohmann::json gain_json(const sid::ChainModel& model, const sid::DriveGainIdentification& g) {
  nlohmann::json gains = nlohmann::json::array();
  for (Eigen::Index j = 0; j < g.gain.size(); ++j)
    gains.push_back({{"joint", model.joint_names()[static_cast<std::size_t>(j)]},
                     {"gain", g.gain[j]},
                     {"std", g.std_dev[j]},
                     {"std_uncorrelated", g.std_dev_uncorrelated[j]},
                     {"payload_torque_rms", g.payload_torque_rms[j]}});
  return gains;
}

nlohmann::json gain_fit_json(const sid::DriveGainIdentification& g,
                             const sid::LinkInertia<double>& payload, const std::string& frame,
                             const std::string& loaded_file) {
  nlohmann::json j;
  j["loaded_run"] = loaded_file;
  j["payload"] = {{"frame", frame},
                  {"mass", payload.mass},
                  {"com", to_json_array(payload.com)},
                  {"inertia_com", to_json_rows(payload.inertia_com)}};
  j["cutoff_hz"] = to_json_array(g.cutoff_hz);
  j["arm_parameters"] = g.arm_parameters;
  j["equations"] = g.equations;
  j["condition_number"] = g.fit.condition_number;
  return j;
}

}  // namespace

sid::LinkInertia<double> parse_known_payload(const std::string& text) {
  const std::vector<double> v = parse_doubles(text, "--known-payload");
  require(v.size() == 4 || v.size() == 10,
          "--known-payload takes 4 numbers (m,cx,cy,cz) or 10 (m,cx,cy,cz,ixx,iyy,izz,ixy,ixz,iyz: "
          "mass [kg], centre of mass [m] and inertia about it [kg m^2] in the --tip link's frame "
          "or --payload-frame's), got " +
              std::to_string(v.size()));
  sid::LinkInertia<double> payload;
  payload.mass = v[0];
  payload.com = Eigen::Vector3d(v[1], v[2], v[3]);
  if (v.size() == 10) payload.inertia_com << v[4], v[7], v[8], v[7], v[5], v[9], v[8], v[9], v[6];
  const std::string why = sid::payload_inconsistency(payload);
  require(why.empty(), "--known-payload is not a real body: " + why);
  return payload;
}

void check_drive_gain_options(const ChainIdentifyAppOptions& chain, const DriveGainAppOptions& o) {
  require(o.currents || (o.known_payload.empty() && o.payload_run.empty()),
          "--known-payload and --payload-run go with --currents (logs of motor currents)");
  require(o.payload_frame.empty() || !o.known_payload.empty(),
          "--payload-frame goes with --known-payload or --payload-of (the frame of the load)");
  if (!o.currents) return;
  require(!chain.robot.empty(), "--currents needs --robot");
  require(!o.known_payload.empty(),
          "--currents needs --known-payload m,cx,cy,cz[,ixx,iyy,izz,ixy,ixz,iyz]: the logs hold "
          "currents, and without a load of known inertia on the tip link the gains' scale (current "
          "to torque) is not identifiable");
  require(!o.payload_run.empty(),
          "--currents needs --payload-run LOADED.csv, the log with the known payload on the tip "
          "link (the RUN files are the logs without it): without it the gains' scale is not "
          "identifiable");
  require(!chain.inputs.empty(),
          "--currents needs a RUN without the payload besides --payload-run: with the payload "
          "alone it merges with the tip link and the gains' scale is not identifiable");
}

DriveGainResult identify_with_drive_gains(const ChainIdentifyAppOptions& chain,
                                          const DriveGainAppOptions& o) {
  check_drive_gain_options(chain, o);
  const sid::LinkInertia<double> given = parse_known_payload(o.known_payload);
  ChainIdentifyAppOptions without_runs = chain;
  without_runs.inputs.clear();
  without_runs.validate.clear();
  const LoadedChain loaded = load_identify_chain(without_runs);
  const sid::ChainModel& model = loaded.model;
  const int n = model.joints();
  // The model carries a load in its last moving link's frame; the user gives it in a flange's.
  const std::string frame = payload_frame_name(loaded.robot, o.payload_frame, "--payload-frame");
  const sid::LinkInertia<double> payload =
      frame.empty() ? given
                    : sid::expressed_in_parent(
                          given, fixed_link_pose(loaded.robot, frame, "--payload-frame"));
  const std::string frame_name = frame.empty() ? "link " + std::to_string(n) : frame;
  const std::string frame_text =
      "the frame of " + frame_name + (frame.empty() ? " (a DH table: its last link's)" : "");
  const std::vector<std::string> columns = chain_columns(chain.columns, n, "--columns");

  const sid::NamedChainRun loaded_run = read_current_run(o.payload_run, loaded, columns);
  std::vector<sid::NamedChainRun> runs, held_out;
  for (const auto& f : chain.inputs) runs.push_back(read_current_run(f, loaded, columns));
  for (const auto& f : chain.validate) held_out.push_back(read_current_run(f, loaded, columns));
  sid::RobotCurrentsOptions options;
  options.identify = robot_identify_options(chain, loaded);
  sid::RobotCurrentsIdentification r;
  try {
    r = sid::identify_robot_currents(model, loaded_run, runs, payload, held_out, options);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("--currents: ") + e.what());
  }
  ChainIdentifyResult identified = identify_report(chain, loaded, std::move(r.arm));
  identified.text = gain_text(model, r.gains, given, frame_text, loaded_run.name, runs.size(),
                              loaded.motor_side, r.first_cutoff_hz) +
                    identified.text;
  identified.json["drive_gains"] = gain_json(model, r.gains);
  identified.json["drive_gain_fit"] = gain_fit_json(r.gains, given, frame_name, loaded_run.name);
  return {std::move(r.gains), std::move(identified)};
}

int identify_robot_currents(const ChainIdentifyAppOptions& chain, const DriveGainAppOptions& o,
                            const char* app_name) {
  check_drive_gain_options(chain, o);
  if (!chain.json.empty()) ensure_writable(chain.json, chain.force);
  if (!chain.write_urdf.empty()) ensure_writable(chain.write_urdf, chain.force);
  if (!chain.write_mjcf.empty()) ensure_writable(chain.write_mjcf, chain.force);
  if (!chain.report.empty()) ensure_writable(chain.report, chain.force);
  const DriveGainResult r = identify_with_drive_gains(chain, o);
  const ChainIdentifyResult& id = r.identified;
  require_model_files(chain, id.loaded.robot);
  write_identify_outputs(chain, id, app_name);
  return kExitOk;
}

}  // namespace sid::app
