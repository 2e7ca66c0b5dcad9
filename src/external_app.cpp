#include "external_app.hpp"

#include <sid/external_torque.hpp>

#include "app.hpp"
#include "csv.hpp"
#include "plot.hpp"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>

namespace sid::app {

namespace {

std::string number(const char* format, double v) { return format_number(format, v); }

/// The library's options from the tool's.
/// @throws InputError naming the option at fault.
sid::ExternalTorqueOptions external_options(const ExternalOptions& o, int joints,
                                            const ChainRunFile& run) {
  require(o.method == "observer" || o.method == "residual",
          "--method: observer or residual, not '" + o.method + "'");
  require(o.threshold_factor > 0.0 && std::isfinite(o.threshold_factor), "--threshold must be > 0");
  require(o.min_duration >= 0.0 && o.merge_gap >= 0.0 && o.skip >= 0.0,
          "--min-duration, --merge-gap and --skip must be >= 0 s");
  const sid::ChainTrajectory<double>& log = run.data;
  require(2.0 * o.skip < log.t[log.size() - 1] - log.t[0],
          "--skip " + number("%.3g", o.skip) + " s at each end leaves nothing of " + run.file);
  sid::ExternalTorqueOptions options;
  options.method = o.method == "observer" ? sid::ExternalTorqueMethod::MomentumObserver
                                          : sid::ExternalTorqueMethod::InverseDynamicsResidual;
  if (o.gain) {
    require(*o.gain > 0.0 && std::isfinite(*o.gain), "--gain must be > 0 [1/s]");
    options.gain = *o.gain;
  }
  if (o.cutoff == "fit") {
    options.fit_cutoffs = true;
  } else if (!o.cutoff.empty()) {
    options.cutoff_hz = parse_doubles(o.cutoff, "--cutoff");
    require(options.cutoff_hz.size() == 1 || options.cutoff_hz.size() == std::size_t(joints),
            "--cutoff takes one value or one per joint (" + std::to_string(joints) + ")");
    for (const double c : options.cutoff_hz)
      require(c > 0.0 && std::isfinite(c), "--cutoff values must be > 0 Hz");
  }
  options.threshold_factor = o.threshold_factor;
  options.min_duration = o.min_duration;
  options.merge_gap = o.merge_gap;
  options.skip = o.skip;
  return options;
}

}  // namespace

ExternalResult external_torque(const IdentifiedArm& arm, const ChainRunFile& run,
                               const ExternalOptions& o) {
  const sid::ChainModel& model = arm.model;
  const int n = model.joints();
  const sid::ChainTrajectory<double>& log = run.data;
  const Eigen::Index samples = log.size();
  sid::ExternalTorqueOptions options = external_options(o, n, run);
  options.effort_limit = arm.effort_limit;
  require(std::abs(arm.torque_delay) <= options.skip,
          "--skip " + number("%.3g", options.skip) + " s is shorter than the torque delay of " +
              arm.source + " (" + number("%.3g", 1e3 * arm.torque_delay) +
              " ms): the rates would be taken before the log starts");
  options.torque_delay = arm.torque_delay;
  ExternalResult result;
  result.method = o.method;
  try {
    result.torque = sid::estimate_external_torque(model, arm.theta, arm.cutoff_hz,
                                                  arm.residual_rms_measured, log, options);
  } catch (const std::invalid_argument& e) {
    throw InputError(run.file + ": " + e.what());
  }
  const sid::ExternalTorque& r = result.torque;
  const Eigen::VectorXd& cutoff = r.rate_cutoff_hz;
  const std::string& cutoff_choice = r.rate_cutoff_choice;
  std::ostringstream text;
  text << "external torque on " << run.file << " (" << samples << " samples, "
       << number("%.4g", log.t[samples - 1] - log.t[0]) << " s), arm of " << arm.source << "\n"
       << "method: "
       << (o.method == "observer"
               ? "generalized-momentum observer, K = " + number("%.4g", r.gain) +
                     " /s (it follows a change within about " + number("%.3g", 3000.0 / r.gain) +
                     " ms)"
               : std::string("inverse-dynamics residual (smoothed accelerations)"))
       << "\nangles smoothed at [Hz]:";
  for (int j = 0; j < n; ++j) text << " " << number("%.3g", cutoff[j]);
  text << " (" << cutoff_choice << ")";
  if (arm.torque_delay != 0.0)
    text << "\n" << torque_pairing(arm.torque_delay) << " (the fit's torque delay)";
  text << "\ncontacts are looked for from " << number("%.3g", o.skip)
       << " s after the start to as long before the end (the spline's ends)"
       << "\nthresholds (" << number("%.3g", o.threshold_factor)
       << " x the fit's residual RMS on its own logs, or x this estimate's robust spread where "
          "that is larger):\n";
  for (int j = 0; j < n; ++j)
    text << "  " << model.joint_names()[static_cast<std::size_t>(j)] << ": "
         << number("%.4g", r.thresholds[j]) << " N m (fit RMS "
         << number("%.3g", arm.residual_rms_measured[j]) << ", spread "
         << number("%.3g", r.noise[j]) << "); largest |tau_ext| "
         << number("%.4g", r.external.col(j).cwiseAbs().maxCoeff()) << "\n";
  const auto list = [&](const std::vector<sid::ExternalContact>& excursions) {
    for (const sid::ExternalContact& c : excursions) {
      text << "  " << number("%.3f", c.start) << " s to " << number("%.3f", c.end) << " s ("
           << number("%.0f", 1000.0 * (c.end - c.start)) << " ms), peak";
      for (const int j : c.joints)
        text << " " << model.joint_names()[static_cast<std::size_t>(j)] << " "
             << number("%.3g", c.peak[j]) << " N m";
      text << "\n";
    }
  };
  text << r.contacts.size() << (r.contacts.size() == 1 ? " contact" : " contacts") << "\n";
  list(r.contacts);
  if (!r.beyond_effort.empty()) {
    text << r.beyond_effort.size()
         << " excursion(s) beyond a joint's effort limit: the model's failure, not contacts\n";
    list(r.beyond_effort);
  }
  result.text = text.str();

  nlohmann::json& j = result.json;
  j["log"] = run.file;
  j["model"] = arm.source;
  j["torque_delay"] = arm.torque_delay;
  j["joint_names"] = model.joint_names();
  j["method"] = o.method;
  if (o.method == "observer") j["gain"] = r.gain;
  j["rate_cutoff_hz"] = to_json_array(cutoff);
  j["rate_cutoff_choice"] = cutoff_choice;
  j["threshold_factor"] = o.threshold_factor;
  j["thresholds"] = to_json_array(r.thresholds);
  j["fit_residual_rms"] = to_json_array(arm.residual_rms_measured);
  j["spread"] = to_json_array(r.noise);
  j["peak"] = to_json_array(r.external.cwiseAbs().colwise().maxCoeff().transpose());
  const auto excursions = [&](const std::vector<sid::ExternalContact>& list) {
    nlohmann::json out = nlohmann::json::array();
    for (const sid::ExternalContact& c : list) {
      nlohmann::json e;
      e["start"] = c.start;
      e["end"] = c.end;
      std::vector<std::string> names;
      for (const int joint : c.joints)
        names.push_back(model.joint_names()[static_cast<std::size_t>(joint)]);
      e["joints"] = names;
      e["peak"] = to_json_array(c.peak);
      out.push_back(e);
    }
    return out;
  };
  j["contacts"] = excursions(r.contacts);
  j["beyond_effort_limit"] = excursions(r.beyond_effort);
  if (arm.effort_limit.size() != 0) {
    j["effort_limit"] = nlohmann::json::array();
    for (const double limit : arm.effort_limit)
      j["effort_limit"].push_back(std::isnan(limit) ? nlohmann::json() : nlohmann::json(limit));
  }
  result.warnings = arm.warnings;
  result.warnings.insert(result.warnings.end(), r.warnings.begin(), r.warnings.end());
  return result;
}

int run_external(const ExternalOptions& o, const char* app_name) {
  require(o.chain.inputs.size() == 1, "give one log (RUN.csv)");
  require(!o.model.empty(), "--model ARM.json (sid_identify --robot --json) is required");
  if (!o.output.empty()) ensure_writable(o.output, o.force);
  if (!o.json.empty()) ensure_writable(o.json, o.force);
  LoadedChain loaded = load_chain(o.chain, {});
  if (!o.plots.empty()) {
    std::vector<std::string> plot_names;
    for (const auto& name : loaded.robot.joint_names)
      for (const auto& f : plot_files("external_" + name + ".png")) plot_names.push_back(f);
    ensure_output_directory(o.plots, plot_names, o.force);
  }
  const IdentifiedArm arm = read_identified_arm(o.model, loaded.robot, loaded.transmission);
  const ExternalResult r = external_torque(arm, loaded.runs.front(), o);
  (o.json == "-" || o.output == "-" ? std::cerr : std::cout) << r.text << std::flush;
  for (const auto& w : r.warnings) std::cerr << app_name << ": warning: " << w << "\n";
  const int n = arm.model.joints();
  if (!o.output.empty()) {
    std::vector<std::string> names{"t"};
    std::vector<Eigen::VectorXd> columns{r.torque.t};
    for (int j = 0; j < n; ++j) {
      names.push_back("tau_ext" + std::to_string(j + 1));
      columns.push_back(r.torque.external.col(j));
    }
    names.push_back("contact");
    columns.push_back(r.torque.contact.cast<double>());
    write_csv(o.output, names, columns,
              {"sid_external: the torque the outside applies at each joint [N m or N] (" +
                   r.method + "), and 1 where a contact is found",
               "log " + loaded.runs.front().file + ", arm " + o.model});
  }
  if (!o.json.empty()) write_json(o.json, r.json);
  if (!o.plots.empty()) {
    for (int j = 0; j < n; ++j) {
      const std::string& name = arm.model.joint_names()[static_cast<std::size_t>(j)];
      LinePlot plot;
      plot.title = "external torque on " + name + " (" + r.method + ")";
      plot.x_label = "t [s]";
      plot.y_label = "tau_ext [N m]";
      plot.x = r.torque.t;
      plot.series.push_back({"tau_ext", r.torque.external.col(j)});
      plot.series.push_back(
          {"threshold", Eigen::VectorXd::Constant(r.torque.t.size(), r.torque.thresholds[j])});
      plot.series.push_back(
          {"", Eigen::VectorXd::Constant(r.torque.t.size(), -r.torque.thresholds[j])});
      for (const sid::ExternalContact& c : r.torque.contacts)
        plot.marked.push_back({c.start, c.end, "contact"});
      const PlotResult p = plot_lines(plot, path_in(o.plots, "external_" + name + ".png"));
      if (j == 0 || !p.rendered) std::cerr << p.message << "\n";
    }
  }
  return kExitOk;
}

}  // namespace sid::app
