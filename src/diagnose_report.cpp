#include "diagnose_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sid/model/effects.hpp>
#include <sstream>
#include <utility>

#include "app.hpp"

namespace sid::app {

namespace {

std::string format(const char* fmt, double v) {
  if (std::isnan(v)) return "n/a";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, fmt, v);
  return buffer;
}

std::string g(double v) { return format("%.4g", v); }

std::string pad(const std::string& text, std::size_t width) {
  return text.size() >= width ? text : text + std::string(width - text.size(), ' ');
}

std::string pad_left(const std::string& text, std::size_t width) {
  return text.size() >= width ? text : std::string(width - text.size(), ' ') + text;
}

nlohmann::json number(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

nlohmann::json pair_json(const sid::Vector2<double>& v) {
  return nlohmann::json::array({number(v[0]), number(v[1])});
}

nlohmann::json windows_json(const std::vector<sid::FlaggedWindow>& windows) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& w : windows)
    out.push_back({{"joint", w.joint},
                   {"t_begin", w.t_begin},
                   {"t_end", w.t_end},
                   {"ratio", number(w.ratio)}});
  return out;
}

nlohmann::json model_json(const sid::ModelReport& m) {
  nlohmann::json j;
  j["parameter_names"] = m.parameter_names;
  j["theta"] = to_json_array(m.theta);
  j["std"] = to_json_array(m.std);
  j["residual_rms"] = pair_json(m.residual_rms);
  j["excess_rms"] = pair_json(m.excess_rms);
  j["excess_resolution"] = pair_json(m.excess_resolution);
  j["sim_error_rms"] = pair_json(m.sim_error_rms);
  j["windows"] = windows_json(m.windows);
  j["sim_windows"] = windows_json(m.sim_windows);
  return j;
}

int count_joint(const std::vector<sid::FlaggedWindow>& windows, int joint) {
  return static_cast<int>(
      std::count_if(windows.begin(), windows.end(),
                    [joint](const sid::FlaggedWindow& w) { return w.joint == joint; }));
}

// "1.25-1.75 s (x3.2), 4.25-4.75 s (x5.1)" for one joint; "none" when empty.
std::string window_list(const std::vector<sid::FlaggedWindow>& windows, int joint) {
  std::string text;
  for (const auto& w : windows) {
    if (w.joint != joint) continue;
    if (!text.empty()) text += ", ";
    text += format("%.2f", w.t_begin) + "-" + format("%.2f", w.t_end) + " s (x" +
            format("%.1f", w.ratio) + ")";
  }
  return text.empty() ? "none" : text;
}

std::string unit_of(sid::Effect effect, std::size_t k) {
  const auto units = sid::effect_value_units(effect);
  return k < units.size() ? units[k] : "";
}

// The unit of an effect's main physical parameter (the one detection limits are given in).
std::string main_unit(sid::Effect effect) { return unit_of(effect, 0); }

void disagreement(std::ostringstream& out, const sid::ModelReport& m,
                  const sid::DiagnosisResult& r) {
  for (int j = 0; j < 2; ++j) {
    out << "  joint " << j + 1 << ": torque residual RMS " << g(m.residual_rms[j])
        << " N m vs noise floor " << g(r.noise_floor[j]) << " (torque) and "
        << g(r.kinematic_floor[j]) << " (angle noise through q''), excess " << g(m.excess_rms[j])
        << " N m (below " << g(m.excess_resolution[j])
        << " it means nothing); free-simulation error RMS " << g(m.sim_error_rms[j]) << " rad\n";
    out << "    torque windows beyond the noise: " << window_list(m.windows, j + 1) << "\n";
    out << "    simulation windows beyond the noise: " << window_list(m.sim_windows, j + 1) << "\n";
  }
}

// Splits a stacked residual (joint 1's samples, then joint 2's) into one joint's column;
// NaN when it is missing or has the wrong length.
Eigen::VectorXd joint_residual(const sid::ModelReport& m, Eigen::Index n, int joint) {
  if (m.residual.size() != 2 * n) return Eigen::VectorXd::Constant(n, std::nan(""));
  return m.residual.segment(joint * n, n);
}

// Centred moving average over `half` samples each side (fewer at the ends); NaN stays NaN.
Eigen::VectorXd moving_average(const Eigen::VectorXd& y, Eigen::Index half) {
  const Eigen::Index n = y.size();
  Eigen::VectorXd out(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index a = std::max<Eigen::Index>(0, i - half),
                       b = std::min<Eigen::Index>(n - 1, i + half);
    out[i] = y.segment(a, b - a + 1).mean();
  }
  return out;
}

// Equations per joint the fits left out because that joint was at rest.
Eigen::Vector2i left_out(const sid::DiagnosisResult& r) {
  const Eigen::Index n = r.kinematics.size();
  Eigen::Vector2i count = Eigen::Vector2i::Zero();
  if (r.kept.size() != 2 * n) return count;
  for (int j = 0; j < 2; ++j)
    for (Eigen::Index i = 0; i < n; ++i)
      if (r.kept[j * n + i] == 0.0) ++count[j];
  return count;
}

}  // namespace

std::string diagnose_report(const sid::DiagnosisResult& r, const sid::SimulationCheck& sim,
                            const DiagnoseReportContext& context) {
  std::ostringstream out;
  const sid::Kinematics<double>& k = r.kinematics;
  out << "sid_diagnose: " << context.input << ", " << k.size() << " of " << context.samples_total
      << " samples used";
  if (k.size() > 0) out << " (t = " << g(k.t[0]) << " .. " << g(k.t[k.size() - 1]) << " s)";
  out << "\n\n";

  out << "noise floor of the torque (sigma of its GCV smoothing spline) [N m]: joint 1 "
      << g(r.noise_floor[0]) << ", joint 2 " << g(r.noise_floor[1]) << "\n";
  out << "kinematic floor (the torque error the angle noise leaves through the smoothed qd, qdd) "
         "[N m]: joint 1 "
      << g(r.kinematic_floor[0]) << ", joint 2 " << g(r.kinematic_floor[1])
      << "; excesses are over sqrt(noise^2 + kinematic^2)\n";
  const Eigen::Vector2i rest = left_out(r);
  out << "equations left out where a joint rests (|qd| < " << g(context.rest_velocity)
      << " rad/s, and " << g(context.rest_margin)
      << " s around; static friction is unknown there): joint 1 " << rest[0] << ", joint 2 "
      << rest[1] << " of " << k.size() << "\n";
  out << "free simulation: restarted from the smoothed state every " << g(context.segment)
      << " s; torque noise alone gives " << g(sim.noise_error_rms[0]) << ", "
      << g(sim.noise_error_rms[1]) << " rad RMS (" << context.noise_runs
      << " simulations); windows of " << g(context.window_length) << " s are flagged above "
      << g(context.threshold) << "x that\n\n";

  out << "nominal fit (two-link arm, 7 parameters; std from the HAC covariance):\n";
  for (Eigen::Index p = 0; p < r.nominal.theta.size(); ++p) {
    const std::string name = p < static_cast<Eigen::Index>(r.nominal.parameter_names.size())
                                 ? r.nominal.parameter_names[static_cast<std::size_t>(p)]
                                 : "p" + std::to_string(p + 1);
    out << "  " << pad(name, 28) << pad_left(format("%.6g", r.nominal.theta[p]), 14) << " +- "
        << (p < r.nominal.std.size() ? g(r.nominal.std[p]) : "n/a") << "\n";
  }
  out << "\nwhere the nominal model and the data disagree:\n";
  disagreement(out, r.nominal, r);
  if (!sim.nominal.ok())
    out << "  note: the free simulation of the nominal model: " << simulation_summary(sim.nominal)
        << "\n";

  out << "\nnamed effects (forward selection; each passed the HAC Wald test, BIC and blocked "
         "CV):\n";
  if (r.effects.empty()) out << "  none: no candidate explains the residual beyond the noise\n";
  for (const auto& e : r.effects) {
    out << "  " << e.effect << ": " << e.name << "\n   ";
    for (Eigen::Index v = 0; v < e.estimate.size(); ++v) {
      const auto vk = static_cast<std::size_t>(v);
      const std::string vname = vk < e.value_names.size() ? e.value_names[vk] : "value";
      out << " " << vname << " = " << format("%.5g", e.estimate[v]) << " +- "
          << (v < e.std.size() && std::isfinite(e.std[v]) ? g(e.std[v]) : "n/a");
      const std::string unit = unit_of(e.effect, vk);
      if (!unit.empty()) out << " " << unit;
      out << (v + 1 < e.estimate.size() ? ";" : "");
    }
    out << "\n    Wald " << g(e.wald) << ", p (Holm) " << g(e.p_value) << ", BIC drop "
        << g(e.information_drop) << ", CV drop " << format("%.1f", 100.0 * e.cv_drop) << " %, size "
        << format("%.0f", 100.0 * e.practical_size.maxCoeff()) << " % of the residual\n";
    if (!e.note.empty()) out << "    note: " << e.note << "\n";
  }
  if (!r.friction_checks.empty()) {
    out << "\nfriction curves tested by output error (angles simulated around each reversal):\n";
    for (const auto& c : r.friction_checks) {
      out << "  joint " << c.joint << ": named " << c.named << " -> " << c.chosen << " ("
          << c.windows << " windows; ";
      if (std::isfinite(c.score))
        out << "score of a Stribeck bump at the Coulomb fit " << g(c.score);
      else
        out << "Stribeck fitted first, as named";
      if (c.stribeck_fitted)
        out << "; Stribeck vs Coulomb likelihood ratio " << g(c.statistic) << ", p "
            << g(c.p_value);
      else
        out << ", too low to fit the Stribeck curve";
      out << "; angle error / noise " << format("%.3f", c.normalized_rms_coulomb) << " Coulomb";
      if (c.stribeck_fitted)
        out << ", " << format("%.3f", c.normalized_rms_stribeck) << " Stribeck";
      out << ")\n";
      if (!c.message.empty()) out << "    note: " << c.message << "\n";
    }
  }
  if (!r.not_separable.empty()) {
    out << "\nnot separable (the data cannot tell these from the nominal model):\n";
    for (const auto& s : r.not_separable)
      out << "  " << s.effect << ": " << s.name << ": " << s.explanation << "\n";
  }
  if (!r.not_named.empty()) {
    out << "\ncandidates not named (detection limit: the smallest value the test would have "
           "found):\n";
    for (const auto& u : r.not_named) {
      out << "  " << pad(u.effect.id(), 18) << pad(u.reason, 28);
      if (std::isfinite(u.detection_limit))
        out << " limit " << g(u.detection_limit) << " " << main_unit(u.effect);
      out << "\n";
    }
  }

  out << "\nbefore / after (nominal -> final model):\n";
  char line[256];
  std::snprintf(line, sizeof line, "  %-6s %-22s %-22s %-22s %-10s %-10s\n", "joint",
                "residual RMS [N m]", "excess [N m]", "sim error RMS [rad]", "torque win",
                "sim win");
  out << line;
  for (int j = 0; j < 2; ++j) {
    const auto arrow = [](double a, double b) { return g(a) + " -> " + g(b); };
    std::snprintf(line, sizeof line, "  %-6d %-22s %-22s %-22s %-10s %-10s\n", j + 1,
                  arrow(r.nominal.residual_rms[j], r.final.residual_rms[j]).c_str(),
                  arrow(r.nominal.excess_rms[j], r.final.excess_rms[j]).c_str(),
                  arrow(r.nominal.sim_error_rms[j], r.final.sim_error_rms[j]).c_str(),
                  (std::to_string(count_joint(r.nominal.windows, j + 1)) + " -> " +
                   std::to_string(count_joint(r.final.windows, j + 1)))
                      .c_str(),
                  (std::to_string(count_joint(r.nominal.sim_windows, j + 1)) + " -> " +
                   std::to_string(count_joint(r.final.sim_windows, j + 1)))
                      .c_str());
    out << line;
  }
  if (!r.effects.empty() && !sim.final.ok())
    out << "  note: the free simulation of the final model: " << simulation_summary(sim.final)
        << "\n";

  if (context.has_reference) {
    out << "\ndrift against the reference theta (final model; significant when |z| > 3):\n";
    std::snprintf(line, sizeof line, "  %-8s %14s %14s %12s %9s\n", "name", "reference", "estimate",
                  "std", "z");
    out << line;
    for (const auto& d : r.drift) {
      std::snprintf(line, sizeof line, "  %-8s %14s %14s %12s %9s%s\n", d.name.c_str(),
                    format("%.6g", d.reference).c_str(), format("%.6g", d.estimate).c_str(),
                    g(d.std).c_str(), format("%+.2f", d.z).c_str(),
                    d.significant ? "  drifted" : "");
      out << line;
    }
  }
  out << "\nwall time " << format("%.3f", r.seconds) << " s\n";
  return out.str();
}

nlohmann::json diagnose_json(const sid::DiagnosisResult& r, const sid::SimulationCheck& sim,
                             const DiagnoseReportContext& context) {
  nlohmann::json j;
  j["input"] = context.input;
  j["samples_total"] = context.samples_total;
  j["samples_used"] = r.kinematics.size();
  j["noise_floor"] = pair_json(r.noise_floor);
  j["kinematic_floor"] = pair_json(r.kinematic_floor);
  const Eigen::Vector2i rest = left_out(r);
  j["rest"] = {{"velocity", context.rest_velocity},
               {"margin", context.rest_margin},
               {"left_out", {rest[0], rest[1]}}};
  nlohmann::json effects = nlohmann::json::array();
  for (const auto& e : r.effects) {
    nlohmann::json units = nlohmann::json::array();
    for (std::size_t v = 0; v < e.value_names.size(); ++v) units.push_back(unit_of(e.effect, v));
    effects.push_back({{"id", e.effect.id()},
                       {"name", e.name},
                       {"value_names", e.value_names},
                       {"units", units},
                       {"estimate", to_json_array(e.estimate)},
                       {"std", to_json_array(e.std)},
                       {"wald", number(e.wald)},
                       {"p_value", number(e.p_value)},
                       {"information_drop", number(e.information_drop)},
                       {"cv_drop", number(e.cv_drop)},
                       {"practical_size", to_json_array(e.practical_size)},
                       {"note", e.note}});
  }
  j["effects"] = effects;
  nlohmann::json friction = nlohmann::json::array();
  for (const auto& c : r.friction_checks)
    friction.push_back({{"joint", c.joint},
                        {"named", c.named.id()},
                        {"chosen", c.chosen.id()},
                        {"score", number(c.score)},
                        {"score_velocity", number(c.score_velocity)},
                        {"stribeck_fitted", c.stribeck_fitted},
                        {"likelihood_ratio", number(c.statistic)},
                        {"p_value", number(c.p_value)},
                        {"windows", c.windows},
                        {"normalized_rms_coulomb", number(c.normalized_rms_coulomb)},
                        {"normalized_rms_stribeck", number(c.normalized_rms_stribeck)},
                        {"message", c.message}});
  j["friction_checks"] = friction;
  nlohmann::json not_separable = nlohmann::json::array();
  for (const auto& s : r.not_separable)
    not_separable.push_back(
        {{"id", s.effect.id()}, {"name", s.name}, {"explanation", s.explanation}});
  j["not_separable"] = not_separable;
  nlohmann::json not_named = nlohmann::json::array();
  for (const auto& u : r.not_named)
    not_named.push_back({{"id", u.effect.id()},
                         {"name", u.name},
                         {"reason", u.reason},
                         {"detection_limit", number(u.detection_limit)},
                         {"unit", main_unit(u.effect)}});
  j["not_named"] = not_named;
  j["nominal"] = model_json(r.nominal);
  j["final"] = model_json(r.final);
  if (context.has_reference) {
    nlohmann::json drift = nlohmann::json::array();
    for (const auto& d : r.drift)
      drift.push_back({{"name", d.name},
                       {"reference", number(d.reference)},
                       {"estimate", number(d.estimate)},
                       {"std", number(d.std)},
                       {"z", number(d.z)},
                       {"significant", d.significant}});
    j["drift"] = drift;
  } else {
    j["drift"] = nullptr;
  }
  j["simulation"] = {
      {"segment", number(context.segment)},
      {"window_length", context.window_length},
      {"noise_runs", context.noise_runs},
      {"threshold", context.threshold},
      {"noise_error_rms", pair_json(sim.noise_error_rms)},
      {"nominal_ok", sim.nominal.ok()},
      {"final_ok", sim.final.ok()},
      {"message", sim.nominal.message +
                      (sim.final.message.empty() || sim.final.message == sim.nominal.message
                           ? ""
                           : (sim.nominal.message.empty() ? "" : "; ") + sim.final.message)}};
  j["seconds"] = r.seconds;
  return j;
}

std::vector<std::string> diagnose_plot_files() {
  std::vector<std::string> files;
  for (const char* name : {"residual_j1", "residual_j2", "friction_j1", "friction_j2", "sim_q1",
                           "sim_q2", "sim_error_q1", "sim_error_q2"})
    for (const auto& f : plot_files(name)) files.push_back(f);
  return files;
}

std::pair<Eigen::VectorXd, Eigen::VectorXd> binned_mean(const Eigen::Ref<const Eigen::VectorXd>& x,
                                                        const Eigen::Ref<const Eigen::VectorXd>& y,
                                                        int bins, int min_count) {
  if (x.size() != y.size()) throw std::invalid_argument("binned_mean: x and y differ in length");
  if (bins < 1) throw std::invalid_argument("binned_mean: bins must be >= 1");
  std::vector<double> sorted;
  for (Eigen::Index i = 0; i < x.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) sorted.push_back(x[i]);
  Eigen::VectorXd centres = Eigen::VectorXd::Constant(bins, std::nan(""));
  Eigen::VectorXd means = Eigen::VectorXd::Constant(bins, std::nan(""));
  if (sorted.empty()) return {centres, means};
  std::sort(sorted.begin(), sorted.end());
  const auto at = [&sorted](double q) {
    return sorted[static_cast<std::size_t>(q * static_cast<double>(sorted.size() - 1))];
  };
  const double lo = at(0.01), hi = at(0.99);
  const double width = hi > lo ? (hi - lo) / bins : 1.0;
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(bins), count = Eigen::VectorXd::Zero(bins);
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i]) || x[i] < lo || x[i] > hi) continue;
    const int b = std::min(bins - 1, static_cast<int>((x[i] - lo) / width));
    sum[b] += y[i];
    count[b] += 1.0;
  }
  for (int b = 0; b < bins; ++b) {
    centres[b] = lo + (b + 0.5) * width;
    if (count[b] >= min_count) means[b] = sum[b] / count[b];
  }
  return {centres, means};
}

std::vector<PlotResult> write_diagnose_plots(const std::string& dir, const sid::DiagnosisResult& r,
                                             const sid::SimulationCheck& sim) {
  std::vector<PlotResult> plots;
  const sid::Kinematics<double>& k = r.kinematics;
  const Eigen::Index n = k.size();
  const std::string after =
      r.effects.empty() ? "final (= nominal: nothing named)" : "final (with the named effects)";
  for (int j = 0; j < 2; ++j) {
    const std::string joint = std::to_string(j + 1);
    LinePlot residual;
    residual.title = "torque residual of joint " + joint + " before and after the diagnosis";
    residual.x_label = "t [s]";
    residual.y_label = "tau" + joint + " - model [N m]";
    residual.x = k.t;
    // The noise hides the pattern; a 0.1 s mean over the raw residual shows it.
    const Eigen::Index half =
        n > 1 ? std::max<Eigen::Index>(1,
                                       static_cast<Eigen::Index>(0.05 * static_cast<double>(n - 1) /
                                                                 (k.t[n - 1] - k.t[0])))
              : 1;
    const Eigen::VectorXd nominal_residual = joint_residual(r.nominal, n, j);
    const Eigen::VectorXd final_residual = joint_residual(r.final, n, j);
    residual.series.push_back({"nominal", nominal_residual, "lines linecolor rgb '#f0a0a0'"});
    residual.series.push_back({after, final_residual, "lines linecolor rgb '#a0b8f0'"});
    residual.series.push_back({"nominal, 0.1 s mean", moving_average(nominal_residual, half),
                               "lines linewidth 2 linecolor rgb '#c00000'"});
    residual.series.push_back({"final, 0.1 s mean", moving_average(final_residual, half),
                               "lines linewidth 2 linecolor rgb '#0050c0'"});
    for (const auto& w : r.nominal.windows)
      if (w.joint == j + 1) residual.marked.push_back({w.t_begin, w.t_end, ""});
    plots.push_back(plot_lines(residual, path_in(dir, "residual_j" + joint + ".png")));

    LinePlot friction;
    friction.title = "mean torque residual of joint " + joint +
                     " against its velocity (the missing friction curve)";
    friction.x_label = "qd" + joint + " [rad/s]";
    friction.y_label = "mean residual [N m]";
    constexpr int kBins = 41;
    const auto before = binned_mean(k.qd.col(j), joint_residual(r.nominal, n, j), kBins);
    const auto final_bins = binned_mean(k.qd.col(j), joint_residual(r.final, n, j), kBins);
    friction.x = before.first;
    friction.series.push_back({"nominal", before.second, "linespoints linecolor rgb '#c00000'"});
    friction.series.push_back({after, final_bins.second, "linespoints linecolor rgb '#0050c0'"});
    plots.push_back(plot_lines(friction, path_in(dir, "friction_j" + joint + ".png")));

    const auto simulated = [n, j](const sid::FreeSimulation& s, bool error) {
      const auto& m = error ? s.error : s.q;
      return m.rows() == n ? Eigen::VectorXd(m.col(j)) : Eigen::VectorXd::Constant(n, std::nan(""));
    };
    LinePlot angles;
    angles.title = "joint " + joint +
                   ": measured (smoothed) angle and the free simulations (restarted every segment)";
    angles.x_label = "t [s]";
    angles.y_label = "q" + joint + " [rad]";
    angles.x = k.t;
    angles.series.push_back({"measured", k.q.col(j), "lines linewidth 2 linecolor rgb 'black'"});
    angles.series.push_back(
        {"nominal model", simulated(sim.nominal, false), "lines linecolor rgb '#c00000'"});
    angles.series.push_back(
        {after, simulated(sim.final, false), "lines dashtype 2 linecolor rgb '#0050c0'"});
    for (const auto& w : r.nominal.sim_windows)
      if (w.joint == j + 1) angles.marked.push_back({w.t_begin, w.t_end, ""});
    plots.push_back(plot_lines(angles, path_in(dir, "sim_q" + joint + ".png")));

    // The angles differ by far less than they move, so the error gets its own figure, with the
    // band the torque noise alone explains.
    LinePlot error;
    error.title = "joint " + joint +
                  ": measured - simulated angle (free simulation, restarted every segment)";
    error.x_label = "t [s]";
    error.y_label = "q" + joint + " error [rad]";
    error.x = k.t;
    error.series.push_back(
        {"nominal model", simulated(sim.nominal, true), "lines linecolor rgb '#c00000'"});
    error.series.push_back({after, simulated(sim.final, true), "lines linecolor rgb '#0050c0'"});
    if (sim.noise_rms.rows() == n) {
      error.series.push_back({"torque noise alone (+RMS)", sim.noise_rms.col(j),
                              "lines dashtype 2 linecolor rgb 'gray'"});
      error.series.push_back({"torque noise alone (-RMS)", -sim.noise_rms.col(j),
                              "lines dashtype 2 linecolor rgb 'gray'"});
    }
    for (const auto& w : r.nominal.sim_windows)
      if (w.joint == j + 1) error.marked.push_back({w.t_begin, w.t_end, ""});
    plots.push_back(plot_lines(error, path_in(dir, "sim_error_q" + joint + ".png")));
  }
  return plots;
}

std::string simulation_summary(const sid::FreeSimulation& s) {
  const std::size_t segments = s.segment_starts.size();
  std::string text = format("%.4g", s.error_rms[0]) + " / " + format("%.4g", s.error_rms[1]);
  if (s.ok()) return text + " (" + std::to_string(segments) + " segments)";
  // The first failure says where and why; the others repeat it at later segments.
  return "UNSTABLE: " + std::to_string(s.failed_segments) + " of " + std::to_string(segments) +
         " segments failed; first: " + s.message.substr(0, s.message.find("; ")) +
         "; error over the samples simulated " + text;
}

}  // namespace sid::app
