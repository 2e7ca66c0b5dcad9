#include "external_app.hpp"

#include <sid/arm_dynamics.hpp>
#include <sid/identify_chain.hpp>
#include <sid/identify_runs.hpp>
#include <sid/momentum_observer.hpp>
#include <sid/quantisation.hpp>
#include <sid/smoothing_spline.hpp>

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

/// Runs of samples above threshold, merged across short gaps, short ones dropped.
std::vector<std::pair<Eigen::Index, Eigen::Index>> contact_spans(const Eigen::VectorXd& t,
                                                                 const Eigen::MatrixXd& external,
                                                                 const Eigen::VectorXd& threshold,
                                                                 const ExternalOptions& o) {
  std::vector<std::pair<Eigen::Index, Eigen::Index>> spans;
  for (Eigen::Index k = 0; k < t.size(); ++k) {
    if (t[k] < t[0] + o.skip || t[k] > t[t.size() - 1] - o.skip) continue;
    if (!(external.row(k).cwiseAbs().transpose().array() > threshold.array()).any()) continue;
    if (!spans.empty() && t[k] - t[spans.back().second] <= o.merge_gap)
      spans.back().second = k;
    else
      spans.push_back({k, k});
  }
  spans.erase(
      std::remove_if(spans.begin(), spans.end(),
                     [&](const auto& s) { return t[s.second] - t[s.first] < o.min_duration; }),
      spans.end());
  return spans;
}

std::string number(const char* format, double v) { return format_number(format, v); }

/// Per joint, 1.4826 times the median absolute deviation of the estimate from its median, over
/// the samples where contacts are looked for: its standard deviation where it is noise.
Eigen::VectorXd robust_spread(const Eigen::VectorXd& t, const Eigen::MatrixXd& external,
                              double skip) {
  std::vector<double> values;
  Eigen::VectorXd spread(external.cols());
  for (Eigen::Index j = 0; j < external.cols(); ++j) {
    values.clear();
    for (Eigen::Index i = 0; i < t.size(); ++i)
      if (t[i] >= t[0] + skip && t[i] <= t[t.size() - 1] - skip) values.push_back(external(i, j));
    const auto median = [](std::vector<double>& v) {
      const auto middle = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
      std::nth_element(v.begin(), middle, v.end());
      return *middle;
    };
    const double centre = median(values);
    for (double& v : values) v = std::abs(v - centre);
    spread[j] = 1.4826 * median(values);
  }
  return spread;
}

/// The observer's default rate [1/s]: after the backward pass it follows a 20 ms ramp to about
/// 10 % of its height at the corners, on a simulated UR5 whose angles carry 1e-6 rad of noise;
/// a faster one passes more of the rates' noise.
constexpr double kDefaultGain = 300.0;

/// Per joint, the cutoff [Hz] of the GCV smoothing spline of the log's angles: as much of the
/// motion as the angle noise lets through. The identification's cutoffs are chosen for
/// accelerations and are lower: they would smooth away the jolt a contact gives the arm, which
/// the momentum must see.
Eigen::VectorXd gcv_rate_cutoff(const sid::ChainTrajectory<double>& run) {
  const Eigen::Index n = run.q.cols();
  const double h = (run.t[run.size() - 1] - run.t[0]) / static_cast<double>(run.size() - 1);
  const sid::SmoothingSpline<double> spline(run.t);
  Eigen::VectorXd cutoff(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double lambda = spline.fit_cross_validated(run.q.col(j)).lambda;
    cutoff[j] = std::min(sid::smoothing_cutoff_for_lambda(lambda, h), 0.25 / h);
  }
  return cutoff;
}

/// Why GCV cannot choose the rates of a log, or "" when it can: GCV assumes white angle noise,
/// and takes a real log's quantised angles (encoder counts, a fixed number of logged decimals)
/// for motion; rates it leaves unsmoothed carry that error into the momentum, and on a real
/// arm's free motion they made contacts of the model's error.
std::string measured_log(const sid::ChainModel& model, const sid::ChainTrajectory<double>& run,
                         const Eigen::VectorXd& gcv, double h) {
  for (int j = 0; j < model.joints(); ++j)
    if (const double step = sid::quantisation_step(run.q.col(j)); step > 0.0)
      return "the angles of " + model.joint_names()[std::size_t(j)] + " lie on a grid (a step of " +
             number("%.2g", step) + "): a measured log";
  for (int j = 0; j < model.joints(); ++j)
    if (gcv[j] >= 0.25 / h * (1.0 - 1e-9))
      return "GCV leaves the angles of " + model.joint_names()[std::size_t(j)] +
             " unsmoothed: a measured log";
  return "";
}

/// The rates' cutoffs and, in words, how they were chosen.
std::pair<Eigen::VectorXd, std::string> rate_cutoff(const ExternalOptions& o,
                                                    const IdentifiedArm& arm,
                                                    const sid::ChainTrajectory<double>& run) {
  const int n = arm.model.joints();
  // The residual needs accelerations: the fit's cutoffs, chosen for them, by default.
  if (o.cutoff == "fit") return {arm.cutoff_hz, "the fit's"};
  if (o.cutoff.empty() && o.method == "residual") return {arm.cutoff_hz, "the fit's"};
  if (o.cutoff.empty()) {
    const double h = (run.t[run.size() - 1] - run.t[0]) / static_cast<double>(run.size() - 1);
    const Eigen::VectorXd gcv = gcv_rate_cutoff(run);
    const std::string measured = measured_log(arm.model, run, gcv, h);
    if (measured.empty()) return {gcv, "GCV"};
    return {arm.cutoff_hz, "the fit's: " + measured};
  }
  const std::vector<double> c = parse_doubles(o.cutoff, "--cutoff");
  require(c.size() == 1 || c.size() == std::size_t(n),
          "--cutoff takes one value or one per joint (" + std::to_string(n) + ")");
  Eigen::VectorXd cutoff(n);
  for (int j = 0; j < n; ++j) {
    cutoff[j] = c.size() == 1 ? c[0] : c[std::size_t(j)];
    require(cutoff[j] > 0.0 && std::isfinite(cutoff[j]), "--cutoff values must be > 0 Hz");
  }
  return {cutoff, "given"};
}

}  // namespace

ExternalResult external_torque(const IdentifiedArm& arm, const ChainRunFile& run,
                               const ExternalOptions& o) {
  const sid::ChainModel& model = arm.model;
  const int n = model.joints();
  const sid::ChainTrajectory<double>& log = run.data;
  const Eigen::Index samples = log.size();
  require(o.method == "observer" || o.method == "residual",
          "--method: observer or residual, not '" + o.method + "'");
  require(o.threshold_factor > 0.0 && std::isfinite(o.threshold_factor), "--threshold must be > 0");
  require(o.min_duration >= 0.0 && o.merge_gap >= 0.0 && o.skip >= 0.0,
          "--min-duration, --merge-gap and --skip must be >= 0 s");
  require(2.0 * o.skip < log.t[samples - 1] - log.t[0],
          "--skip " + number("%.3g", o.skip) + " s at each end leaves nothing of " + run.file);
  sid::ChainKinematics<double> k;
  Eigen::VectorXd cutoff;
  std::string cutoff_choice;
  try {
    sid::ChainIdentifyOptions smoothing;
    smoothing.filter_torque = false;
    std::tie(cutoff, cutoff_choice) = rate_cutoff(o, arm, log);
    k = sid::smooth_chain_run(log, cutoff, smoothing);
  } catch (const std::invalid_argument& e) {
    throw InputError(run.file + ": " + e.what());
  }
  ExternalResult r;
  r.t = log.t;
  r.method = o.method;
  r.external.resize(samples, n);
  const sid::ArmDynamics dynamics(model, arm.theta);
  using Vector = sid::ArmDynamics::Vector;
  Vector q(n), qd(n), qdd(n), tau(n), id(n);
  if (o.method == "residual") {
    for (Eigen::Index i = 0; i < samples; ++i) {
      q = k.q.row(i).transpose();
      qd = k.qd.row(i).transpose();
      qdd = k.qdd.row(i).transpose();
      dynamics.inverse_dynamics(q, qd, qdd, id);
      r.external.row(i) = (id - log.tau.row(i).transpose()).transpose();
    }
  } else {
    const double dt = (log.t[samples - 1] - log.t[0]) / static_cast<double>(samples - 1);
    r.gain = o.gain.value_or(std::min(kDefaultGain, 0.5 / dt));
    require(r.gain > 0.0 && std::isfinite(r.gain), "--gain must be > 0 [1/s]");
    sid::MomentumObserver observer(dynamics, Eigen::VectorXd::Constant(n, r.gain));
    for (Eigen::Index i = 0; i < samples; ++i) {
      q = k.q.row(i).transpose();
      qd = k.qd.row(i).transpose();
      tau = log.tau.row(i).transpose();
      const double step = i > 0 ? log.t[i] - log.t[i - 1] : 0.0;
      r.external.row(i) = observer.update(q, qd, tau, step).transpose();
    }
    // The observer lags the external torque by 1 / K; with the whole log at hand, the same
    // first-order lag run backwards in time cancels that phase (a ramp comes out where it was),
    // and halves the noise's bandwidth again.
    for (Eigen::Index i = samples - 2; i >= 0; --i) {
      const double decay = std::exp(-r.gain * (log.t[i + 1] - log.t[i]));
      r.external.row(i) += decay * (r.external.row(i + 1) - r.external.row(i));
    }
  }
  // The model's own error sets what counts as a contact; where this log's estimate is noisier
  // still (coarse encoders: the momentum's rate noise), its robust spread does, so that noise is
  // not called a contact. The median absolute deviation ignores the contacts themselves as long
  // as they cover less than half the log.
  r.noise = robust_spread(r.t, r.external, o.skip);
  r.thresholds = o.threshold_factor * arm.residual_rms_measured.cwiseMax(r.noise);
  r.contact = Eigen::VectorXi::Zero(samples);
  for (const auto& [first, last] : contact_spans(r.t, r.external, r.thresholds, o)) {
    Contact c;
    c.start = r.t[first];
    c.end = r.t[last];
    r.contact.segment(first, last - first + 1).setOnes();
    c.peak = Eigen::VectorXd::Zero(n);
    for (int j = 0; j < n; ++j) {
      for (Eigen::Index i = first; i <= last; ++i)
        if (std::abs(r.external(i, j)) > std::abs(c.peak[j])) c.peak[j] = r.external(i, j);
      if (std::abs(c.peak[j]) > r.thresholds[j]) c.joints.push_back(j);
    }
    r.contacts.push_back(std::move(c));
  }

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
  text << " (" << cutoff_choice << ")"
       << "\ncontacts are looked for from " << number("%.3g", o.skip)
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
  text << r.contacts.size() << (r.contacts.size() == 1 ? " contact" : " contacts") << "\n";
  for (const Contact& c : r.contacts) {
    text << "  " << number("%.3f", c.start) << " s to " << number("%.3f", c.end) << " s ("
         << number("%.0f", 1000.0 * (c.end - c.start)) << " ms), peak";
    for (const int j : c.joints)
      text << " " << model.joint_names()[static_cast<std::size_t>(j)] << " "
           << number("%.3g", c.peak[j]) << " N m";
    text << "\n";
  }
  r.text = text.str();

  nlohmann::json& j = r.json;
  j["log"] = run.file;
  j["model"] = arm.source;
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
  j["contacts"] = nlohmann::json::array();
  for (const Contact& c : r.contacts) {
    nlohmann::json e;
    e["start"] = c.start;
    e["end"] = c.end;
    std::vector<std::string> names;
    for (const int joint : c.joints)
      names.push_back(model.joint_names()[static_cast<std::size_t>(joint)]);
    e["joints"] = names;
    e["peak"] = to_json_array(c.peak);
    j["contacts"].push_back(e);
  }
  r.warnings = arm.warnings;
  // Twice the model's own error: the estimate's noise, not the model, sets the thresholds.
  for (int joint = 0; joint < n; ++joint)
    if (r.noise[joint] > 2.0 * arm.residual_rms_measured[joint]) {
      r.warnings.push_back(
          "the estimate's spread on " + model.joint_names()[static_cast<std::size_t>(joint)] +
          " (" + number("%.3g", r.noise[joint]) + " N m) is more than twice the fit's residual (" +
          number("%.3g", arm.residual_rms_measured[joint]) +
          "): the rates are noisy (coarse encoders?), so only contacts above its threshold are "
          "seen; a lower --cutoff (or --cutoff fit) and --gain quiet it");
      break;
    }
  return r;
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
    std::vector<Eigen::VectorXd> columns{r.t};
    for (int j = 0; j < n; ++j) {
      names.push_back("tau_ext" + std::to_string(j + 1));
      columns.push_back(r.external.col(j));
    }
    names.push_back("contact");
    columns.push_back(r.contact.cast<double>());
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
      plot.x = r.t;
      plot.series.push_back({"tau_ext", r.external.col(j)});
      plot.series.push_back({"threshold", Eigen::VectorXd::Constant(r.t.size(), r.thresholds[j])});
      plot.series.push_back({"", Eigen::VectorXd::Constant(r.t.size(), -r.thresholds[j])});
      for (const Contact& c : r.contacts) plot.marked.push_back({c.start, c.end, "contact"});
      const PlotResult p = plot_lines(plot, path_in(o.plots, "external_" + name + ".png"));
      if (j == 0 || !p.rendered) std::cerr << p.message << "\n";
    }
  }
  return kExitOk;
}

}  // namespace sid::app
