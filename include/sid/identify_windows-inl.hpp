#pragma once
// The definitions of <sid/identify_windows.hpp>.

#include <sid/detail/format.hpp>
#include <sid/detail/parallel.hpp>
#include <sid/identify_windows.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

namespace detail {

/// The first sample of each window of a run of `duration` seconds (offsets from its start):
/// whole windows, the last piece joining the one before unless it is at least half a window.
inline std::vector<double> window_starts(double duration, double window) {
  if (window <= 0.0 || duration < window) return {0.0};
  auto whole = static_cast<long>(std::floor(duration / window));
  if (duration - static_cast<double>(whole) * window >= 0.5 * window) ++whole;
  std::vector<double> starts;
  for (long k = 0; k < whole; ++k) starts.push_back(static_cast<double>(k) * window);
  return starts;
}

inline ChainTrajectory<double> run_rows(const ChainTrajectory<double>& run, Eigen::Index first,
                                        Eigen::Index count) {
  return {run.t.segment(first, count), run.q.middleRows(first, count),
          run.tau.middleRows(first, count)};
}

}  // namespace detail

namespace detail {

/// Where a window lies: its run, its rows, its name and its middle [s] from its run's start.
struct WindowSpan {
  std::size_t run = 0;
  Eigen::Index first = 0, count = 0;
  std::string name;
  double middle = 0.0;
};

/// The windows of runs (see cut_into_windows), without copying a sample.
inline std::vector<WindowSpan> window_spans(const std::vector<NamedChainRun>& runs, double window) {
  const std::string who = "sid::cut_into_windows: ";
  if (!(window >= 0.0 && std::isfinite(window)))
    throw std::invalid_argument(who + "the window must be finite and >= 0 s (0: each run whole)");
  if (runs.empty()) throw std::invalid_argument(who + "no run given");
  std::vector<WindowSpan> spans;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const NamedChainRun& run = runs[r];
    run.data.validate(("sid::cut_into_windows (" + run.name + ")").c_str());
    const Eigen::Index n = run.data.size();
    if (n < 2) throw std::invalid_argument(who + run.name + " has fewer than 2 samples");
    const auto& t = run.data.t;
    if (window > 0.0 && (t[n - 1] - t[0]) / window > static_cast<double>(n))
      throw std::invalid_argument(who + "a window of " + format_number("%g", window) +
                                  " s would cut " + run.name + " into more windows than its " +
                                  std::to_string(n) + " samples");
    const std::vector<double> starts = window_starts(t[n - 1] - t[0], window);
    Eigen::Index first = 0;
    for (std::size_t k = 0; k < starts.size(); ++k) {
      Eigen::Index next = n;
      if (k + 1 < starts.size()) {
        next = first;
        while (next < n && t[next] - t[0] < starts[k + 1]) ++next;
      }
      const Eigen::Index count = next - first;
      if (count == 0) continue;  // a gap in the log longer than a window
      const double start = t[first], end = t[next - 1];
      const std::string name = starts.size() == 1 ? run.name
                                                  : run.name + " [" + format_number("%g", start) +
                                                        "-" + format_number("%g", end) + " s]";
      spans.push_back({r, first, count, name, 0.5 * (start + end) - t[0]});
      first = next;
    }
  }
  return spans;
}

}  // namespace detail

SID_INLINE std::vector<NamedChainRun> cut_into_windows(const std::vector<NamedChainRun>& runs,
                                                       double window) {
  std::vector<NamedChainRun> windows;
  for (const detail::WindowSpan& s : detail::window_spans(runs, window))
    windows.push_back({s.name, detail::run_rows(runs[s.run].data, s.first, s.count)});
  return windows;
}

namespace detail {

/// The weighted line alone (mean, slope, its Birge-inflated std), without a verdict.
inline ParameterTrend drift_line(const Eigen::VectorXd& hours, const Eigen::VectorXd& value,
                                 const Eigen::VectorXd& std_dev) {
  ParameterTrend d;
  double sw = 0.0, swt = 0.0, swy = 0.0;
  for (Eigen::Index k = 0; k < value.size(); ++k) {
    if (!(std_dev[k] > 0.0 && std::isfinite(std_dev[k]) && std::isfinite(value[k]))) continue;
    const double w = 1.0 / (std_dev[k] * std_dev[k]);
    ++d.windows;
    sw += w;
    swt += w * hours[k];
    swy += w * value[k];
  }
  if (d.windows == 0) return d;
  const double centre = swt / sw;
  d.mean = swy / sw;
  if (d.windows < 2) return d;
  double stt = 0.0, sty = 0.0;
  for (Eigen::Index k = 0; k < value.size(); ++k) {
    if (!(std_dev[k] > 0.0 && std::isfinite(std_dev[k]) && std::isfinite(value[k]))) continue;
    const double w = 1.0 / (std_dev[k] * std_dev[k]), dt = hours[k] - centre;
    stt += w * dt * dt;
    sty += w * dt * (value[k] - d.mean);
  }
  if (!(stt > 0.0)) return d;  // every window at one time: no line
  d.slope = sty / stt;
  d.slope_std_dev = std::sqrt(1.0 / stt);
  if (d.windows < 3) return d;
  double chi2 = 0.0;
  for (Eigen::Index k = 0; k < value.size(); ++k) {
    if (!(std_dev[k] > 0.0 && std::isfinite(std_dev[k]) && std::isfinite(value[k]))) continue;
    const double r = (value[k] - d.mean - d.slope * (hours[k] - centre)) / std_dev[k];
    chi2 += r * r;
  }
  d.birge_ratio = std::sqrt(chi2 / (d.windows - 2));
  d.slope_std_dev *= std::max(1.0, d.birge_ratio);
  return d;
}

}  // namespace detail

SID_INLINE ParameterTrend fit_drift(const Eigen::VectorXd& hours, const Eigen::VectorXd& value,
                                    const Eigen::VectorXd& std_dev, double drift_z) {
  ParameterTrend d = detail::drift_line(hours, value, std_dev);
  if (d.windows < 4 || !(std::abs(d.slope) > drift_z * d.slope_std_dev)) return d;
  // No one window may make the verdict: a window whose motion shows a model error the others
  // do not (its estimate off by more than its std, which sees only the noise) would otherwise
  // read as drift when it comes first or last.
  Eigen::VectorXd without = std_dev;
  for (Eigen::Index k = 0; k < value.size(); ++k) {
    if (!(std_dev[k] > 0.0 && std::isfinite(std_dev[k]) && std::isfinite(value[k]))) continue;
    without[k] = std::nan("");
    const ParameterTrend rest = detail::drift_line(hours, value, without);
    without[k] = std_dev[k];
    if (!(rest.slope * d.slope > 0.0 && std::abs(rest.slope) > drift_z * rest.slope_std_dev))
      return d;
  }
  d.drifts = true;
  return d;
}

namespace detail {

/// Identifies each window of runs into `out`; run_start: each run's start on the operating time.
inline void identify_windows_of(const ChainModel& model, const std::vector<NamedChainRun>& runs,
                                const std::vector<double>& run_start,
                                const ChainWindowOptions& options, std::vector<ChainWindow>& out) {
  std::vector<WindowSpan> spans = window_spans(runs, options.window);
  const std::size_t before = out.size();
  out.resize(before + spans.size());
  for_each_index(static_cast<Eigen::Index>(spans.size()), thread_count(options.threads),
                 [&](Eigen::Index i, int) {
                   const WindowSpan& span = spans[static_cast<std::size_t>(i)];
                   ChainWindow& w = out[before + static_cast<std::size_t>(i)];
                   const ChainTrajectory<double>& run = runs[span.run].data;
                   w.source = span.name;
                   w.start = run.t[span.first];
                   w.end = run.t[span.first + span.count - 1];
                   w.samples = span.count;
                   w.operating_time = run_start[span.run] + span.middle;
                   try {
                     w.identification = identify_chain(
                         model, {run_rows(run, span.first, span.count)}, options.fit);
                   } catch (const std::invalid_argument& e) {
                     throw std::invalid_argument("window " + span.name + ": " + e.what());
                   }
                   // The one member that grows with the window: a month of windows must not keep
                   // them.
                   w.identification.fit.residual = Eigen::VectorXd();
                 });
}

/// The parameters of every window and their drift (see ChainWindows).
inline void fit_window_drifts(const ChainWindowOptions& options, ChainWindows& result);

}  // namespace detail

SID_INLINE ChainWindows identify_chain_windows(const ChainModel& model,
                                               const std::vector<NamedChainRun>& runs,
                                               const ChainWindowOptions& options) {
  return identify_chain_windows(
      model, runs.size(), [&](std::size_t i) { return runs[i]; }, options);
}

SID_INLINE ChainWindows identify_chain_windows(const ChainModel& model, std::size_t runs,
                                               const ChainRunLoader& load,
                                               const ChainWindowOptions& options) {
  if (!(options.drift_z > 0.0 && std::isfinite(options.drift_z)))
    throw std::invalid_argument("sid::identify_chain_windows: drift_z must be finite and > 0");
  if (runs == 0) throw std::invalid_argument("sid::identify_chain_windows: no run given");
  ChainWindows result;
  // As many runs at a time as windows are fitted side by side: the memory held is theirs.
  const auto batch_size = static_cast<std::size_t>(detail::thread_count(options.threads));
  double offset = 0.0;  // the operating time at the next run's start: the same in any batches
  for (std::size_t next = 0; next < runs;) {
    std::vector<NamedChainRun> batch;
    std::vector<double> start;
    for (; batch.size() < batch_size && next < runs; ++next) {
      batch.push_back(load(next));
      const ChainTrajectory<double>& run = batch.back().data;
      start.push_back(offset);
      if (run.size() > 0) offset += run.t[run.size() - 1] - run.t[0];
    }
    detail::identify_windows_of(model, batch, start, options, result.windows);
    if (options.progress) options.progress(next, runs);
  }
  detail::fit_window_drifts(options, result);
  return result;
}

namespace detail {

inline void fit_window_drifts(const ChainWindowOptions& options, ChainWindows& result) {
  // The parameters by their full combination: windows whose data regroup a parameter differently
  // do not determine the same quantity.
  std::map<std::string, Eigen::Index> column_of;
  for (const ChainWindow& w : result.windows)
    for (std::size_t i = 0; i < w.identification.parameter_combinations.size(); ++i) {
      const std::string& key = w.identification.parameter_combinations[i];
      if (!column_of.emplace(key, static_cast<Eigen::Index>(column_of.size())).second) continue;
      ParameterTrend p;
      p.name = w.identification.parameter_names[i];
      p.combination = key;
      result.parameters.push_back(p);
    }
  const auto count = static_cast<Eigen::Index>(result.windows.size());
  const auto columns = static_cast<Eigen::Index>(column_of.size());
  result.value = Eigen::MatrixXd::Constant(count, columns, std::nan(""));
  result.std_dev = result.value;
  for (Eigen::Index k = 0; k < count; ++k) {
    const ChainIdentification& id = result.windows[static_cast<std::size_t>(k)].identification;
    if (!id.fit.ok()) continue;
    for (std::size_t i = 0; i < id.parameter_combinations.size(); ++i) {
      const Eigen::Index c = column_of.at(id.parameter_combinations[i]);
      result.value(k, c) = id.fit.theta[static_cast<Eigen::Index>(i)];
      result.std_dev(k, c) = id.std_dev[static_cast<Eigen::Index>(i)];
    }
  }
  Eigen::VectorXd hours(count);
  for (Eigen::Index k = 0; k < count; ++k)
    hours[k] = result.windows[static_cast<std::size_t>(k)].operating_time / 3600.0;
  for (Eigen::Index c = 0; c < columns; ++c) {
    ParameterTrend& p = result.parameters[static_cast<std::size_t>(c)];
    ParameterTrend fitted =
        fit_drift(hours, result.value.col(c), result.std_dev.col(c), options.drift_z);
    fitted.name = p.name;
    fitted.combination = p.combination;
    p = fitted;
  }
  for (const ChainWindow& w : result.windows)
    if (!w.identification.fit.ok())
      result.warnings.push_back("window " + w.source +
                                " could not be fitted: " + w.identification.fit.message);
  const auto partial = std::count_if(result.parameters.begin(), result.parameters.end(),
                                     [&](const ParameterTrend& p) { return p.windows < count; });
  if (partial > 0)
    result.warnings.push_back(
        std::to_string(partial) + " of " + std::to_string(columns) +
        " parameters are determined by some windows only: the others' motion does not excite "
        "them and their data regroup them with others. Longer windows (or richer motion) give "
        "every window the same parameters.");
}

}  // namespace detail

}  // namespace sid
