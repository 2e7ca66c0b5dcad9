#include "windows_report_html.hpp"

#include "html_page.hpp"
#include "svg_plot.hpp"

#include <algorithm>
#include <cmath>

namespace sid::app {

namespace {

/// The model's drive-term parameter names (they follow the links' parameters).
std::vector<std::string> drive_term_names(const sid::ChainModel& model) {
  const std::vector<std::string>& names = model.parameter_names();
  return {names.end() - static_cast<std::ptrdiff_t>(model.terms().size()), names.end()};
}

std::string drift_plot(const sid::ChainWindows& w, std::size_t column, const Eigen::VectorXd& x) {
  const sid::ParameterTrend& p = w.parameters[column];
  const auto c = static_cast<Eigen::Index>(column);
  const Eigen::VectorXd value = w.value.col(c), two_std = 2.0 * w.std_dev.col(c);
  std::string verdict = std::isnan(p.slope) ? ""
                                            : ": slope " + html_number(p.slope) + " ± " +
                                                  html_number(p.slope_std_dev) + " /h" +
                                                  (p.drifts ? " — drifts" : "");
  return "<h3>" + xml_escaped(p.name + verdict) + "</h3>\n" +
         svg_line_plot(x,
                       {{"estimate", "#1f4e9a", value},
                        {"+2 std", "#9bb3dd", value + two_std},
                        {"-2 std", "#9bb3dd", value - two_std}},
                       "operating time [h]", p.name, 760, 180) +
         "\n";
}

}  // namespace

std::string windows_report_html(const WindowsResult& r, const sid::ChainModel& model) {
  const sid::ChainWindows& w = r.windows;
  std::string body = "<h1>Parameters window by window</h1>\n";
  for (const auto& warning : w.warnings)
    body += "<p class=\"warning\">" + xml_escaped(warning) + "</p>\n";
  body += "<pre>" + xml_escaped(r.text) + "</pre>\n<h2>Drive terms over the operating time</h2>\n";
  if (w.windows.size() < 2) {
    body += "<p>One window: nothing to plot over time.</p>\n";
    return html_document("sid_identify: drift", body);
  }
  Eigen::VectorXd hours(static_cast<Eigen::Index>(w.windows.size()));
  for (std::size_t k = 0; k < w.windows.size(); ++k)
    hours[static_cast<Eigen::Index>(k)] = w.windows[k].operating_time / 3600.0;
  const std::vector<std::string> drives = drive_term_names(model);
  for (std::size_t i = 0; i < w.parameters.size(); ++i)
    if (std::find(drives.begin(), drives.end(), w.parameters[i].combination) != drives.end())
      body += drift_plot(w, i, hours);
  return html_document("sid_identify: drift", body);
}

}  // namespace sid::app
