#include "chain_montecarlo_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include <sid/measurement_noise.hpp>
#include <sid/study/montecarlo.hpp>

#include "app.hpp"
#include "montecarlo_report.hpp"

namespace sid::app {

namespace {

/// The figures of one method at one level that the table prints.
struct MethodFigures {
  double median_bias = std::nan(""), max_bias = std::nan("");
  std::string max_bias_name;
  double median_std = std::nan(""), max_std = std::nan("");
  double mean_torque = std::nan(""), max_torque = std::nan("");
};

double median_of(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

MethodFigures figures_of(const sid::MethodSummary& s, const std::vector<std::string>& names) {
  MethodFigures f;
  std::vector<double> bias, std_dev;
  for (Eigen::Index k = 0; k < s.bias_pct.size(); ++k) {
    if (std::isfinite(s.bias_pct[k])) {
      const double b = std::abs(s.bias_pct[k]);
      bias.push_back(b);
      if (!(b <= f.max_bias)) {
        f.max_bias = b;
        f.max_bias_name = names[static_cast<std::size_t>(k)];
      }
    }
    if (std::isfinite(s.std_pct[k])) std_dev.push_back(s.std_pct[k]);
  }
  f.median_bias = median_of(bias);
  f.median_std = median_of(std_dev);
  if (!std_dev.empty()) f.max_std = *std::max_element(std_dev.begin(), std_dev.end());
  double sum = 0.0;
  int good = 0;
  for (Eigen::Index r = 0; r < s.torque_error_pct.size(); ++r)
    if (std::isfinite(s.torque_error_pct[r])) {
      sum += s.torque_error_pct[r];
      ++good;
      if (!(s.torque_error_pct[r] <= f.max_torque)) f.max_torque = s.torque_error_pct[r];
    }
  if (good > 0) f.mean_torque = sum / good;
  return f;
}

std::string fixed(double v, int width, int digits) {
  char buffer[64];
  if (!std::isfinite(v))
    std::snprintf(buffer, sizeof buffer, "%*s", width, "n/a");
  else
    std::snprintf(buffer, sizeof buffer, "%*.*f", width, digits, v);
  // A number wider than its column still stands apart from its neighbour.
  const std::string text = buffer;
  return text.size() >= static_cast<std::size_t>(width) ? " " + text : text;
}

/// The first non-empty reason of a list.
std::string first_reason(const std::vector<std::string>& reasons) {
  for (const std::string& r : reasons)
    if (!r.empty()) return r;
  return {};
}

/// css_tcv's estimates of the torque's delay at one level: their mean and spread over runs.
std::string delay_line(const Eigen::VectorXd& delays) {
  std::vector<double> found;
  for (const double d : delays)
    if (std::isfinite(d)) found.push_back(1e3 * d);
  if (found.empty()) return "  css_tcv found no torque delay (every run failed)\n";
  const Eigen::Map<const Eigen::VectorXd> ms(found.data(), static_cast<Eigen::Index>(found.size()));
  const double mean = ms.mean();
  const double spread =
      found.size() > 1 ? std::sqrt((ms.array() - mean).square().sum() / (ms.size() - 1.0)) : 0.0;
  char text[128];
  std::snprintf(text, sizeof text,
                "  css_tcv's torque delay found: %.3f ms, std %.3f ms over %zu runs\n", mean,
                spread, found.size());
  return text;
}

/// The header's lines on the sensors and on css_tcv's delay search; "" for plain sensors.
std::string sensors_lines(const sid::ChainMonteCarloOptions& options,
                          const ChainStudySetup& setup) {
  std::string out;
  const sid::LoggedSensors& s = options.sensors;
  if (s.quantised() || s.torque_delay != 0.0) {
    std::string what;
    if (s.quantised())
      what = setup.encoder_bits + "-bit encoders " +
             (setup.encoder_ratio.empty() ? std::string("on the joints")
                                          : "at " + setup.encoder_ratio + " turns per joint turn");
    if (s.torque_delay != 0.0)
      what += (what.empty() ? "" : ", ") + std::string("torque logged ") +
              shortest_number(1e3 * s.torque_delay) + " ms behind the angles";
    out += "  sensors          " + what + "\n";
  }
  if (options.estimate_torque_delay)
    out += "  css_tcv          estimates the torque's delay within +-" +
           shortest_number(1e3 * options.estimate_torque_delay->max_delay) + " ms\n";
  return out;
}

}  // namespace

std::string chain_montecarlo_header(const sid::ChainMonteCarloOptions& options,
                                    const ChainStudySetup& setup) {
  std::ostringstream out;
  std::string levels, methods, joints;
  for (double v : options.sigma_q2_levels) levels += (levels.empty() ? "" : ", ") + level_label(v);
  for (auto m : options.methods)
    methods += (methods.empty() ? "" : ", ") + std::string(sid::study_method_name(m));
  for (const auto& name : setup.joint_names) joints += (joints.empty() ? "" : ", ") + name;
  out << "Monte Carlo study of a chain (the paper's section 3.1, on the base parameters)\n"
      << "  robot            " << setup.robot << "\n"
      << "  joints           " << setup.joint_names.size() << " (" << joints << ")\n"
      << "  excitation       " << setup.harmonics << " harmonics of "
      << shortest_number(setup.base_frequency)
      << " Hz, |q - q0| <= " << shortest_number(setup.q_range)
      << ", |qd| <= " << shortest_number(setup.qd_max) << " (within the <limit>s), from the seed\n"
      << "  true trajectory  " << setup.samples
      << " samples, T = " << shortest_number(setup.duration)
      << " s, Ts = " << shortest_number(setup.sample_time) << " s (computed torque, CVODE)\n"
      << "  runs per level   " << options.runs << "\n"
      << "  sigma_q2 levels  " << levels << " rad^2\n"
      << "  sigma_tau2       " << level_label(options.sigma_tau2) << " (N m)^2\n"
      << sensors_lines(options, setup) << "  methods          " << methods << "\n"
      << "  seed             " << options.seed
      << " (the excitation; a run's noise depends on seed, level, run only)\n";
  return out.str();
}

std::string chain_montecarlo_tables(const sid::ChainMonteCarloResult& result) {
  std::ostringstream out;
  std::size_t zero = 0;
  for (const bool z : result.zero_in_truth) zero += z ? 1 : 0;
  out << "\n"
      << result.beta.size() << " base parameters, " << result.equations
      << " equations (samples x joints in the window)\n"
      << "|bias| and std: over runs, in % of each true value";
  if (zero > 0) out << " (not for the " << zero << " whose true value is 0, listed below)";
  out << "\ntorque: 100 |tau - Y beta-hat| / |tau| at the true motion, over runs\n";
  for (std::size_t l = 0; l < result.levels.size(); ++l) {
    const sid::LevelSummary& level = result.levels[l];
    out << "\nsigma_q2 = " << level_label(level.sigma_q2) << " rad^2\n"
        << "  method     |bias| median       max   std median       max   rms err   torque mean"
           "     max  failed  largest |bias|\n";
    for (const auto& s : level.methods) {
      const MethodFigures f = figures_of(s, result.parameter_names);
      std::string method = sid::study_method_name(s.method);
      method.resize(9, ' ');
      char failed[16];
      std::snprintf(failed, sizeof failed, "%8d", s.failed_runs);
      out << "  " << method << fixed(f.median_bias, 14, 2) << fixed(f.max_bias, 10, 2)
          << fixed(f.median_std, 13, 2) << fixed(f.max_std, 10, 2)
          << fixed(s.rms_rel_error_pct, 10, 2) << fixed(f.mean_torque, 14, 3)
          << fixed(f.max_torque, 8, 3) << failed << "  " << f.max_bias_name << "\n";
    }
    for (const auto& s : level.methods) {
      for (const auto& why : s.failures)
        out << "  " << sid::study_method_name(s.method) << " failed: " << why << "\n";
      if (s.declined_runs() > 0)
        out << "  " << sid::study_method_name(s.method) << ": the IV step declined on "
            << s.declined_runs() << " of " << s.declined.size()
            << " runs, which keep the css_gcv fit (" << first_reason(s.declined) << ")\n";
    }
    if (!result.torque_delays.empty()) out << delay_line(result.torque_delays[l]);
  }
  if (zero > 0) {
    out << "\nzero in truth (no relative figures; their mean and variance are in the JSON):";
    std::size_t shown = 0;
    for (std::size_t k = 0; k < result.zero_in_truth.size(); ++k)
      if (result.zero_in_truth[k])
        out << (shown++ % 6 == 0 ? "\n  " : ", ") << result.parameter_names[k];
    out << "\n";
  }
  return out.str();
}

std::string chain_montecarlo_wall_line(const sid::ChainMonteCarloResult& result) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.2f", result.wall_seconds);
  return "wall time " + std::string(buffer) + " s (" + std::to_string(result.threads_used) +
         " thread" + (result.threads_used == 1 ? "" : "s") +
         "; the numbers do not depend on the thread count)\n";
}

nlohmann::json chain_montecarlo_json(const sid::ChainMonteCarloResult& result,
                                     const sid::ChainMonteCarloOptions& options,
                                     const ChainStudySetup& setup) {
  nlohmann::json j;
  j["robot"] = setup.robot;
  j["base"] = setup.base;
  j["tip"] = setup.tip;
  j["joint_names"] = setup.joint_names;
  j["samples"] = setup.samples;
  j["duration"] = setup.duration;
  j["sample_time"] = setup.sample_time;
  j["excitation"] = {{"harmonics", setup.harmonics},
                     {"base_frequency", setup.base_frequency},
                     {"q_range", setup.q_range},
                     {"qd_max", setup.qd_max}};
  j["sensors"] = {{"encoder_bits", options.sensors.encoder_bits},
                  {"encoder_ratio", options.sensors.encoder_ratio},
                  {"torque_delay", options.sensors.torque_delay}};
  if (options.estimate_torque_delay)
    j["estimate_torque_delay"] = options.estimate_torque_delay->max_delay;
  j["runs"] = result.runs;
  j["seed"] = result.seed;
  j["sigma_tau2"] = number_or_null(options.sigma_tau2);
  j["threads"] = result.threads_used;
  nlohmann::json methods = nlohmann::json::array();
  for (auto m : options.methods) methods.push_back(sid::study_method_name(m));
  j["methods"] = methods;
  j["equations"] = result.equations;
  j["parameter_names"] = result.parameter_names;
  j["parameter_combinations"] = result.parameter_combinations;
  j["true_beta"] = to_json_array(result.beta);
  j["zero_in_truth"] = result.zero_in_truth;
  j["true_theta"] = to_json_array(result.theta);
  nlohmann::json levels = nlohmann::json::array();
  for (std::size_t k = 0; k < result.levels.size(); ++k) {
    const sid::LevelSummary& level = result.levels[k];
    nlohmann::json l;
    l["sigma_q2"] = level.sigma_q2;
    if (!result.torque_delays.empty()) l["torque_delays"] = to_json_array(result.torque_delays[k]);
    nlohmann::json ms = nlohmann::json::object();
    for (const auto& s : level.methods) {
      const MethodFigures f = figures_of(s, result.parameter_names);
      nlohmann::json m = method_summary_json(s);
      m["median_abs_bias_pct"] = number_or_null(f.median_bias);
      m["max_abs_bias_pct"] = number_or_null(f.max_bias);
      m["max_abs_bias_parameter"] = f.max_bias_name;
      m["median_std_pct"] = number_or_null(f.median_std);
      m["max_std_pct"] = number_or_null(f.max_std);
      m["torque_error_pct"] = to_json_array(s.torque_error_pct);
      m["mean_torque_error_pct"] = number_or_null(f.mean_torque);
      m["max_torque_error_pct"] = number_or_null(f.max_torque);
      if (s.method == sid::StudyMethod::CssIv) {
        m["declined_runs"] = s.declined_runs();
        m["declined"] = s.declined;
      }
      ms[sid::study_method_name(s.method)] = m;
    }
    l["methods"] = ms;
    levels.push_back(l);
  }
  j["levels"] = levels;
  j["wall_seconds"] = number_or_null(result.wall_seconds);
  return j;
}

void write_chain_montecarlo_csv(const std::string& dir, const sid::ChainMonteCarloResult& result) {
  // The combinations hold spaces, signs and products: a plain name heads each column, and the
  // comments say what it is.
  std::vector<std::string> names,
      comments{"seed = " + std::to_string(result.seed) + ", runs = " + std::to_string(result.runs) +
               "; nan = a failed run"};
  for (std::size_t k = 0; k < result.parameter_combinations.size(); ++k) {
    names.push_back("beta" + std::to_string(k + 1));
    comments.push_back(names.back() + " = " + result.parameter_combinations[k] + " (true " +
                       format_double(result.beta[static_cast<Eigen::Index>(k)]) + ")");
  }
  write_estimates_csv(dir, result.levels, names, comments, "base-parameter estimate");
}

std::vector<std::string> chain_montecarlo_plot_files(int joints, Eigen::Index parameters) {
  std::vector<std::string> pngs{"torque_error.png"};
  for (int j = 1; j <= joints; ++j) pngs.push_back("qdd_j" + std::to_string(j) + ".png");
  for (Eigen::Index k = 1; k <= parameters; ++k)
    pngs.push_back("beta" + std::to_string(k) + ".png");
  std::vector<std::string> files;
  for (const auto& png : pngs)
    for (const auto& f : plot_files(png)) files.push_back(f);
  return files;
}

std::vector<PlotResult> write_chain_montecarlo_plots(const std::string& dir,
                                                     const sid::ChainKinematics<double>& truth,
                                                     const sid::ChainMonteCarloResult& result,
                                                     const sid::ChainMonteCarloOptions& options,
                                                     const std::vector<std::string>& joint_names) {
  std::vector<PlotResult> plots;
  const std::string runs_seed =
      std::to_string(result.runs) + " runs, seed " + std::to_string(result.seed);
  BoxPlot torque;
  torque.title = "Prediction of the true torque at the true motion, " + runs_seed;
  torque.y_label = "100 |tau - Y beta-hat| / |tau| [%]";
  torque.groups = method_level_groups(
      result.levels, [](const sid::MethodSummary& s) { return s.torque_error_pct; });
  torque.log_y = true;
  torque.width = box_plot_width(torque);
  plots.push_back(plot_boxes(torque, path_in(dir, "torque_error.png")));

  // As the paper's Fig. 2 and 3, over the samples every method keeps.
  const double sigma_q2 = 1e-6;
  std::mt19937_64 rng = sid::run_generator(options.seed, montecarlo_figure_level_index(options), 0);
  const sid::ChainTrajectory<double> measured =
      sid::add_measurement_noise(sid::ChainTrajectory<double>{truth.t, truth.q, truth.tau},
                                 sid::MeasurementNoise<double>{sigma_q2, options.sigma_tau2}, rng);
  const auto css = sid::detail::method_kinematics(sid::StudyMethod::Css, truth, measured, sigma_q2,
                                                  options.kinematics);
  const auto filtered = sid::detail::method_kinematics(sid::StudyMethod::Filtered, truth, measured,
                                                       sigma_q2, options.kinematics);
  const double t0 = truth.t[0];
  Eigen::Index from = 0;
  while (from + 1 < truth.t.size() && truth.t[from] < t0 + options.kinematics.skip) ++from;
  const double t_end = truth.t[truth.t.size() - 1] - options.kinematics.skip_end;
  Eigen::Index to = truth.t.size();
  while (to - 1 > from && truth.t[to - 1] > t_end) --to;
  const Eigen::Index count = to - from;
  for (Eigen::Index j = 0; j < truth.q.cols(); ++j) {
    const std::string name = joint_names[static_cast<std::size_t>(j)];
    LinePlot plot;
    plot.title = "qdd of " + name + ", sigma_q2 = 1e-6, run 0, seed " +
                 std::to_string(options.seed) + " (" + format_number("%g", truth.t[from]) +
                 " <= t <= " + format_number("%g", truth.t[to - 1]) + " s)";
    plot.x_label = "t [s]";
    plot.y_label = "qdd " + name + " [rad/s^2]";
    plot.x = truth.t.segment(from, count);
    plot.series.push_back(
        {"exact", truth.qdd.col(j).segment(from, count), "lines linewidth 2 linecolor rgb 'blue'"});
    plot.series.push_back({"CSS", on_grid(truth.t, css.t, css.qdd.col(j)).segment(from, count),
                           "lines linecolor rgb 'red'"});
    plot.series.push_back({"filtered",
                           on_grid(truth.t, filtered.t, filtered.qdd.col(j)).segment(from, count),
                           "lines dashtype 2 linecolor rgb 'black'"});
    plot.marked.push_back(
        {truth.t[from], t0 + options.kinematics.filtered_skip, "dropped by filtered"});
    plots.push_back(plot_lines(plot, path_in(dir, "qdd_j" + std::to_string(j + 1) + ".png")));
  }

  for (std::size_t k = 0; k < result.parameter_names.size(); ++k) {
    const auto p = static_cast<Eigen::Index>(k);
    BoxPlot plot;
    plot.title =
        "beta" + std::to_string(k + 1) + " = " + result.parameter_names[k] + ", " + runs_seed;
    plot.y_label = "beta" + std::to_string(k + 1);
    plot.groups = method_level_groups(
        result.levels, [p](const sid::MethodSummary& s) { return s.estimates.col(p); });
    plot.has_reference = true;
    plot.reference = result.beta[p];
    plot.reference_label = "true value " + format_number("%.6g", result.beta[p]);
    plot.width = box_plot_width(plot);
    plots.push_back(plot_boxes(plot, path_in(dir, "beta" + std::to_string(k + 1) + ".png")));
  }
  return plots;
}

}  // namespace sid::app
