#include "diagnose_report_html.hpp"

#include <sid/diagnose_chain.hpp>

#include "html_page.hpp"
#include "svg_plot.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace sid::app {
namespace {

std::string joint_name(const sid::ChainModel& model, Eigen::Index j) {
  return model.joint_names()[static_cast<std::size_t>(j)];
}

std::string summary(const ChainDiagnoseAppOptions& o, const LoadedChain& loaded,
                    const sid::RobotDiagnosis& whole) {
  const sid::ChainDiagnosis& r = whole.diagnosis;
  std::string runs, nominal = "rigid bodies", cutoffs;
  for (const ChainRunFile& run : loaded.runs)
    runs += (runs.empty() ? "" : ", ") + run.file + " (" + std::to_string(run.data.size()) +
            " samples, " + html_number(run.data.t[run.data.size() - 1] - run.data.t[0], "%.3g") +
            " s)";
  for (const sid::DriveTerm& t : loaded.model.terms())
    if (!t.on_motor && t.index == 0) nominal += std::string(", ") + sid::drive_term_keyword(t.kind);
  for (Eigen::Index j = 0; j < r.cutoff_hz.size(); ++j)
    cutoffs += (j ? ", " : "") + html_number(r.cutoff_hz[j], "%.3g");
  return "<table>\n" + html_row("robot", o.chain.robot) +
         html_row("joints", std::to_string(loaded.model.joints())) + html_row("runs", runs) +
         html_row("nominal model", nominal) + html_row("equations", std::to_string(r.equations)) +
         html_row("angle smoothing cutoffs [Hz]", cutoffs + " (" + r.smoothing + ")") +
         html_row("time", html_number(r.seconds, "%.2f") + " s (the free simulations " +
                              html_number(whole.motion_seconds, "%.2f") + " s)") +
         "</table>\n";
}

/// The verdict the text report ends with: whether what remains is at the noise.
std::string verdict(const sid::ChainDiagnosis& r) {
  std::string named;
  for (const auto& e : r.named) named += (named.empty() ? "" : ", ") + e.id;
  const bool at_noise = remains_at_noise(r);
  return std::string("<p class=\"verdict") + (at_noise ? "" : " bad") + "\">" +
         xml_escaped((named.empty() ? "No tried effect named. " : "Named: " + named + ". ") +
                     (at_noise ? "What remains is at the noise."
                               : "What remains above the noise is not a tried drive term: look at "
                                 "the rigid-body model, the kinematics or effects not in the "
                                 "library.")) +
         "</p>\n";
}

std::string residuals(const sid::ChainModel& model, const sid::ChainDiagnosis& r) {
  std::vector<std::string> joints;
  for (int j = 0; j < model.joints(); ++j) joints.push_back(joint_name(model, j));
  std::string html = svg_bar_chart(joints,
                                   {{"torque noise", "#9a9a9a", r.noise_floor},
                                    {"residual, nominal model", "#c0392b", r.nominal_residual_rms},
                                    {"residual, final model", "#1f5fbf", r.final_residual_rms}},
                                   "RMS [N m]") +
                     "\n";
  html +=
      "<table>\n<tr><th>joint</th><th>torque noise</th><th>residual, nominal</th><th>residual, "
      "final</th><th>unexplained</th></tr>\n";
  for (int j = 0; j < model.joints(); ++j)
    html += "<tr>" + html_cell(joints[std::size_t(j)]) + html_number_cell(r.noise_floor[j]) +
            html_number_cell(r.nominal_residual_rms[j]) +
            html_number_cell(r.final_residual_rms[j]) + html_number_cell(r.unexplained_rms[j]) +
            "</tr>\n";
  return html + "</table>\n<p>[N m] RMS over the fitted equations at the measured torque; " +
         "unexplained: what the final model leaves above the noise.</p>\n";
}

std::string named_effects(const sid::ChainDiagnosis& r) {
  if (r.named.empty())
    return "<p>Nothing: no tried term passes the tests and is of practical size.</p>\n";
  std::string html =
      "<table>\n<tr><th>effect</th><th>value</th><th>std (HAC)</th><th>unit</th><th>Wald</th>"
      "<th>p (Holm)</th><th>BIC drop</th><th>CV drop</th><th>size / "
      "noise</th><th>caveat</th></tr>\n";
  for (const auto& e : r.named)
    html += "<tr>" + html_cell(e.id + stribeck_width(e.term)) + html_number_cell(e.value, "%.5g") +
            html_number_cell(e.std, "%.2g") + html_cell(e.unit) + html_number_cell(e.wald, "%.3g") +
            html_number_cell(e.p_value, "%.2g") + html_number_cell(e.bic_drop, "%.3g") +
            "<td class=\"number\">" + html_percent(e.cv_drop) + "</td><td class=\"number\">" +
            html_percent(e.practical_size.maxCoeff()) + "</td>" + html_cell(e.caveat) + "</tr>\n";
  return html + "</table>\n";
}

std::string not_named(const sid::ChainDiagnosis& r) {
  if (r.not_named.empty()) return "<p>Every tried term was named.</p>\n";
  std::string html =
      "<table>\n<tr><th>effect</th><th>why not</th><th>this log shows it from</th></tr>\n";
  for (const auto& t : r.not_named)
    html += "<tr>" + html_cell(t.id + stribeck_width(t.term)) + html_cell(t.reason) +
            html_cell(std::isfinite(t.detection_limit)
                          ? html_number(t.detection_limit, "%.2g") + " " + t.unit
                          : "-") +
            "</tr>\n";
  return html + "</table>\n";
}

std::string free_simulation(const sid::ChainModel& model, const sid::RobotDiagnosis& whole) {
  const sid::ChainMotionCheck& m = whole.motion;
  if (m.final_error.size() == 0)
    return "<p>" +
           xml_escaped(whole.motion_note.empty() ? "No free simulation." : whole.motion_note) +
           "</p>\n";
  const double margin = sid::ChainMotionCheckOptions().margin;
  std::vector<std::string> joints;
  Eigen::VectorXd replicates(model.joints());
  for (int j = 0; j < model.joints(); ++j) {
    joints.push_back(joint_name(model, j));
    replicates[j] = m.threshold[j] / margin;
  }
  std::string html =
      "<p>" + std::to_string(m.segments) +
      " segments of 1 s from the smoothed state, driven by the smoothed torque; each model at "
      "its physically consistent fit. Against the largest angle error of " +
      std::to_string(m.replicate_error.rows()) +
      " exact-model replicates of this log (its noise, fitted and simulated alike).</p>\n";
  html += svg_bar_chart(joints,
                        {{"exact-model replicates (largest)", "#9a9a9a", replicates},
                         {"nominal model", "#c0392b", m.nominal_error},
                         {"final model", "#1f5fbf", m.final_error}},
                        "angle error RMS [rad]") +
          "\n";
  std::string beyond;
  for (const int j : m.beyond) beyond += (beyond.empty() ? "" : ", ") + joint_name(model, j);
  html += std::string("<p class=\"verdict") + (beyond.empty() ? "" : " bad") + "\">" +
          xml_escaped(beyond.empty()
                          ? "The final model follows the motion as an exact model does (within " +
                                html_number(margin, "%.0f") + "x the replicates)."
                          : "Beyond " + html_number(margin, "%.0f") +
                                "x what an exact model gives: " + beyond +
                                ": motion the final model does not explain.") +
          "</p>\n";
  if (m.failed_nominal + m.failed_final > 0)
    html +=
        "<p class=\"warning\">" +
        xml_escaped("Segments that blew up or failed: nominal " + std::to_string(m.failed_nominal) +
                    ", final " + std::to_string(m.failed_final) + " (first: " + m.failure + ")") +
        "</p>\n";
  return html;
}

}  // namespace

std::string diagnose_report_html(const ChainDiagnoseAppOptions& o, const LoadedChain& loaded,
                                 const ChainDiagnoseResult& r) {
  const std::string robot = std::filesystem::path(o.chain.robot).filename().string();
  const sid::ChainDiagnosis& d = r.result.diagnosis;
  std::string html = "<h1>" + xml_escaped("Diagnosis of " + robot) + "</h1>\n";
  html += "<h2>Summary</h2>\n" + summary(o, loaded, r.result) + verdict(d);
  html += "<h2>Torque residual against the noise</h2>\n" + residuals(loaded.model, d);
  html += "<h2>Named effects</h2>\n" + named_effects(d);
  html += "<h2>Not named</h2>\n" + not_named(d);
  html += "<h2>Free simulation</h2>\n" + free_simulation(loaded.model, r.result);
  html += "<h2>The report</h2>\n<pre>" + xml_escaped(r.text) + "</pre>\n";
  return html_document("sid diagnosis: " + robot, html);
}

}  // namespace sid::app
