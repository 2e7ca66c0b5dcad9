#include "chain_diagnose_app.hpp"

#include <sid/diagnose_chain.hpp>

#include "app.hpp"

#include <nlohmann/json.hpp>

#include <iostream>
#include <sstream>

namespace sid::app {

namespace {

std::string number(const char* format, double v) { return format_number(format, v); }

std::string report_text(const ChainDiagnoseAppOptions& o, const sid::ChainModel& nominal,
                        const sid::ChainDiagnosis& r) {
  std::ostringstream out;
  out << "robot " << o.chain.robot << ": " << nominal.joints() << " joints; nominal model: rigid "
      << "bodies";
  for (const sid::DriveTerm& t : nominal.terms())
    if (!t.on_motor && t.index == 0) out << ", " << sid::drive_term_keyword(t.kind);
  out << " (" << r.equations << " equations)\nsmoothing cutoffs [Hz]:";
  for (Eigen::Index j = 0; j < r.cutoff_hz.size(); ++j)
    out << " " << number("%.3g", r.cutoff_hz[j]);
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
        << " " << e.unit << "  (Wald " << number("%.3g", e.wald) << ", p (Holm) "
        << number("%.2g", e.p_value) << ", BIC drop " << number("%.3g", e.bic_drop) << ", CV drop "
        << number("%.2f", 100.0 * e.cv_drop) << " %, size "
        << number("%.0f", 100.0 * e.practical_size.maxCoeff()) << " % of the noise)\n";
  out << "\nnot named:\n";
  for (const auto& t : r.not_named) out << "  " << t.id << ": " << t.reason << "\n";
  double unexplained = 0.0;
  for (Eigen::Index j = 0; j < r.unexplained_rms.size(); ++j)
    unexplained = std::max(unexplained, r.unexplained_rms[j] / r.noise_floor[j]);
  out << "\n"
      << (unexplained > 0.5
              ? "what remains above the noise (unexplained, per joint above) is not a tried drive "
                "term: look at the rigid-body model, the kinematics or effects not in the library\n"
              : "what remains is at the noise\n")
      << "time " << number("%.2f", r.seconds) << " s\n";
  return out.str();
}

nlohmann::json test_json(const sid::ChainEffectTest& t) {
  return {{"id", t.id},
          {"value", t.value},
          {"std", t.std},
          {"unit", t.unit},
          {"wald", t.wald},
          {"p_value", t.p_value},
          {"bic_drop", t.bic_drop},
          {"cv_drop", t.cv_drop},
          {"practical_size", to_json_array(t.practical_size)},
          {"reason", t.reason}};
}

nlohmann::json report_json(const ChainDiagnoseAppOptions& o, const sid::ChainModel& nominal,
                           const sid::ChainDiagnosis& r) {
  nlohmann::json j;
  j["robot"] = o.chain.robot;
  j["joint_names"] = nominal.joint_names();
  j["cutoff_hz"] = to_json_array(r.cutoff_hz);
  j["equations"] = r.equations;
  j["noise_floor"] = to_json_array(r.noise_floor);
  j["nominal_residual_rms"] = to_json_array(r.nominal_residual_rms);
  j["final_residual_rms"] = to_json_array(r.final_residual_rms);
  j["unexplained_rms"] = to_json_array(r.unexplained_rms);
  j["named"] = nlohmann::json::array();
  for (const auto& e : r.named) j["named"].push_back(test_json(e));
  j["not_named"] = nlohmann::json::array();
  for (const auto& t : r.not_named) j["not_named"].push_back(test_json(t));
  j["seconds"] = r.seconds;
  return j;
}

}  // namespace

int diagnose_robot(const ChainDiagnoseAppOptions& o) {
  require(!o.chain.inputs.empty(), "no run given");
  if (!o.chain.json.empty()) ensure_writable(o.chain.json, o.chain.force);
  sid::ChainDiagnoseOptions options;
  if (!o.candidates.empty()) {
    try {
      options.candidate_kinds = sid::parse_drive_term_kinds(o.candidates);
    } catch (const std::invalid_argument& e) {
      throw InputError(std::string("--candidates: ") + e.what());
    }
  }
  if (o.negligible_size) {
    require(*o.negligible_size >= 0.0 && *o.negligible_size < 1.0,
            "--negligible-size must be in [0, 1)");
    options.negligible_size = *o.negligible_size;
  }
  // The options are checked before the files are read.
  const LoadedChain loaded =
      load_chain(o.chain, {sid::DriveTermKind::Viscous, sid::DriveTermKind::Armature});
  options.identify = loaded.options;
  std::vector<sid::ChainTrajectory<double>> runs;
  for (const auto& r : loaded.runs) runs.push_back(r.data);
  sid::ChainDiagnosis result;
  try {
    result = sid::diagnose_chain(loaded.model, runs, options);
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  (o.chain.json == "-" ? std::cerr : std::cout)
      << report_text(o, loaded.model, result) << std::flush;
  if (!o.chain.json.empty()) write_json(o.chain.json, report_json(o, loaded.model, result));
  return kExitOk;
}

}  // namespace sid::app
