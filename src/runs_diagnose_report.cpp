#include "runs_diagnose_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "app.hpp"
#include "diagnose_report.hpp"  // simulation_summary

namespace sid::app {
namespace {

std::string values_text(const sid::RunsEffectTest& t) {
  const auto names = sid::effect_value_names(t.effect);
  const auto units = sid::effect_value_units(t.effect);
  std::string text;
  for (std::size_t k = 0; k < names.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    text += (k ? ", " : "") + names[k] + " = " + format_number("%.4g", t.estimate.value[i]);
    if (t.estimate.std[i] > 0.0) text += " +- " + format_number("%.2g", t.estimate.std[i]);
    text += " " + units[k];
  }
  return text;
}

nlohmann::json effect_json(const sid::RunsEffectTest& t) {
  return {{"id", t.effect.id()},
          {"name", sid::effect_name(t.effect)},
          {"value_names", sid::effect_value_names(t.effect)},
          {"estimate", to_json_array(t.estimate.value)},
          {"std", to_json_array(t.estimate.std)},
          {"wald", t.wald},
          {"p_value", t.p_value},
          {"prediction_gain", to_json_array(t.prediction_gain)},
          {"reason", t.reason}};
}

void runs_table(const RunsDiagnoseReportInput& in, std::ostringstream& out, nlohmann::json& j) {
  const sid::RunsDiagnosis& d = in.diagnosis;
  const bool left_out = d.final.left_out_prediction_rms.size() == in.runs.size();
  const int w = file_column_width(12, in.runs, in.validation);
  out << "\ntorque per run [N m], joint 1 / joint 2: the floor (content above the cutoff, which no "
         "model on\n"
         "the smoothed angles can explain), the residual RMS of the nominal and the final model"
      << (left_out ? ", and the final\nmodel's prediction of the run from the other runs' fit" : "")
      << "\n";
  char line[512];
  std::snprintf(line, sizeof line, "  %-*s %7s %15s %15s %15s", w, "run", "used", "floor",
                "nominal", "final");
  out << line << (left_out ? "        left out" : "") << "\n";
  nlohmann::json rows = nlohmann::json::array();
  sid::Vector2<double> mean_left_out = sid::Vector2<double>::Zero();
  for (std::size_t r = 0; r < in.runs.size(); ++r) {
    const auto& f = d.floor[r];
    const auto& nominal = d.nominal.residual_rms[r];
    const auto& final = d.final.residual_rms[r];
    std::snprintf(line, sizeof line, "  %-*s %7ld %7.4f %7.4f %7.4f %7.4f %7.4f %7.4f", w,
                  in.runs[r].file.c_str(), static_cast<long>(d.final.kinematics[r].size()), f[0],
                  f[1], nominal[0], nominal[1], final[0], final[1]);
    out << line;
    nlohmann::json row{{"file", in.runs[r].file},
                       {"samples", in.runs[r].data.size()},
                       {"used", d.final.kinematics[r].size()},
                       {"floor", to_json_array(f)},
                       {"nominal_residual_rms", to_json_array(nominal)},
                       {"residual_rms", to_json_array(final)}};
    if (left_out) {
      const auto& p = d.final.left_out_prediction_rms[r];
      std::snprintf(line, sizeof line, " %7.4f %7.4f", p[0], p[1]);
      out << line;
      row["left_out_prediction_rms"] = to_json_array(p);
      mean_left_out += p / static_cast<double>(in.runs.size());
    }
    out << "\n";
    rows.push_back(row);
  }
  if (left_out) {
    std::snprintf(line, sizeof line, "  %-*s %55s %7.4f %7.4f", w, "mean", "", mean_left_out[0],
                  mean_left_out[1]);
    out << line << "\n";
    j["mean_left_out_prediction_rms"] = to_json_array(mean_left_out);
  }
  j["runs"] = rows;
}

void friction_shape_lines(const RunsDiagnoseReportInput& in, std::ostringstream& out,
                          nlohmann::json& j) {
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& s : in.diagnosis.friction_shapes) {
    const bool atan = s.shape == sid::CoulombShape::Atan;
    out << "  friction shape of " << s.coulomb << ": " << (atan ? "atan" : "tanh") << ", "
        << (s.asymmetric ? "asymmetric" : "symmetric") << " (atan instead of tanh: held-out "
        << sid::detail::mean_square_change(s.atan_gain)
        << "; asymmetric: " << sid::detail::mean_square_change(s.asymmetric_gain)
        << ", Wald p = " << format_number("%.2g", s.asymmetric_p_value) << ", forward "
        << format_number("%.4g", s.forward) << " +- " << format_number("%.2g", s.forward_std)
        << ", backward " << format_number("%.4g", s.backward) << " +- "
        << format_number("%.2g", s.backward_std) << " N m)\n";
    rows.push_back({{"id", s.coulomb.id()},
                    {"shape", atan ? "atan" : "tanh"},
                    {"asymmetric", s.asymmetric},
                    {"atan_gain", to_json_array(s.atan_gain)},
                    {"asymmetric_gain", to_json_array(s.asymmetric_gain)},
                    {"asymmetric_p_value", s.asymmetric_p_value},
                    {"forward", s.forward},
                    {"backward", s.backward},
                    {"forward_std", s.forward_std},
                    {"backward_std", s.backward_std}});
  }
  j["friction_shapes"] = rows;
}

void effect_lines(const RunsDiagnoseReportInput& in, std::ostringstream& out, nlohmann::json& j) {
  const sid::RunsDiagnosis& d = in.diagnosis;
  out << "\nnamed effects (significant under the HAC covariance and lowering the held-out torque "
         "error):\n";
  if (d.named.empty()) out << "  none\n";
  nlohmann::json named = nlohmann::json::array(), rejected = nlohmann::json::array();
  for (const auto& t : d.named) {
    out << "  " << t.effect << ": " << sid::effect_name(t.effect) << "\n    " << values_text(t)
        << "; held-out torque mean square " << sid::detail::mean_square_change(t.prediction_gain)
        << " (joint 1 / 2) when added\n";
    named.push_back(effect_json(t));
  }
  friction_shape_lines(in, out, j);
  out << "not named:\n";
  for (const auto& t : d.not_named) {
    out << "  " << t.effect << " (" << values_text(t) << "): " << t.reason << "\n";
    rejected.push_back(effect_json(t));
  }
  j["effects"] = named;
  j["not_named"] = rejected;
}

// The rotor of drive 2 rides on link 1. With θ1 and θ2 free its inertia Ir enters the
// regression only as an armature on joint 2, Ia = (gr² + gr) Ir (see docs/real-data.md).
void rotor_lines(const RunsDiagnoseReportInput& in, std::ostringstream& out, nlohmann::json& j) {
  const sid::RunsDiagnosis& d = in.diagnosis;
  const auto named = std::find_if(d.named.begin(), d.named.end(),
                                  [](const auto& t) { return t.effect == kRotorCoupling; });
  const sid::RunsEffectTest* t = named != d.named.end() ? &*named
                                 : d.rotor_coupling     ? &*d.rotor_coupling
                                                        : nullptr;
  if (!t) return;
  const bool supported = named != d.named.end();
  const double ia = t->estimate.value[0], ia_std = t->estimate.std[0];
  out << "\nrotor coupling of drive 2 on link 1 (armature_j2): Ia = " << format_number("%.4g", ia)
      << " +- " << format_number("%.2g", ia_std) << " kg m^2";
  nlohmann::json rj{{"Ia", ia},
                    {"Ia_std", ia_std},
                    {"supported", supported},
                    {"prediction_gain", to_json_array(t->prediction_gain)},
                    {"p_value", t->p_value}};
  if (in.gear_ratio) {
    const double factor = *in.gear_ratio * *in.gear_ratio + *in.gear_ratio;
    out << ", so Ir = Ia / (gr^2 + gr) = " << format_number("%.3g", ia / factor) << " +- "
        << format_number("%.2g", ia_std / factor) << " kg m^2 (gear ratio "
        << format_number("%g", *in.gear_ratio) << ")";
    rj["gear_ratio"] = *in.gear_ratio;
    rj["Ir"] = ia / factor;
    rj["Ir_std"] = ia_std / factor;
  }
  out << "\n  " << (supported ? "supported: named" : "not supported: " + t->reason) << "\n";
  j["rotor_coupling"] = rj;
}

void theta_lines(const RunsDiagnoseReportInput& in, std::ostringstream& out, nlohmann::json& j) {
  const sid::RunsDiagnosis& d = in.diagnosis;
  const auto names = d.final_model.parameter_names();
  const bool jackknife = d.final.jackknife_std_dev.size() == d.final.fit.theta.size();
  out << "\nfinal model (all runs): estimate, HAC std"
      << (jackknife ? ", std over runs left out" : "") << "\n";
  char line[256];
  for (std::size_t k = 0; k < names.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    std::snprintf(line, sizeof line, "  %-18s %14.6g %12.3g", names[k].c_str(),
                  d.final.fit.theta[i],
                  d.final.hac_std_dev.size() > i ? d.final.hac_std_dev[i] : std::nan(""));
    out << line;
    if (jackknife) {
      std::snprintf(line, sizeof line, " %12.3g", d.final.jackknife_std_dev[i]);
      out << line;
    }
    out << "\n";
  }
  j["final"] = {{"parameter_names", names},
                {"theta", to_json_array(d.final.fit.theta)},
                {"std", to_json_array(d.final.hac_std_dev)},
                {"jackknife_std",
                 jackknife ? to_json_array(d.final.jackknife_std_dev) : nlohmann::json(nullptr)}};
  j["nominal"] = {{"parameter_names", d.nominal_model.parameter_names()},
                  {"theta", to_json_array(d.nominal.fit.theta)},
                  {"std", to_json_array(d.nominal.hac_std_dev)}};
}

void simulation_lines(const RunsDiagnoseReportInput& in, std::ostringstream& out,
                      nlohmann::json& j) {
  if (in.simulations.empty()) return;
  out << "\nfree simulation of the final model (driven by the measured torque, restarted from the "
         "smoothed\n"
         "state every "
      << format_number("%g", in.segment) << " s), q error RMS [rad]:\n";
  nlohmann::json rows = nlohmann::json::array();
  const int w = file_column_width(12, in.runs, in.validation);
  for (std::size_t r = 0; r < in.simulations.size(); ++r) {
    const auto& s = in.simulations[r];
    char head[256];
    std::snprintf(head, sizeof head, "  %-*s ", w, in.runs[r].file.c_str());
    out << head << simulation_summary(s) << "\n";
    rows.push_back({{"file", in.runs[r].file},
                    {"ok", s.ok()},
                    {"error_rms", to_json_array(s.error_rms)},
                    {"segments", s.segment_starts.size()},
                    {"failed_segments", s.failed_segments},
                    {"message", s.message.substr(0, s.message.find("; "))}});
  }
  j["simulation"] = rows;
}

void validation_lines(const RunsDiagnoseReportInput& in, std::ostringstream& out,
                      nlohmann::json& j) {
  nlohmann::json rows = nlohmann::json::array();
  if (!in.validation.empty()) {
    out << "\nvalidation (runs not used in the fit): torque prediction RMS [N m], joint 1 / joint "
           "2\n";
    const int w = file_column_width(12, in.runs, in.validation);
    char line[512];
    std::snprintf(line, sizeof line, "  %-*s %8s %17s %17s", w, "file", "samples", "final",
                  "nominal");
    out << line << "\n";
    for (const auto& v : in.validation) {
      std::snprintf(line, sizeof line, "  %-*s %8ld %8.4f %8.4f %8.4f %8.4f", w, v.file.c_str(),
                    static_cast<long>(v.final.samples), v.final.residual_rms[0],
                    v.final.residual_rms[1], v.nominal.residual_rms[0], v.nominal.residual_rms[1]);
      out << line << "\n";
      rows.push_back({{"file", v.file},
                      {"samples", v.final.samples},
                      {"residual_rms", to_json_array(v.final.residual_rms)},
                      {"nominal_residual_rms", to_json_array(v.nominal.residual_rms)}});
    }
  }
  j["validation"] = rows;
}

}  // namespace

RunsReport make_runs_diagnose_report(const RunsDiagnoseReportInput& in) {
  const sid::RunsDiagnosis& d = in.diagnosis;
  std::ostringstream out;
  nlohmann::json j;
  Eigen::Index samples = 0;
  for (const auto& k : d.final.kinematics) samples += k.size();
  out << "sid_diagnose: " << in.runs.size() << " run" << (in.runs.size() == 1 ? "" : "s")
      << " diagnosed together (" << samples << " equations per joint), "
      << format_number("%.2f", d.seconds) << " s\n";
  out << "smoothing: cutoff " << format_number("%.3g", d.cutoff_hz) << " Hz"
      << (d.cutoff_chosen ? " (chosen by torque cross-validation)" : " (given)") << "; held out: "
      << (in.runs.size() >= 3 ? "each run in turn"
                              : "each of " + std::to_string(in.options.identify.folds_per_run) +
                                    " contiguous blocks of every run")
      << "\n";
  j["input"] = nlohmann::json::array();
  for (const auto& r : in.runs) j["input"].push_back(r.file);
  j["cutoff_hz"] = d.cutoff_hz;
  j["cutoff_chosen"] = d.cutoff_chosen;
  runs_table(in, out, j);
  effect_lines(in, out, j);
  rotor_lines(in, out, j);
  out << "\nwhat no effect explains (residual excess over the floor, over all runs), joint 1 / "
         "joint 2: "
      << format_number("%.4f", d.excess_rms[0]) << " / " << format_number("%.4f", d.excess_rms[1])
      << " N m fitted";
  if (!std::isnan(d.left_out_excess_rms[0]))
    out << ", " << format_number("%.4f", d.left_out_excess_rms[0]) << " / "
        << format_number("%.4f", d.left_out_excess_rms[1]) << " N m held out";
  out << "\n";
  j["excess_rms"] = to_json_array(d.excess_rms);
  j["left_out_excess_rms"] = to_json_array(d.left_out_excess_rms);
  theta_lines(in, out, j);
  physical_lines(d.final_model, in.physical, in.consistent, out, j);
  simulation_lines(in, out, j);
  validation_lines(in, out, j);
  j["seconds"] = d.seconds;
  return {out.str(), j};
}

}  // namespace sid::app
