#include "montecarlo_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numeric>
#include <sid/measurement_noise.hpp>
#include <sstream>
#include <stdexcept>

#include "app.hpp"
#include "csv.hpp"
#include "paper_tables.hpp"

namespace sid::app {

namespace {

constexpr int kParameters = 7;

std::string printf_double(const char* format, double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, v);
  return buffer;
}

// "1.8940e-07" -> "1.894e-07"; "1.0000e-04" -> "1e-04".
std::string trimmed_scientific(double v, int digits) {
  char format[16];
  std::snprintf(format, sizeof format, "%%.%de", digits);
  std::string text = printf_double(format, v);
  const auto e = text.find('e');
  if (e == std::string::npos) return text;
  std::string mantissa = text.substr(0, e);
  if (mantissa.find('.') != std::string::npos) {
    while (!mantissa.empty() && mantissa.back() == '0') mantissa.pop_back();
    if (!mantissa.empty() && mantissa.back() == '.') mantissa.pop_back();
  }
  return mantissa + text.substr(e);
}

std::string pad_left(const std::string& text, std::size_t width) {
  return text.size() >= width ? text : std::string(width - text.size(), ' ') + text;
}

std::string pad_right(const std::string& text, std::size_t width) {
  return text.size() >= width ? text : text + std::string(width - text.size(), ' ');
}

// Sample means: fixed 6 decimals (the paper prints 4), scientific when huge.
std::string format_mean(double v) {
  if (!std::isfinite(v)) return "nan";
  return std::fabs(v) < 1e4 ? printf_double("%.6f", v) : printf_double("%.4e", v);
}

std::string format_variance(double v) {
  if (!std::isfinite(v)) return "nan";
  return printf_double("%.3e", v);
}

std::string format_percent(const char* format, double v) {
  if (!std::isfinite(v)) return "nan";
  return printf_double(format, v);
}

std::string format_paper_mean(const PaperEntry& e) {
  return e.order_only ? "~" + trimmed_scientific(e.value, 0) : printf_double("%.4f", e.value);
}

std::string format_paper_variance(const PaperEntry& e) {
  return e.order_only ? "~" + trimmed_scientific(e.value, 0) : trimmed_scientific(e.value, 4);
}

// The paper's column of a method (raw 0, filtered 1, css 2), or -1 (oracle).
int paper_column(sid::StudyMethod m) {
  switch (m) {
    case sid::StudyMethod::Raw:
      return 0;
    case sid::StudyMethod::Filtered:
      return 1;
    case sid::StudyMethod::Css:
      return 2;
    case sid::StudyMethod::CssGcv:
    case sid::StudyMethod::CssWls:
    case sid::StudyMethod::CssIv:
    case sid::StudyMethod::CssTorqueCv:
      return -1;
    case sid::StudyMethod::Oracle:
      return -1;
  }
  return -1;
}

std::string paper_tables_of(const PaperLevel& level) {
  const auto& all = paper_levels();
  for (std::size_t k = 0; k < all.size(); ++k)
    if (&all[k] == &level)
      return "paper: tables " + std::to_string(2 + 2 * k) + " and " + std::to_string(3 + 2 * k);
  return "paper";
}

constexpr std::size_t kNameWidth = 8;   // "theta1" + gap
constexpr std::size_t kTrueWidth = 12;  // "0.00306414" + gap
constexpr std::size_t kOursWidth = 10;  // "-0.000512", "1.234e-07"
constexpr std::size_t kPaperMeanWidth = 7;
constexpr std::size_t kPaperVarWidth = 9;

// One cell "ours / paper" (or "ours" alone), with the two-space gap before it.
std::string cell(const std::string& ours, const std::string* paper, std::size_t paper_width) {
  std::string text = "  " + pad_left(ours, kOursWidth);
  if (paper) text += " / " + pad_right(*paper, paper_width);
  return text;
}

std::string cell_header(const std::string& name, bool with_paper, std::size_t paper_width) {
  const std::size_t width = kOursWidth + (with_paper ? 3 + paper_width : 0);
  return "  " + pad_left(name, width);
}

// Removes trailing spaces of every line.
std::string rstrip_lines(const std::string& text) {
  std::istringstream in(text);
  std::string line, out;
  while (std::getline(in, line)) {
    while (!line.empty() && line.back() == ' ') line.pop_back();
    out += line + "\n";
  }
  return out;
}

std::string table_of_values(const sid::LevelSummary& level, const PaperLevel* paper,
                            const sid::TwoLinkParameters<double>& theta, bool means) {
  const auto names = montecarlo_parameter_names();
  const std::size_t paper_width = means ? kPaperMeanWidth : kPaperVarWidth;
  std::ostringstream out;
  out << pad_right("param", kNameWidth);
  if (means) out << pad_left("true value", kTrueWidth - 2) << "  ";
  for (const auto& s : level.methods) {
    const bool with_paper = paper && paper_column(s.method) >= 0;
    out << cell_header(sid::study_method_name(s.method), with_paper, paper_width);
  }
  out << "\n";
  if (paper) {
    out << pad_right("", kNameWidth);
    if (means) out << pad_right("", kTrueWidth);
    for (const auto& s : level.methods) {
      const bool with_paper = paper_column(s.method) >= 0;
      out << (with_paper
                  ? "  " + pad_left("ours", kOursWidth) + " / " + pad_right("paper", paper_width)
                  : "  " + pad_left("ours", kOursWidth));
    }
    out << "\n";
  }
  for (int p = 0; p < kParameters; ++p) {
    out << pad_right(names[static_cast<std::size_t>(p)], kNameWidth);
    if (means) out << pad_left(printf_double("%.6g", theta[p]), kTrueWidth - 2) << "  ";
    for (const auto& s : level.methods) {
      const int column = paper_column(s.method);
      const std::string ours = means ? format_mean(s.mean[p]) : format_variance(s.variance[p]);
      if (paper && column >= 0) {
        const auto& row = means ? paper->mean : paper->variance;
        const PaperEntry& e = row[static_cast<std::size_t>(p)][static_cast<std::size_t>(column)];
        const std::string printed = means ? format_paper_mean(e) : format_paper_variance(e);
        out << cell(ours, &printed, paper_width);
      } else {
        out << cell(ours, nullptr, paper_width);
      }
    }
    out << "\n";
  }
  return out.str();
}

std::string table_of_percentages(const sid::LevelSummary& level) {
  const auto names = montecarlo_parameter_names();
  std::ostringstream out;
  out << pad_right("param", kNameWidth);
  for (const auto& s : level.methods) out << "  " << pad_left(sid::study_method_name(s.method), 16);
  out << "\n" << pad_right("", kNameWidth);
  for (std::size_t m = 0; m < level.methods.size(); ++m)
    out << "  " << pad_left("bias %", 8) << pad_left("std %", 8);
  out << "\n";
  for (int p = 0; p < kParameters; ++p) {
    out << pad_right(names[static_cast<std::size_t>(p)], kNameWidth);
    for (const auto& s : level.methods)
      out << "  " << pad_left(format_percent("%+.2f", s.bias_pct[p]), 8)
          << pad_left(format_percent("%.2f", s.std_pct[p]), 8);
    out << "\n";
  }
  return out.str();
}

std::string ranking(const sid::LevelSummary& level) {
  const auto names = montecarlo_parameter_names();
  std::vector<std::size_t> order(level.methods.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  // NaN (every run failed) goes last; ties keep the order of the methods.
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const double ra = level.methods[a].rms_rel_error_pct, rb = level.methods[b].rms_rel_error_pct;
    if (std::isnan(ra) || std::isnan(rb)) return !std::isnan(ra) && std::isnan(rb);
    return ra < rb;
  });
  std::ostringstream out;
  out << "RMS relative error over runs and the 7 parameters, best first:\n";
  for (std::size_t k = 0; k < order.size(); ++k) {
    const auto& s = level.methods[order[k]];
    out << "  " << (k + 1) << ". " << pad_right(sid::study_method_name(s.method), 9)
        << pad_left(format_percent("%.2f", s.rms_rel_error_pct), 9) << " %";
    if (std::isfinite(s.worst_abs_bias_pct)) {
      Eigen::Index worst = 0;
      s.bias_pct.cwiseAbs().maxCoeff(&worst);
      out << "   worst |bias| " << pad_left(format_percent("%.2f", s.worst_abs_bias_pct), 8)
          << " % (" << names[static_cast<std::size_t>(worst)] << ")";
    }
    out << "\n";
  }
  return out.str();
}

std::string failures(const sid::LevelSummary& level, int runs) {
  std::ostringstream out;
  for (const auto& s : level.methods) {
    if (s.failed_runs == 0) continue;
    out << "  " << sid::study_method_name(s.method) << ": " << s.failed_runs << " of " << runs
        << " runs failed (left out of the statistics)";
    if (!s.failures.empty()) out << "; first: " << s.failures.front();
    out << "\n";
  }
  const std::string text = out.str();
  return text.empty() ? text : "Failed runs:\n" + text;
}

const char* parameter_unit(int p) { return p < 3 ? "kg m^2" : p < 5 ? "kg m" : "N m s/rad"; }

}  // namespace

// The estimators keep a subset of the sample times, copied exactly; a small tolerance guards
// against rounding anyway.
Eigen::VectorXd on_grid(const Eigen::VectorXd& t, const Eigen::VectorXd& tk,
                        const Eigen::VectorXd& y) {
  Eigen::VectorXd out = Eigen::VectorXd::Constant(t.size(), std::nan(""));
  Eigen::Index i = 0;
  const double tol = t.size() > 1 ? 1e-6 * (t[1] - t[0]) : 0.0;
  for (Eigen::Index k = 0; k < tk.size(); ++k) {
    while (i < t.size() && t[i] < tk[k] - tol) ++i;
    if (i < t.size() && std::fabs(t[i] - tk[k]) <= tol) out[i] = y[k];
  }
  return out;
}

std::string level_label(double sigma_q2) {
  // Scientific below 0.01 (noise variances are mostly powers of ten), %g otherwise.
  const double a = std::fabs(sigma_q2);
  std::string text = a != 0.0 && std::isfinite(a) && (a < 1e-2 || a >= 1e6)
                         ? trimmed_scientific(sigma_q2, 5)
                         : printf_double("%.6g", sigma_q2);
  const auto e = text.find('e');
  if (e == std::string::npos) return text;
  std::string exponent = text.substr(e + 1);
  std::string sign;
  if (!exponent.empty() && (exponent[0] == '-' || exponent[0] == '+')) {
    if (exponent[0] == '-') sign = "-";
    exponent.erase(0, 1);
  }
  while (exponent.size() > 1 && exponent[0] == '0') exponent.erase(0, 1);
  return text.substr(0, e) + "e" + sign + exponent;
}

std::vector<std::string> montecarlo_parameter_names() {
  std::vector<std::string> names;
  for (int p = 1; p <= kParameters; ++p) names.push_back("theta" + std::to_string(p));
  return names;
}

std::string montecarlo_header(const sid::MonteCarloOptions& options, Eigen::Index samples) {
  std::ostringstream out;
  std::string levels, methods;
  for (double v : options.sigma_q2_levels) levels += (levels.empty() ? "" : ", ") + level_label(v);
  for (auto m : options.methods)
    methods += (methods.empty() ? "" : ", ") + std::string(sid::study_method_name(m));
  out << "Monte Carlo study of the paper (Dolinsky & Celikovsky, section 3.1): two-link arm,\n"
      << "u1 = 6 sin t, u2 = 4 cos t, " << samples << " samples (true trajectory by CVODE)\n"
      << "  runs per level   " << options.runs << "\n"
      << "  sigma_q2 levels  " << levels << " rad^2\n"
      << "  sigma_tau2       " << level_label(options.sigma_tau2) << " (N m)^2\n"
      << "  methods          " << methods << "\n"
      << "  seed             " << options.seed
      << " (a run's noise depends on seed, level, run only)\n"
      << "  true theta       the corrected values (the paper prints 0.0030 and 0.0170 for theta2 "
         "and\n"
      << "                   theta5; see docs/paper-reproduction.md)\n";
  return out.str();
}

std::string montecarlo_tables(const sid::MonteCarloResult& result) {
  std::ostringstream out;
  for (const auto& level : result.levels) {
    const PaperLevel* paper = paper_level(level.sigma_q2);
    out << "\n=== sigma_q2 = " << level_label(level.sigma_q2) << " rad^2  ("
        << (paper ? paper_tables_of(*paper) : std::string("no paper values for this level"))
        << ") ===\n\n";
    out << "Sample means over " << result.runs << " runs"
        << (paper ? " (ours / the paper's printed value)" : "") << "\n"
        << table_of_values(level, paper, result.theta, true) << "\n";
    out << "Sample variances (ddof 1)"
        << (paper ? " (ours / the paper's; ~ = the paper gives only the order of magnitude)" : "")
        << "\n"
        << table_of_values(level, paper, result.theta, false) << "\n";
    out << "Bias and standard deviation in % of the true value\n"
        << table_of_percentages(level) << "\n";
    out << ranking(level);
    out << failures(level, result.runs);
  }
  return rstrip_lines(out.str());
}

std::string montecarlo_wall_line(const sid::MonteCarloResult& result) {
  return "wall time " + printf_double("%.2f", result.wall_seconds) + " s (" +
         std::to_string(result.threads_used) + " thread" + (result.threads_used == 1 ? "" : "s") +
         "; the numbers do not depend on the thread count)\n";
}

nlohmann::json number_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

nlohmann::json method_summary_json(const sid::MethodSummary& s) {
  nlohmann::json m;
  m["mean"] = to_json_array(s.mean);
  m["var"] = to_json_array(s.variance);
  m["bias_pct"] = to_json_array(s.bias_pct);
  m["std_pct"] = to_json_array(s.std_pct);
  m["rms_rel_error_pct"] = number_or_null(s.rms_rel_error_pct);
  m["standard_error"] = to_json_array(s.standard_error);
  m["failed_runs"] = s.failed_runs;
  m["failures"] = s.failures;
  return m;
}

nlohmann::json montecarlo_json(const sid::MonteCarloResult& result,
                               const sid::MonteCarloOptions& options, Eigen::Index samples) {
  nlohmann::json j;
  j["runs"] = result.runs;
  j["seed"] = result.seed;
  j["true_theta"] = to_json_array(result.theta);
  j["sigma_tau2"] = number_or_null(options.sigma_tau2);
  j["samples"] = samples;
  j["threads"] = result.threads_used;
  nlohmann::json methods = nlohmann::json::array();
  for (auto m : options.methods) methods.push_back(sid::study_method_name(m));
  j["methods"] = methods;
  j["parameter_names"] = montecarlo_parameter_names();
  j["paper_printed_true_theta"] = kPaperPrintedTrue;
  nlohmann::json levels = nlohmann::json::array();
  for (const auto& level : result.levels) {
    const PaperLevel* paper = paper_level(level.sigma_q2);
    nlohmann::json l;
    l["sigma_q2"] = level.sigma_q2;
    nlohmann::json ms = nlohmann::json::object();
    for (const auto& s : level.methods) {
      nlohmann::json m = method_summary_json(s);
      m["worst_abs_bias_pct"] = number_or_null(s.worst_abs_bias_pct);
      const int column = paper_column(s.method);
      if (paper && column >= 0) {
        nlohmann::json pm = nlohmann::json::array(), pv = nlohmann::json::array(),
                       pmo = nlohmann::json::array(), pvo = nlohmann::json::array();
        for (std::size_t p = 0; p < kParameters; ++p) {
          const auto c = static_cast<std::size_t>(column);
          pm.push_back(paper->mean[p][c].value);
          pmo.push_back(paper->mean[p][c].order_only);
          pv.push_back(paper->variance[p][c].value);
          pvo.push_back(paper->variance[p][c].order_only);
        }
        m["paper"] = {{"mean", pm}, {"var", pv}, {"mean_order_only", pmo}, {"var_order_only", pvo}};
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

std::vector<std::string> montecarlo_csv_files(const sid::StudySettings& options) {
  std::vector<std::string> files{"estimates.csv"};
  for (double level : options.sigma_q2_levels)
    for (auto m : options.methods)
      files.push_back(std::string(sid::study_method_name(m)) + "_" + level_label(level) + ".csv");
  return files;
}

void write_estimates_csv(const std::string& dir, const std::vector<sid::LevelSummary>& levels,
                         const std::vector<std::string>& names,
                         const std::vector<std::string>& comments, const std::string& what) {
  const std::string all = path_in(dir, "estimates.csv");
  {
    std::ofstream out(all, std::ios::binary);
    if (!out) throw std::runtime_error("cannot write '" + all + "'");
    out << "# sid_montecarlo: every " << what << " of every run";
    for (std::size_t c = 0; c < comments.size(); ++c)
      out << (c == 0 ? "; " : "\n# ") << comments[c];
    out << "\n";
    out << "level,method,run";
    for (const auto& n : names) out << "," << n;
    out << "\n";
    for (const auto& level : levels)
      for (const auto& s : level.methods)
        for (Eigen::Index r = 0; r < s.estimates.rows(); ++r) {
          out << format_double(level.sigma_q2) << "," << sid::study_method_name(s.method) << ","
              << r;
          for (Eigen::Index p = 0; p < s.estimates.cols(); ++p)
            out << "," << format_double(s.estimates(r, p));
          out << "\n";
        }
    if (!out.flush()) throw std::runtime_error("cannot write '" + all + "'");
  }
  for (const auto& level : levels)
    for (const auto& s : level.methods) {
      std::vector<std::string> columns_names{"run"};
      columns_names.insert(columns_names.end(), names.begin(), names.end());
      std::vector<Eigen::VectorXd> columns{Eigen::VectorXd::LinSpaced(
          s.estimates.rows(), 0.0, static_cast<double>(s.estimates.rows() - 1))};
      for (Eigen::Index p = 0; p < s.estimates.cols(); ++p)
        columns.emplace_back(s.estimates.col(p));
      const std::string file = path_in(dir, std::string(sid::study_method_name(s.method)) + "_" +
                                                level_label(level.sigma_q2) + ".csv");
      std::vector<std::string> lines{"sid_montecarlo: " + what + " of every run, method " +
                                     std::string(sid::study_method_name(s.method)) +
                                     ", sigma_q2 = " + level_label(level.sigma_q2) + " rad^2"};
      lines.insert(lines.end(), comments.begin(), comments.end());
      write_csv(file, columns_names, columns, lines);
    }
}

void write_montecarlo_csv(const std::string& dir, const sid::MonteCarloResult& result) {
  write_estimates_csv(dir, result.levels, montecarlo_parameter_names(),
                      {"seed = " + std::to_string(result.seed) +
                       ", runs = " + std::to_string(result.runs) + "; nan = a failed run"},
                      "theta-hat");
}

std::vector<std::string> montecarlo_plot_files() {
  std::vector<std::string> files;
  std::vector<std::string> pngs{"fig2_qdd1.png", "fig2_qdd1_detail.png", "fig3_qdd2.png",
                                "fig3_qdd2_detail.png"};
  for (const auto& n : montecarlo_parameter_names()) pngs.push_back(n + ".png");
  for (const auto& png : pngs)
    for (const auto& f : plot_files(png)) files.push_back(f);
  return files;
}

std::size_t montecarlo_figure_level_index(const sid::StudySettings& options) {
  for (std::size_t l = 0; l < options.sigma_q2_levels.size(); ++l) {
    const double v = options.sigma_q2_levels[l];
    if (v > 0.999e-6 && v < 1.001e-6) return l;
  }
  return 1;
}

std::vector<PlotResult> write_montecarlo_plots(const std::string& dir,
                                               const sid::Kinematics<double>& truth,
                                               const sid::MonteCarloResult& result,
                                               const sid::MonteCarloOptions& options) {
  std::vector<PlotResult> plots;
  // Fig. 2 and 3: one data set at sigma_q2 = 1e-6, run 0.
  const double sigma_q2 = 1e-6;
  const std::size_t level = montecarlo_figure_level_index(options);
  std::mt19937_64 rng = sid::run_generator(options.seed, level, 0);
  const sid::Trajectory<double> measured = sid::add_measurement_noise(
      truth, sid::MeasurementNoise<double>{sigma_q2, options.sigma_tau2}, rng);
  const auto css =
      sid::study_kinematics(sid::StudyMethod::Css, truth, measured, sigma_q2, options.identify);
  const auto filtered = sid::study_kinematics(sid::StudyMethod::Filtered, truth, measured, sigma_q2,
                                              options.identify);
  const double t0 = truth.t[0];
  const double clip = t0 + options.identify.filtered_skip;
  // The start transient (qdd2(0) is about 2205 rad/s^2) dwarfs the rest, so each figure comes
  // twice: 0 <= t <= 10 s as in the paper, and a detail from t0 + skip (what every method keeps).
  for (int joint = 0; joint < 2; ++joint) {
    const Eigen::VectorXd f = on_grid(truth.t, filtered.t, filtered.qdd.col(joint));
    Eigen::VectorXd kept = f, clipped = f;
    for (Eigen::Index i = 0; i < truth.t.size(); ++i)
      (truth.t[i] < clip ? kept[i] : clipped[i]) = std::nan("");
    // The clipped curve ends at the first kept sample, so the two join.
    for (Eigen::Index i = 0; i < truth.t.size(); ++i)
      if (truth.t[i] >= clip) {
        clipped[i] = f[i];
        break;
      }
    const Eigen::VectorXd spline = on_grid(truth.t, css.t, css.qdd.col(joint));
    Eigen::Index first_kept = 0;
    while (first_kept < truth.t.size() && truth.t[first_kept] < t0 + options.identify.skip)
      ++first_kept;
    for (const bool detail : {false, true}) {
      const Eigen::Index from = detail ? std::min(first_kept, truth.t.size() - 1) : 0;
      const Eigen::Index count = truth.t.size() - from;
      LinePlot plot;
      plot.title = std::string(joint == 0 ? "Fig. 2" : "Fig. 3") + ": qdd" +
                   std::to_string(joint + 1) + ", sigma_q2 = 1e-6, run 0, seed " +
                   std::to_string(options.seed) +
                   (detail ? " (t >= " + printf_double("%g", truth.t[from]) + " s)" : "");
      plot.x_label = "t [s]";
      plot.y_label = "qdd" + std::to_string(joint + 1) + " [rad/s^2]";
      plot.x = truth.t.segment(from, count);
      plot.series.push_back({"exact", truth.qdd.col(joint).segment(from, count),
                             "lines linewidth 2 linecolor rgb 'blue'"});
      plot.series.push_back({"CSS", spline.segment(from, count), "lines linecolor rgb 'red'"});
      plot.series.push_back(
          {"filtered", kept.segment(from, count), "lines dashtype 2 linecolor rgb 'black'"});
      plot.series.push_back({"filtered, clipped", clipped.segment(from, count),
                             "lines dashtype 2 linecolor rgb '#00a000'"});
      plot.marked.push_back({truth.t[from], clip, "clipped (filtered)"});
      const std::string name =
          std::string(joint == 0 ? "fig2_qdd1" : "fig3_qdd2") + (detail ? "_detail" : "");
      plots.push_back(plot_lines(plot, path_in(dir, name + ".png")));
    }
  }
  // Box plots of theta-hat per parameter, by level and method.
  const auto names = montecarlo_parameter_names();
  for (int p = 0; p < kParameters; ++p) {
    BoxPlot plot;
    plot.title = names[static_cast<std::size_t>(p)] + ": estimates of " +
                 std::to_string(result.runs) + " runs by method and sigma_q2 (seed " +
                 std::to_string(result.seed) + ")";
    plot.y_label = names[static_cast<std::size_t>(p)] + " [" + parameter_unit(p) + "]";
    plot.groups = method_level_groups(
        result.levels, [p](const sid::MethodSummary& s) { return s.estimates.col(p); });
    plot.has_reference = true;
    plot.reference = result.theta[p];
    plot.reference_label = "true value " + printf_double("%.6g", result.theta[p]);
    plot.width = box_plot_width(plot);
    plots.push_back(plot_boxes(plot, path_in(dir, names[static_cast<std::size_t>(p)] + ".png")));
  }
  return plots;
}

}  // namespace sid::app
