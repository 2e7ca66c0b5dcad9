#include "identify_report_html.hpp"

#include <sid/identify_chain.hpp>
#include <sid/model/link_inertia.hpp>

#include "html_page.hpp"
#include "svg_plot.hpp"

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace sid::app {
namespace {

/// Per joint, the measured and the model's torque, then their difference, over one run.
std::string run_plots(const ChainIdentifyResult& r, const sid::NamedChainRun& run,
                      const std::string& role) {
  const sid::ChainIdentification& id = r.result.identification;
  Eigen::MatrixXd model;
  try {
    model = sid::chain_torque(r.loaded.model, id, run.data, r.loaded.options);
  } catch (const std::invalid_argument& e) {
    return "<p class=\"warning\">" + xml_escaped(run.name + ": no plot (" + e.what() + ")") +
           "</p>\n";
  }
  std::string html = "<h3>" + xml_escaped(role + ": " + run.name) + "</h3>\n";
  const std::vector<std::string>& names = r.loaded.robot.joint_names;
  for (int j = 0; j < run.data.joints(); ++j) {
    const std::string joint = static_cast<std::size_t>(j) < names.size()
                                  ? names[static_cast<std::size_t>(j)]
                                  : "joint " + std::to_string(j + 1);
    const Eigen::VectorXd measured = run.data.tau.col(j), predicted = model.col(j);
    html += "<p>" + xml_escaped(joint) + "</p>\n";
    html += svg_line_plot(run.data.t,
                          {{"measured", "#7a7a7a", measured},
                           {"model", "#1f5fbf", predicted},
                           {"measured - model", "#c0392b", measured - predicted}},
                          "t [s]", "torque [N m]") +
            "\n";
  }
  return html;
}

std::string summary(const ChainIdentifyResult& r) {
  const nlohmann::json& j = r.json;
  std::string runs;
  for (const auto& run : r.result.fitted_runs)
    runs += (runs.empty() ? "" : ", ") + run.name + " (" + std::to_string(run.data.size()) +
            " samples, " + html_number(run.data.t[run.data.size() - 1] - run.data.t[0], "%.3g") +
            " s)";
  std::string cutoffs;
  for (const auto& c : j["cutoff_hz"])
    cutoffs += (cutoffs.empty() ? "" : ", ") + html_number(c.get<double>(), "%.3g");
  std::string html = "<table>\n" + html_row("robot", j.value("robot", std::string())) +
                     html_row("joints", std::to_string(r.loaded.model.joints())) +
                     html_row("fitted runs", runs) +
                     html_row("estimator", j.value("estimator", "ls")) +
                     html_row("angle smoothing cutoffs [Hz]", cutoffs) +
                     html_row("base parameters", std::to_string(j["theta"].size())) +
                     html_row("torque error, fitted equations",
                              html_percent(j["relative_residual"].get<double>())) +
                     html_row("torque error, fitted runs as recorded",
                              html_percent(j["relative_residual_measured"].get<double>()));
  for (const auto& v : j["validation"])
    html += html_row("held-out torque error: " + v["file"].get<std::string>(),
                     html_percent(v["relative_residual"].get<double>()) + " (as recorded " +
                         html_percent(v["relative_residual_measured"].get<double>()) + ")");
  return html + "</table>\n";
}

std::string verdicts(const ChainIdentifyResult& r) {
  const nlohmann::json& p = r.json["physically_consistent"];
  const bool written = p.value("written", false);
  std::string html =
      std::string("<p class=\"verdict") + (written ? "" : " bad") + "\">" +
      "Physically consistent model (each link a real body): " +
      html_percent(p["torque_error"].get<double>()) + " torque error on the " +
      xml_escaped(p["torque_error_on"].get<std::string>()) + ", against " +
      html_percent(p["estimate_torque_error"].get<double>()) + " for the estimate; " +
      (p.value("converged", false) ? "converged" : "did not converge") + "; " +
      (r.loaded.robot.urdf.empty() ? "--write-urdf and --write-mjcf need a URDF as the robot."
       : written                   ? "written by --write-urdf and --write-mjcf."
                                   : "refused by --write-urdf and --write-mjcf.") +
      "</p>\n";
  if (r.result.warnings.empty()) return html + "<p>No warnings.</p>\n";
  html += "<ul>\n";
  for (const std::string& w : r.result.warnings)
    html += "<li class=\"warning\">" + xml_escaped(w) + "</li>\n";
  return html + "</ul>\n";
}

std::string parameters(const nlohmann::json& j) {
  std::string html =
      "<table>\n<tr><th>base parameter</th><th>value</th><th>std (HAC)</th><th>std / "
      "|value|</th></tr>\n";
  for (std::size_t i = 0; i < j["theta"].size(); ++i) {
    const double value = j["theta"][i].get<double>(), std_dev = j["std_dev"][i].get<double>();
    html += "<tr><td title=\"" + xml_escaped(j["parameter_combinations"][i].get<std::string>()) +
            "\">" + xml_escaped(j["parameter_names"][i].get<std::string>()) +
            "</td><td class=\"number\">" + html_number(value) + "</td><td class=\"number\">" +
            html_number(std_dev) + "</td><td class=\"number\">" +
            (value != 0.0 ? html_percent(std_dev / std::abs(value)) : std::string("-")) +
            "</td></tr>\n";
  }
  return html + "</table>\n";
}

std::string consistent_model(const ChainIdentifyResult& r) {
  const Eigen::VectorXd& theta = r.result.consistent.theta;
  const std::vector<std::string>& links = r.loaded.robot.link_names;
  const int n = r.loaded.model.joints();
  if (theta.size() < 10 * n) return "";
  std::string html =
      "<table>\n<tr><th>link</th><th>mass [kg]</th><th>centre of mass [m]</th></tr>\n";
  for (int k = 0; k < n; ++k) {
    const sid::LinkParameters<double> phi = theta.segment<10>(10 * k);
    const std::string name = static_cast<std::size_t>(k) < links.size()
                                 ? links[static_cast<std::size_t>(k)]
                                 : "link " + std::to_string(k + 1);
    std::string com = "-";
    if (phi[0] > 0.0) {
      const Eigen::Vector3d c = phi.segment<3>(1) / phi[0];
      com = html_number(c[0]) + ", " + html_number(c[1]) + ", " + html_number(c[2]);
    }
    html += "<tr>" + html_cell(name) + "<td class=\"number\">" + html_number(phi[0]) + "</td>" +
            html_cell(com) + "</tr>\n";
  }
  html += "</table>\n<table>\n<tr><th>drive term</th><th>value</th></tr>\n";
  const std::vector<std::string>& names = r.loaded.model.parameter_names();
  for (Eigen::Index i = 10 * n; i < theta.size(); ++i)
    html += "<tr>" + html_cell(names[static_cast<std::size_t>(i)]) + "<td class=\"number\">" +
            html_number(theta[i]) + "</td></tr>\n";
  return html + "</table>\n";
}

}  // namespace

std::string identify_report_html(const ChainIdentifyResult& r) {
  const std::string robot =
      std::filesystem::path(r.json.value("robot", std::string("the robot"))).filename().string();
  std::string html = "<h1>" + xml_escaped("Identification of " + robot) + "</h1>\n";
  html += "<h2>Summary</h2>\n" + summary(r) + verdicts(r);
  html += "<h2>Torque, measured and predicted</h2>\n";
  for (const auto& run : r.result.fitted_runs) html += run_plots(r, run, "fitted");
  for (const auto& run : r.result.held_out_runs) html += run_plots(r, run, "held out");
  html += "<h2>Base parameters</h2>\n" + parameters(r.json);
  html += "<h2>Physically consistent model</h2>\n" + consistent_model(r);
  html += "<h2>The report</h2>\n<pre>" + xml_escaped(r.text) + "</pre>\n";
  return html_document("sid identification: " + robot, html);
}

}  // namespace sid::app
