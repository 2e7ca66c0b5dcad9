#include "windows_app.hpp"

#include "app.hpp"
#include "progress_bar.hpp"
#include "windows_report_html.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace sid::app {

double parse_window(const std::string& text) {
  if (text == "log") return 0.0;
  const std::string usage = "--window: '" + text +
                            "' is no length; give seconds with an optional unit (600, 600s, "
                            "10min, 2h, 1d) or 'log' (each log one window)";
  std::size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    throw InputError(usage);
  }
  const std::string unit = text.substr(used);
  const std::pair<const char*, double> units[] = {
      {"", 1.0}, {"s", 1.0}, {"min", 60.0}, {"h", 3600.0}, {"d", 86400.0}};
  const auto found = std::find_if(std::begin(units), std::end(units),
                                  [&](const auto& u) { return unit == u.first; });
  require(found != std::end(units), usage);
  require(value > 0.0 && std::isfinite(value), "--window must be a length > 0 (or 'log')");
  return value * found->second;
}

namespace {

/// v in a right-aligned cell of `width` characters ("n/a" for NaN, which format_number gives
/// unpadded).
std::string cell(const char* format, double v, std::size_t width) {
  const std::string text = std::isnan(v) ? "n/a" : format_number(format, v);
  return std::string(width > text.size() ? width - text.size() : 1, ' ') + text;
}

std::string window_length(double window) {
  if (window == 0.0) return "each log whole";
  return shortest_number(window) + " s each";
}

}  // namespace

std::string windows_text(const sid::ChainWindows& w, std::size_t logs, double window) {
  std::ostringstream out;
  out << "Identified window by window: " << w.windows.size() << " window(s) ("
      << window_length(window) << ") of " << logs
      << " log(s) laid end to end in the order given.\n";
  std::size_t width = 6;
  for (const auto& win : w.windows) width = std::max(width, win.source.size());
  out << std::string(width - 6, ' ')
      << "window   t_op [h]  equations  rel. residual  cutoffs [Hz]\n";
  for (const auto& win : w.windows) {
    const sid::ChainIdentification& id = win.identification;
    std::string cutoffs;
    for (Eigen::Index j = 0; j < id.cutoff_hz.size(); ++j)
      cutoffs += (j ? " " : "") + format_number("%g", id.cutoff_hz[j]);
    out << std::string(width - win.source.size(), ' ') << win.source
        << cell("%.4g", win.operating_time / 3600.0, 11)
        << cell("%.0f", static_cast<double>(id.fitted.equations.sum()), 11)
        << cell("%.3f", 100.0 * id.fitted.relative_residual, 13) << " %  " << cutoffs
        << (id.fit.ok() ? "" : "  (fit failed: " + id.fit.message + ")") << "\n";
  }
  out << "\nDrift over the operating time: per parameter a line through its windows' estimates "
         "(weights 1/std^2, HAC std), its slope's std inflated by the Birge ratio sqrt(chi^2 / "
         "(K - 2)) when the windows scatter more than their std allow. 'drifts': |slope| > "
         "3 std with 4 windows or more, and with any one window left out.\n";
  std::size_t name_width = 9;
  for (const auto& p : w.parameters) name_width = std::max(name_width, p.name.size());
  out << std::string(name_width - 9, ' ')
      << "parameter  windows          mean    slope [/h]      std [/h]       z   Birge\n";
  for (const auto& p : w.parameters) {
    const double z = p.slope / p.slope_std_dev;
    out << std::string(name_width - p.name.size(), ' ') << p.name
        << cell("%.0f", static_cast<double>(p.windows), 9) << cell("%.6g", p.mean, 14)
        << cell("%.6g", p.slope, 14) << cell("%.6g", p.slope_std_dev, 14) << cell("%.2f", z, 8)
        << cell("%.2f", p.birge_ratio, 8) << (p.drifts ? "  drifts" : "") << "\n";
  }
  return out.str();
}

nlohmann::json windows_json(const sid::ChainWindows& w, const sid::ChainModel& model,
                            double window) {
  nlohmann::json j;
  j["joint_names"] = model.joint_names();
  j["window_s"] = window > 0.0 ? nlohmann::json(window) : nlohmann::json(nullptr);
  nlohmann::json parameters = nlohmann::json::array();
  for (const auto& p : w.parameters)
    parameters.push_back({{"name", p.name},
                          {"combination", p.combination},
                          {"windows", p.windows},
                          {"mean", p.mean},
                          {"slope_per_hour", p.slope},
                          {"slope_std_dev", p.slope_std_dev},
                          {"birge_ratio", p.birge_ratio},
                          {"drifts", p.drifts}});
  j["parameters"] = parameters;
  nlohmann::json windows = nlohmann::json::array();
  for (std::size_t k = 0; k < w.windows.size(); ++k) {
    const sid::ChainWindow& win = w.windows[k];
    const auto row = static_cast<Eigen::Index>(k);
    windows.push_back({{"source", win.source},
                       {"start", win.start},
                       {"end", win.end},
                       {"operating_time_h", win.operating_time / 3600.0},
                       {"cutoff_hz", to_json_array(win.identification.cutoff_hz)},
                       {"relative_residual", win.identification.fitted.relative_residual},
                       {"theta", to_json_array(w.value.row(row).transpose())},
                       {"std_dev", to_json_array(w.std_dev.row(row).transpose())}});
  }
  j["windows"] = windows;
  j["warnings"] = w.warnings;
  return j;
}

namespace {

/// The time the windows took, per sample of the logs (what a long log will cost).
std::string time_line(const sid::ChainWindows& w, double seconds) {
  double samples = 0.0;
  for (const auto& win : w.windows) samples += static_cast<double>(win.samples);
  return "\nTime: " + format_number("%.1f", seconds) + " s for " + format_number("%.0f", samples) +
         " samples (" + format_number("%.1f", samples > 0.0 ? 1e6 * seconds / samples : 0.0) +
         " us per sample).\n";
}

/// The library's options from the tool's, after refusing what windows cannot do.
sid::ChainWindowOptions window_options(const ChainIdentifyAppOptions& o,
                                       const LoadedChain& loaded) {
  sid::ChainWindowOptions options;
  options.window = parse_window(o.window);
  require(o.validate.empty() && !o.validate_fraction,
          "--window: each window is judged by its own fit; --validate and --validate-fraction "
          "do not apply");
  require(o.write_urdf.empty() && o.write_mjcf.empty(),
          "--window writes no model file (one per window would be needed); identify the window "
          "you want without --window");
  require(o.estimator == "ls" || o.estimator == "wls",
          "--window: the estimators are ls and wls (iv refines a single fit)");
  require(!o.estimate_torque_delay,
          "--window: give the delay with --torque-delay (estimate it on one log first)");
  options.fit = loaded.options;  // the tool's smoothing, rest rule, skips and delay
  options.fit.filter_torque = sid::ChainWindowOptions{}.fit.filter_torque;
  options.fit.weighted = o.estimator == "wls";
  options.threads = 0;
  return options;
}

WindowsResult identify_windows(const ChainIdentifyAppOptions& o, const LoadedChain& loaded,
                               std::size_t runs, const sid::ChainRunLoader& load,
                               ProgressBar* bar = nullptr) {
  sid::ChainWindowOptions options = window_options(o, loaded);
  if (bar != nullptr)
    options.progress = [bar](std::size_t done, std::size_t total) {
      bar->update(static_cast<int>(done), static_cast<int>(total));
    };
  WindowsResult result;
  const auto start = std::chrono::steady_clock::now();
  try {
    result.windows = sid::identify_chain_windows(loaded.model, runs, load, options);
  } catch (const std::invalid_argument& e) {
    if (bar != nullptr) bar->finish();
    throw InputError(e.what());
  } catch (...) {  // a log that cannot be read
    if (bar != nullptr) bar->finish();
    throw;
  }
  if (bar != nullptr) bar->finish();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.text =
      windows_text(result.windows, runs, options.window) + time_line(result.windows, seconds);
  result.json = windows_json(result.windows, loaded.model, options.window);
  return result;
}

}  // namespace

WindowsResult identify_windows_loaded(const ChainIdentifyAppOptions& o, LoadedChain loaded) {
  require(!loaded.runs.empty(), "no run given");
  return identify_windows(o, loaded, loaded.runs.size(), [&](std::size_t i) {
    return sid::NamedChainRun{loaded.runs[i].file, loaded.runs[i].data};
  });
}

int identify_robot_windows(const ChainIdentifyAppOptions& o, const char* app_name) {
  require(!o.inputs.empty(), "no run given");
  if (!o.json.empty()) ensure_writable(o.json, o.force);
  if (!o.report.empty()) ensure_writable(o.report, o.force);
  ChainIdentifyAppOptions without_runs = o;
  without_runs.inputs.clear();
  const LoadedChain loaded = load_identify_chain(without_runs);
  // Each log is read when its windows are fitted: memory does not grow with the logs' number.
  ProgressBar bar(app_name, "logs", stderr_is_terminal());
  const WindowsResult r = identify_windows(
      o, loaded, o.inputs.size(),
      [&](std::size_t i) {
        ChainRunFile run = load_chain_run(o, loaded, o.inputs[i]);
        return sid::NamedChainRun{std::move(run.file), std::move(run.data)};
      },
      &bar);
  (o.json == "-" ? std::cerr : std::cout) << r.text << std::flush;
  for (const auto& w : r.windows.warnings) std::cerr << app_name << ": warning: " << w << "\n";
  if (!o.json.empty()) write_json(o.json, r.json);
  if (!o.report.empty()) write_text(o.report, windows_report_html(r, loaded.model));
  return kExitOk;
}

}  // namespace sid::app
