#include "chain_diagnose_app.hpp"

#include <sid/chain_consistency.hpp>
#include <sid/cvode/diagnose_robot.hpp>
#include <sid/diagnose_chain.hpp>

#include "app.hpp"
#include "diagnose_report_html.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <iostream>
#include <sstream>

namespace sid::app {

namespace {

std::string number(const char* format, double v) { return format_number(format, v); }

/// The sid_excite call that designs a motion on which a named term and its look-alikes are told
/// apart.
std::string separating(const ChainDiagnoseAppOptions& o, const sid::ChainEffectTest& e) {
  std::string ids = e.id;
  if (!e.angle_offset && e.term.kind == sid::DriveTermKind::Stribeck)
    ids += ":" + number("%.3g", e.term.velocity);
  for (const std::string& other : e.look_alikes) ids += "," + other;
  const auto option = [](const char* name, const std::string& value) {
    return value.empty() ? std::string() : std::string(" ") + name + " " + value;
  };
  return "    a motion that separates them: sid_excite --robot " + o.chain.robot +
         option("--base", o.chain.base) + option("--tip", o.chain.tip) +
         option("--hold", o.chain.hold) + option("--transmission", o.chain.transmission) +
         " --separate " + ids + "\n";
}

/// The motion check's margin over its exact-model replicates, as the library's default.
const double kMotionMargin = sid::ChainMotionCheckOptions().margin;

std::string report_text(const ChainDiagnoseAppOptions& o, const sid::ChainModel& nominal,
                        const sid::RobotDiagnosis& whole) {
  const sid::ChainDiagnosis& r = whole.diagnosis;
  std::ostringstream out;
  out << "robot " << o.chain.robot << ": " << nominal.joints() << " joints; nominal model: rigid "
      << "bodies";
  for (const sid::DriveTerm& t : nominal.terms())
    if (!t.on_motor && t.index == 0) out << ", " << sid::drive_term_keyword(t.kind);
  out << " (" << r.equations << " equations)\nsmoothing cutoffs [Hz]:";
  for (Eigen::Index j = 0; j < r.cutoff_hz.size(); ++j)
    out << " " << number("%.3g", r.cutoff_hz[j]);
  out << " (" << r.smoothing << ")";
  out << "\n\nper joint [N m]: torque noise | residual nominal -> final | unexplained\n";
  for (int j = 0; j < nominal.joints(); ++j)
    out << "  " << nominal.joint_names()[static_cast<std::size_t>(j)] << ": "
        << number("%.4g", r.noise_floor[j]) << " | " << number("%.4g", r.nominal_residual_rms[j])
        << " -> " << number("%.4g", r.final_residual_rms[j]) << " | "
        << number("%.4g", r.unexplained_rms[j]) << "\n";
  out << "\nnamed (" << r.named.size() << "):\n";
  if (r.named.empty())
    out << "  nothing: no tried term passes the tests and is of practical size\n";
  for (const auto& e : r.named)
    out << "  " << e.id << " = " << number("%.5g", e.value) << " +- " << number("%.2g", e.std)
        << " " << e.unit << stribeck_width(e.term) << "  (Wald " << number("%.3g", e.wald)
        << ", p (Holm) " << number("%.2g", e.p_value) << ", BIC drop " << number("%.3g", e.bic_drop)
        << ", CV drop " << number("%.2f", 100.0 * e.cv_drop) << " %, size "
        << number("%.0f", 100.0 * e.practical_size.maxCoeff()) << " % of the noise)\n"
        << (e.caveat.empty() ? "" : "    but: " + e.caveat + "\n" + separating(o, e));
  out << "\nnot named:\n";
  for (const auto& t : r.not_named)
    out << "  " << t.id << stribeck_width(t.term) << ": " << t.reason
        << (std::isfinite(t.detection_limit) ? "; this log shows it from about " +
                                                   number("%.2g", t.detection_limit) + " " + t.unit
                                             : "")
        << "\n";
  const sid::ChainMotionCheck& m = whole.motion;
  if (m.final_error.size()) {
    out << "\nfree simulation (" << m.segments
        << " segments of 1 s from the smoothed state, driven by the smoothed torque; each model "
           "at its physically consistent fit): angle error RMS nominal -> final [rad], against "
           "the largest of "
        << m.replicate_error.rows()
        << " exact-model replicates of this log (the final model's motion and torque, with this "
           "log's noise, fitted and simulated alike)\n";
    std::string beyond;
    for (int j = 0; j < nominal.joints(); ++j) {
      const std::string& name = nominal.joint_names()[static_cast<std::size_t>(j)];
      out << "  " << name << ": " << number("%.3g", m.nominal_error[j]) << " -> "
          << number("%.3g", m.final_error[j]) << " (replicates up to "
          << number("%.2g", m.threshold[j] / kMotionMargin) << ", "
          << number("%.2g", m.final_error[j] * kMotionMargin / m.threshold[j]) << "x)\n";
    }
    for (const int j : m.beyond)
      beyond += (beyond.empty() ? "" : ", ") + nominal.joint_names()[static_cast<std::size_t>(j)];
    out << (beyond.empty()
                ? "  the final model follows the motion as an exact model does (within " +
                      number("%.0f", kMotionMargin) + "x the replicates)\n"
                : "  beyond " + number("%.0f", kMotionMargin) + "x what an exact model gives: " +
                      beyond + ": motion the final model does not explain\n");
    if (m.failed_nominal + m.failed_final > 0)
      out << "  segments that blew up or failed: nominal " << m.failed_nominal << ", final "
          << m.failed_final << " (first: " << m.failure << ")\n";
  }
  if (!whole.motion_note.empty()) out << "\n" << whole.motion_note << "\n";
  out << "\n"
      << (!remains_at_noise(r)
              ? "what remains above the noise (unexplained, per joint above) is not a tried drive "
                "term: look at the rigid-body model, the kinematics or effects not in the library\n"
              : "what remains is at the noise\n")
      << "time " << number("%.2f", r.seconds) << " s (the free simulations "
      << number("%.2f", whole.motion_seconds) << " s)\n";
  return out.str();
}

nlohmann::json test_json(const sid::ChainEffectTest& t) {
  nlohmann::json j = {{"id", t.id},           {"angle_offset", t.angle_offset},
                      {"value", t.value},     {"std", t.std},
                      {"unit", t.unit},       {"wald", t.wald},
                      {"p_value", t.p_value}, {"bic_drop", t.bic_drop},
                      {"cv_drop", t.cv_drop}, {"practical_size", to_json_array(t.practical_size)},
                      {"reason", t.reason},   {"caveat", t.caveat}};
  j["look_alikes"] = t.look_alikes;
  j["detection_limit"] = std::isfinite(t.detection_limit) ? nlohmann::json(t.detection_limit)
                                                          : nlohmann::json(nullptr);
  if (t.term.kind == sid::DriveTermKind::Stribeck) j["stribeck_velocity"] = t.term.velocity;
  return j;
}

nlohmann::json report_json(const ChainDiagnoseAppOptions& o, const sid::ChainModel& nominal,
                           const sid::RobotDiagnosis& whole) {
  const sid::ChainDiagnosis& r = whole.diagnosis;
  nlohmann::json j;
  j["robot"] = o.chain.robot;
  j["joint_names"] = nominal.joint_names();
  j["cutoff_hz"] = to_json_array(r.cutoff_hz);
  j["smoothing"] = r.smoothing;
  j["equations"] = r.equations;
  j["noise_floor"] = to_json_array(r.noise_floor);
  j["nominal_residual_rms"] = to_json_array(r.nominal_residual_rms);
  j["final_residual_rms"] = to_json_array(r.final_residual_rms);
  j["unexplained_rms"] = to_json_array(r.unexplained_rms);
  j["angle_offset"] = to_json_array(r.angle_offset);
  j["named"] = nlohmann::json::array();
  for (const auto& e : r.named) j["named"].push_back(test_json(e));
  j["not_named"] = nlohmann::json::array();
  for (const auto& t : r.not_named) j["not_named"].push_back(test_json(t));
  const sid::ChainMotionCheck& m = whole.motion;
  if (m.final_error.size()) {
    nlohmann::json replicates = nlohmann::json::array();
    for (Eigen::Index b = 0; b < m.replicate_error.rows(); ++b)
      replicates.push_back(to_json_array(Eigen::VectorXd(m.replicate_error.row(b).transpose())));
    nlohmann::json beyond = nlohmann::json::array();
    for (const int j : m.beyond)
      beyond.push_back(nominal.joint_names()[static_cast<std::size_t>(j)]);
    j["free_simulation"] = {{"segments", m.segments},
                            {"error_rms_nominal", to_json_array(m.nominal_error)},
                            {"error_rms_final", to_json_array(m.final_error)},
                            {"replicate_error_rms", replicates},
                            {"angle_noise", to_json_array(m.angle_noise)},
                            {"margin", kMotionMargin},
                            {"threshold", to_json_array(m.threshold)},
                            {"beyond", beyond},
                            {"failed_segments_nominal", m.failed_nominal},
                            {"failed_segments_final", m.failed_final},
                            {"failed_segments_replicates", m.failed_replicates}};
  }
  if (!whole.motion_note.empty()) j["free_simulation_note"] = whole.motion_note;
  j["seconds"] = r.seconds;
  return j;
}

/// The library's options from the tool's (--candidates, --negligible-size).
/// @throws InputError naming the option at fault.
sid::ChainDiagnoseOptions chain_diagnose_options(const ChainDiagnoseAppOptions& o) {
  sid::ChainDiagnoseOptions options;
  if (!o.candidates.empty()) {
    // angle_offset is not a drive term: the rest of the list is.
    std::string kinds;
    std::stringstream in(o.candidates);
    options.angle_offsets = false;
    for (std::string word; std::getline(in, word, ',');) {
      if (word == "angle_offset") {
        require(!options.angle_offsets, "--candidates: angle_offset is given twice");
        options.angle_offsets = true;
      } else {
        kinds += (kinds.empty() ? "" : ",") + word;
      }
    }
    try {
      options.candidate_kinds =
          sid::parse_drive_term_kinds(kinds.empty() && options.angle_offsets ? "none" : kinds);
    } catch (const std::invalid_argument& e) {
      throw InputError(std::string("--candidates: ") + e.what() + " (or angle_offset)");
    }
  }
  if (o.negligible_size) {
    require(*o.negligible_size >= 0.0 && *o.negligible_size < 1.0,
            "--negligible-size must be in [0, 1)");
    options.negligible_size = *o.negligible_size;
  }
  return options;
}

}  // namespace

std::string stribeck_width(const sid::DriveTerm& term) {
  return term.kind == sid::DriveTermKind::Stribeck
             ? " (vs = " + number("%.3g", term.velocity) + " rad/s)"
             : std::string();
}

bool remains_at_noise(const sid::ChainDiagnosis& diagnosis) {
  for (Eigen::Index j = 0; j < diagnosis.unexplained_rms.size(); ++j)
    if (diagnosis.unexplained_rms[j] > 0.5 * diagnosis.noise_floor[j]) return false;
  return true;
}

ChainDiagnoseResult diagnose_loaded(const ChainDiagnoseAppOptions& o, const LoadedChain& loaded) {
  require(!loaded.runs.empty(), "no run given");
  sid::ChainDiagnoseOptions options = chain_diagnose_options(o);
  options.identify = loaded.options;
  if (o.measured || loaded.runs.size() > 1) options.smoothing = sid::ChainSmoothingChoice::Measured;
  std::vector<sid::ChainTrajectory<double>> runs;
  for (const auto& r : loaded.runs) runs.push_back(r.data);
  ChainDiagnoseResult out;
  try {
    out.result =
        sid::diagnose_robot(loaded.model, runs, options, description_dynamics(loaded.robot));
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  out.text = report_text(o, loaded.model, out.result);
  out.json = report_json(o, loaded.model, out.result);
  out.html = diagnose_report_html(o, loaded, out);
  return out;
}

int diagnose_robot(const ChainDiagnoseAppOptions& o) {
  require(!o.chain.inputs.empty(), "no run given");
  if (!o.chain.json.empty()) ensure_writable(o.chain.json, o.chain.force);
  if (!o.chain.report.empty()) ensure_writable(o.chain.report, o.chain.force);
  // The options are checked before the files are read.
  (void)chain_diagnose_options(o);
  const LoadedChain loaded =
      load_chain(o.chain, {sid::DriveTermKind::Viscous, sid::DriveTermKind::Armature});
  const ChainDiagnoseResult r = diagnose_loaded(o, loaded);
  (o.chain.json == "-" ? std::cerr : std::cout) << r.text << std::flush;
  if (!o.chain.json.empty()) write_json(o.chain.json, r.json);
  if (!o.chain.report.empty()) write_text(o.chain.report, r.html);
  return kExitOk;
}

}  // namespace sid::app
