#pragma once
/// @file
/// @brief The parameters of a chain over time: its logs cut into windows, each identified on its
/// own, and per parameter a trend over the operating time with an honest standard deviation.
///
/// What a fleet's maintainer asks of a month of logs is whether friction (or anything else)
/// drifts. Each window is a run of identify_chain (its own cutoffs, base parameters and HAC
/// standard deviations), so a window's estimate is what the tool gives for that stretch of log
/// alone. Windows are laid end to end on an operating time (the logs in the order given, each
/// starting where the one before ended), and each parameter's estimates are fitted by a line in
/// that time, weighted by 1/std². The line's slope is the drift; its standard deviation is
/// inflated by the Birge ratio √(χ²/(K − 2)) when the windows scatter about the line more than
/// their own deviations allow (a model error that differs from window to window), never
/// deflated by it. A drift is declared only when it survives leaving out any one window: on six
/// real runs of a double pendulum, one run that the model fits badly (51 % residual against
/// 19-25 %) made three parameters look as if they drifted.

#include <sid/config.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>

#include <Eigen/Core>

#include <cmath>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace sid {

namespace detail {

inline ChainIdentifyOptions measured_torque_fit() {
  ChainIdentifyOptions fit;
  fit.filter_torque = false;
  return fit;
}

}  // namespace detail

/// @brief Options of identify_chain_windows.
struct ChainWindowOptions {
  /// [s] The windows' length; 0: each run is one window (one log per day, say). A run's last
  /// piece shorter than half a window joins the window before it; a run shorter than a window
  /// is one window.
  double window = 0.0;
  /// A parameter drifts when its slope exceeds this many of its standard deviations (see
  /// ParameterTrend::drifts).
  double drift_z = 3.0;
  /// Windows identified side by side (0: every core); each window's fit uses fit.threads.
  int threads = 1;
  /// Called from the calling thread as runs are done (runs done, runs in all): a tool's bar.
  std::function<void(std::size_t, std::size_t)> progress;
  /// The fit of each window. Its torque is fitted as measured (filter_torque off): filtered as
  /// its angle, a torque and the regressor's Coulomb column (a near-step in q̇) disagree at
  /// every reversal, which biases Coulomb friction upward (by 0.5 to 2.3 of its std on the
  /// simulated arm of the tests, four logs of 8 s; as measured, within 1.5 either way), and
  /// friction is what a drift table is read for.
  ChainIdentifyOptions fit = detail::measured_torque_fit();
};

/// @brief One window: where it lies and what its identification found.
struct ChainWindow {
  std::string source;  ///< the run it was cut from
  double start = 0.0;  ///< [s] its first sample's time, in the run's own clock
  double end = 0.0;    ///< [s] its last sample's time
  Eigen::Index samples = 0;
  /// [s] Its middle on the operating time (the runs laid end to end from 0).
  double operating_time = 0.0;
  /// The window's identification, without fit.residual (one entry per equation: a month of
  /// windows would hold the month's equations); per_run and fitted hold its RMS.
  ChainIdentification identification;
};

/// @brief One parameter over the windows: a line fitted to its estimates in operating time.
struct ParameterTrend {
  std::string name;                     ///< short name (base_parameter_names with six terms)
  std::string combination;              ///< in full: what identifies the parameter across windows
  int windows = 0;                      ///< windows whose identification determines it
  double mean = std::nan("");           ///< the line's value at the windows' weighted centre
  double slope = std::nan("");          ///< [unit / h] of operating time
  double slope_std_dev = std::nan("");  ///< Birge-inflated (see the file comment)
  double birge_ratio = std::nan("");    ///< √(χ² / (K − 2)); NaN with fewer than 3 windows
  /// |slope| / slope_std_dev beyond ChainWindowOptions::drift_z, with four windows or more, and
  /// still so (same sign) with any one window left out: no single window makes the verdict.
  bool drifts = false;
};

/// @brief What identify_chain_windows found.
struct ChainWindows {
  std::vector<ChainWindow> windows;
  /// Every parameter some window determines, in the order of first appearance (the model's
  /// column order in the first window).
  std::vector<ParameterTrend> parameters;
  /// windows × parameters: each window's estimate and HAC standard deviation, NaN where its
  /// runs leave the parameter undetermined (it regrouped with others).
  Eigen::MatrixXd value;
  Eigen::MatrixXd std_dev;
  /// Windows whose fit failed; parameters that only some windows determine (a window's motion
  /// too short or too poor to excite them, so that its data regroup them differently).
  std::vector<std::string> warnings;
};

/// @brief The samples of runs cut into windows as ChainWindowOptions::window says, named
/// "source [start–end s]" when a run gives several windows and by the run's name otherwise.
/// @throws std::invalid_argument on a negative or non-finite window, an empty run list or a run
///         with fewer than two samples.
SID_INLINE std::vector<NamedChainRun> cut_into_windows(const std::vector<NamedChainRun>& runs,
                                                       double window);

/// @brief A line θ(t) = mean + slope (t − t̄) fitted to estimates with their standard deviations
/// (weights 1/std²) at times [h]; entries with a NaN or non-positive std are left out.
SID_INLINE ParameterTrend fit_drift(const Eigen::VectorXd& hours, const Eigen::VectorXd& value,
                                    const Eigen::VectorXd& std_dev, double drift_z = 3.0);

/// @brief Identifies model on each window of runs and fits each parameter's drift.
/// @throws std::invalid_argument as cut_into_windows, on invalid options (drift_z <= 0), or as
///         identify_chain for a window, naming the window.
SID_INLINE ChainWindows identify_chain_windows(const ChainModel& model,
                                               const std::vector<NamedChainRun>& runs,
                                               const ChainWindowOptions& options = {});

/// @brief Gives run i of a sequence (the library reads no files; the caller's loader does).
using ChainRunLoader = std::function<NamedChainRun(std::size_t)>;

/// @brief The same over `runs` runs that `load` gives in order, as many at a time as windows are
/// fitted side by side (options.threads): memory does not grow with the number of runs, so a
/// month of logs is read one log after another. A loader's exception is passed on.
SID_INLINE ChainWindows identify_chain_windows(const ChainModel& model, std::size_t runs,
                                               const ChainRunLoader& load,
                                               const ChainWindowOptions& options = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/identify_windows-inl.hpp>
#endif
