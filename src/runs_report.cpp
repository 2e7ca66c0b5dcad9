#include "runs_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "app.hpp"

namespace sid::app {
namespace {

bool ends_with(const std::string& text, const std::string& tail) {
  return text.size() >= tail.size() &&
         text.compare(text.size() - tail.size(), tail.size(), tail) == 0;
}

// The rotor of drive 2 rides on link 1. With θ1 and θ2 free its inertia Ir enters the
// regression only as an armature on joint 2, Ia = (gr² + gr) Ir (see docs/real-data.md).
void rotor_line(const RunsReportInput& in, std::ostringstream& out, nlohmann::json& j) {
  if (!in.gear_ratio || !in.model.has_term(kRotorCoupling.id())) return;
  const auto k = in.model.parameter_offset(kRotorCoupling.id());
  const double gr = *in.gear_ratio, factor = gr * gr + gr;
  const double ir = in.id.fit.theta[k] / factor, ir_std = in.id.fit.std_dev[k] / factor;
  out << "rotor of drive 2 on link 1 (gear ratio " << format_number("%g", gr)
      << "): Ir = Ia / (gr^2 + gr) = " << format_number("%.4g", ir) << " +- "
      << format_number("%.2g", ir_std) << " kg m^2"
      << (ir > 2.0 * ir_std ? " (supported: positive, more than 2 std from zero)"
          : ir < 0.0        ? " (not supported: negative, not physical)"
                            : " (not supported: within 2 std of zero)")
      << "\n";
  j["rotor"] = {
      {"gear_ratio", gr}, {"Ir", ir}, {"Ir_std", ir_std}, {"supported", ir > 2.0 * ir_std}};
}

}  // namespace

void physical_lines(const sid::Model<double>& model, const sid::PhysicalCheck& p,
                    const std::optional<sid::ConsistentEstimate>& consistent,
                    std::ostringstream& out, nlohmann::json& j) {
  out << "physical plausibility: mass matrix "
      << (p.mass_matrix_positive_definite ? "positive definite for every q2"
                                          : "NOT positive definite at q2 = " +
                                                format_number("%.3f", p.min_eigenvalue_q2) + " rad")
      << " (smallest eigenvalue " << format_number("%.4g", p.min_eigenvalue) << " kg m^2); ";
  if (p.negative_parameters.empty()) {
    out << "gravity, friction and armature terms non-negative";
  } else {
    out << "negative:";
    for (std::size_t k = 0; k < p.negative_parameters.size(); ++k)
      out << " " << p.negative_parameters[k] << " = "
          << format_number("%.4g", p.negative_values[k]);
  }
  out << (p.plausible() ? " -> plausible\n" : " -> NOT plausible\n");
  nlohmann::json pj;
  pj["plausible"] = p.plausible();
  pj["mass_matrix_positive_definite"] = p.mass_matrix_positive_definite;
  pj["min_mass_eigenvalue"] = p.min_eigenvalue;
  pj["min_mass_eigenvalue_q2"] = p.min_eigenvalue_q2;
  pj["negative_parameters"] = p.negative_parameters;
  pj["consistent_theta"] = nullptr;
  if (consistent) {
    const sid::ConsistentEstimate& c = *consistent;
    const std::vector<std::string> names = model.parameter_names();
    out << "nearest physically consistent estimate (least squares under the constraints; the table "
           "above is "
           "the unconstrained one):\n";
    for (std::size_t k = 0; k < names.size(); ++k)
      out << "  " << names[k] << " " << format_number("%.8g", c.theta[static_cast<Eigen::Index>(k)])
          << "\n";
    out << "  cost increase " << format_number("%.4g", c.cost_increase) << " N^2 m^2"
        << (c.converged ? "" : " (iteration limit: feasible, maybe not the closest)") << "\n";
    pj["consistent_theta"] = to_json_array(c.theta);
    pj["consistent_cost_increase"] = c.cost_increase;
    pj["consistent_active_bounds"] = c.active_bounds;
    pj["consistent_converged"] = c.converged;
  }
  j["physical"] = pj;
}

RunFile read_run(const std::string& file, const TrajectoryColumns& columns) {
  const CsvTable table = read_csv(file);
  RunFile run{table.source == "-" ? "<stdin>" : table.source,
              trajectory_from_table(table, columns)};
  require(run.data.size() >= 3,
          run.file + ": a run needs at least 3 data rows, got " + std::to_string(run.data.size()));
  return run;
}

std::vector<RunFile> read_runs(const std::vector<std::string>& files,
                               const TrajectoryColumns& columns) {
  std::vector<RunFile> runs;
  for (const auto& file : files) runs.push_back(read_run(file, columns));
  return runs;
}

void require_stdin_at_most_once(const std::vector<std::string>& fitted,
                                const std::vector<std::string>& held_out) {
  const auto uses = std::count(fitted.begin(), fitted.end(), "-") +
                    std::count(held_out.begin(), held_out.end(), "-");
  require(uses <= 1, "standard input ('-') can be read only once");
}

namespace {

void validation_lines(const RunsReportInput& in, std::ostringstream& out, nlohmann::json& j) {
  const int w = file_column_width(20, in.runs, in.validation);
  nlohmann::json rows = nlohmann::json::array();
  if (!in.validation.empty()) {
    out << "\nvalidation (runs not used in the fit): torque prediction RMS [N m]\n";
    char line[512];
    std::snprintf(line, sizeof line, "  %-*s %8s %10s %10s", w, "file", "samples", "joint 1",
                  "joint 2");
    out << line << (in.reference_theta ? "   reference: joint 1, joint 2" : "") << "\n";
    sid::Vector2<double> mean = sid::Vector2<double>::Zero(), reference_mean = mean;
    for (const auto& v : in.validation) {
      std::snprintf(line, sizeof line, "  %-*s %8ld %10.4f %10.4f", w, v.file.c_str(),
                    static_cast<long>(v.prediction.samples), v.prediction.residual_rms[0],
                    v.prediction.residual_rms[1]);
      out << line;
      nlohmann::json r{{"file", v.file},
                       {"samples", v.prediction.samples},
                       {"residual_rms", to_json_array(v.prediction.residual_rms)},
                       {"nominal_residual_rms", to_json_array(v.prediction.residual_rms)}};
      mean += v.prediction.residual_rms / static_cast<double>(in.validation.size());
      if (v.reference) {
        std::snprintf(line, sizeof line, "   %10.4f %10.4f", v.reference->residual_rms[0],
                      v.reference->residual_rms[1]);
        out << line;
        r["reference_residual_rms"] = to_json_array(v.reference->residual_rms);
        reference_mean += v.reference->residual_rms / static_cast<double>(in.validation.size());
      }
      out << "\n";
      rows.push_back(r);
    }
    if (in.validation.size() > 1) {
      std::snprintf(line, sizeof line, "  %-*s %8s %10.4f %10.4f", w, "mean", "", mean[0], mean[1]);
      out << line;
      if (in.reference_theta) {
        std::snprintf(line, sizeof line, "   %10.4f %10.4f", reference_mean[0], reference_mean[1]);
        out << line;
      }
      out << "\n";
    }
  }
  j["validation"] = rows;
}

void runs_table(const RunsReportInput& in, std::ostringstream& out, nlohmann::json& j) {
  const int w = file_column_width(20, in.runs, in.validation);
  char line[512];
  const bool left_out = in.id.left_out_prediction_rms.size() == in.runs.size();
  std::snprintf(line, sizeof line, "  %-*s %8s %8s %12s %10s %10s", w, "run (fitted)", "samples",
                "used", "lambda", "RMS j1", "RMS j2");
  out << line << (left_out ? "   left out: j1, j2" : "")
      << (in.reference_theta ? "   reference: j1, j2" : "") << "\n";
  nlohmann::json runs = nlohmann::json::array();
  for (std::size_t r = 0; r < in.runs.size(); ++r) {
    const auto& rms = in.id.residual_rms[r];
    std::snprintf(line, sizeof line, "  %-*s %8ld %8ld %12.4g %10.4f %10.4f", w,
                  in.runs[r].file.c_str(), static_cast<long>(in.runs[r].data.size()),
                  static_cast<long>(in.id.kinematics[r].size()), in.id.lambda[r], rms[0], rms[1]);
    out << line;
    if (left_out) {
      std::snprintf(line, sizeof line, "   %8.4f %8.4f", in.id.left_out_prediction_rms[r][0],
                    in.id.left_out_prediction_rms[r][1]);
      out << line;
    }
    nlohmann::json run{{"file", in.runs[r].file},
                       {"samples_total", in.runs[r].data.size()},
                       {"samples_used", in.id.kinematics[r].size()},
                       {"lambda", in.id.lambda[r]},
                       {"residual_rms", to_json_array(rms)}};
    run["left_out_prediction_rms"] =
        left_out ? to_json_array(in.id.left_out_prediction_rms[r]) : nlohmann::json(nullptr);
    if (r < in.reference_on_fitted.size()) {
      std::snprintf(line, sizeof line, "   %8.4f %8.4f", in.reference_on_fitted[r].residual_rms[0],
                    in.reference_on_fitted[r].residual_rms[1]);
      out << line;
      run["reference_residual_rms"] = to_json_array(in.reference_on_fitted[r].residual_rms);
    }
    out << "\n";
    runs.push_back(run);
  }
  j["runs"] = runs;
}

void smoothing_lines(const RunsReportInput& in, std::ostringstream& out, nlohmann::json& j) {
  const sid::RunsIdentification& id = in.id;
  out << "smoothing: cutoff " << format_number("%.4g", id.cutoff_hz) << " Hz";
  std::size_t best = 0;
  for (std::size_t g = 0; g < id.grid_hz.size(); ++g)
    if (id.grid_hz[g] == id.cutoff_hz) best = g;
  if (id.cutoff_chosen)
    out << ", chosen by " << in.options.folds_per_run
        << "-fold cross-validation of the torque prediction over "
        << format_number("%g", id.grid_hz.front()) << ".." << format_number("%g", id.grid_hz.back())
        << " Hz (held-out torque RMS " << format_number("%.4g", id.cross_validation_rms[best])
        << " N m)";
  else
    out << " (given)";
  if (id.cutoff_chosen && (best == 0 || best + 1 == id.grid_hz.size()))
    out << "\nwarning: the cutoff is at the end of the searched range; the data may need a wider "
           "one";
  out << "\n";
  j["smoothing"] = {{"mode", "torque-cv"},        {"cutoff_hz", id.cutoff_hz},
                    {"chosen", id.cutoff_chosen}, {"folds_per_run", in.options.folds_per_run},
                    {"grid_hz", id.grid_hz},      {"cross_validation_rms", id.cross_validation_rms},
                    {"lambda", id.lambda}};
}

// std is the HAC one (the residuals are correlated in time); with three runs or more the
// spread over the fits that leave one run out is shown too, and is the larger, honest one.
void parameter_table(const RunsReportInput& in, std::ostringstream& out, nlohmann::json& j) {
  const auto& fit = in.id.fit;
  const std::vector<std::string> names = in.model.parameter_names();
  const bool jackknife = in.id.jackknife_std_dev.size() == fit.theta.size();
  const bool hac = in.id.hac_std_dev.size() == fit.theta.size();
  const Eigen::VectorXd std_dev = hac ? in.id.hac_std_dev : fit.std_dev;
  Eigen::VectorXd relative = 100.0 * std_dev.cwiseQuotient(fit.theta.cwiseAbs());
  char line[256];
  std::snprintf(line, sizeof line, "%-22s %15s %12s %11s %12s  %-10s", "parameter", "estimate",
                "std (HAC)", "rel.std %", jackknife ? "std (runs)" : "", "unit");
  out << line << (in.reference_theta ? "  reference" : "") << "\n";
  std::vector<std::string> units;
  for (std::size_t k = 0; k < names.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    units.push_back(parameter_unit(names[k]));
    std::snprintf(line, sizeof line, "%-22s %15s %12s %11s %12s  %-10s", names[k].c_str(),
                  format_number("%.8g", fit.theta[i]).c_str(),
                  format_number("%.3g", std_dev[i]).c_str(),
                  format_number("%.4f", relative[i]).c_str(),
                  jackknife ? format_number("%.3g", in.id.jackknife_std_dev[i]).c_str() : "",
                  units.back().c_str());
    out << line;
    if (in.reference_theta) out << "  " << format_number("%.6g", (*in.reference_theta)[i]);
    out << "\n";
  }
  out << "std (HAC): from the residuals' autocorrelation (Newey-West); the least-squares std "
         "assumes none and is "
      << format_number("%.2g", (std_dev.cwiseQuotient(fit.std_dev)).minCoeff()) << "-"
      << format_number("%.2g", (std_dev.cwiseQuotient(fit.std_dev)).maxCoeff()) << "x smaller here"
      << (jackknife ? ";\nstd (runs): jackknife over the fits that leave one run out (what differs "
                      "between runs)"
                    : "")
      << "\n";
  j["names"] = names;
  j["units"] = units;
  j["theta"] = to_json_array(fit.theta);
  j["std"] = to_json_array(std_dev);
  j["rel_std_pct"] = to_json_array(relative);
  j["ls_std"] = to_json_array(fit.std_dev);
  j["jackknife_std"] = jackknife ? to_json_array(in.id.jackknife_std_dev) : nlohmann::json(nullptr);
}

}  // namespace

std::string parameter_unit(const std::string& name) {
  if (name == "theta1" || name == "theta2" || name == "theta3" || ends_with(name, ".Ia") ||
      ends_with(name, ".theta3_sin"))
    return "kg m^2";
  if (name == "theta4" || name == "theta5" || ends_with(name, ".theta4_sin") ||
      ends_with(name, ".theta5_sin"))
    return "kg m";
  if (name == "theta6" || name == "theta7") return "N m s/rad";
  if (ends_with(name, ".Fc") || ends_with(name, ".Fs_minus_Fc") || ends_with(name, ".b"))
    return "N m";
  if (ends_with(name, ".k")) return "N m/rad";
  return "";
}

RunsReport make_runs_report(const RunsReportInput& in) {
  const auto& fit = in.id.fit;
  std::ostringstream out;
  nlohmann::json j;
  Eigen::Index used = 0;
  for (const auto& k : in.id.kinematics) used += k.size();
  out << in.program << ": " << in.runs.size() << (in.runs.size() == 1 ? " run" : " runs") << ", "
      << used << " samples used (" << 2 * used << " equations), method css, estimator ls\n";
  smoothing_lines(in, out, j);
  out << "\n";
  parameter_table(in, out, j);
  out << "\nresidual RMS [N m] over the fitted runs: joint 1 "
      << format_number("%.4g", fit.residual_rms[0]) << ", joint 2 "
      << format_number("%.4g", fit.residual_rms[1]) << "\n";
  out << "condition number (column-scaled regressor): "
      << format_number("%.4g", fit.condition_number) << "\n";
  runs_table(in, out, j);
  validation_lines(in, out, j);
  out << "\n";
  physical_lines(in.model, in.physical, in.consistent, out, j);
  rotor_line(in, out, j);
  if (fit.ill_conditioned) out << "warning: " << fit.message << "\n";

  std::vector<std::string> files;
  for (const auto& r : in.runs) files.push_back(r.file);
  j["input"] = files;
  j["method"] = "css";
  j["estimator"] = "ls";
  j["residual_rms"] = to_json_array(fit.residual_rms);
  j["condition_number"] = fit.condition_number;
  j["ill_conditioned"] = fit.ill_conditioned;
  j["warning"] = fit.ill_conditioned ? nlohmann::json(fit.message) : nlohmann::json(nullptr);
  j["samples_used"] = used;
  j["skip"] = in.options.skip;
  j["skip_end"] = in.options.skip_end;
  j["reference_theta"] =
      in.reference_theta ? to_json_array(*in.reference_theta) : nlohmann::json(nullptr);
  return {out.str(), j};
}

}  // namespace sid::app
