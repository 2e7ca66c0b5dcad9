#pragma once
/// @file
/// @brief How far a chain's logged torque lags its logged angles, estimated from the logs: the
/// delay at which the model explains the torque best.
///
/// Cheap arms send a servo's position and current over separate paths, so the two channels of a
/// log are a few milliseconds apart. A model fitted with the angles paired with the wrong torque
/// sample misreads the lag as inertia and friction. The torque logged at t is paired with the
/// angles' spline at t − delay (ChainIdentifyOptions::torque_delay), and the delay searched for
/// is the one whose least-squares fit leaves the smallest residual.
///
/// Every joint is smoothed at one cutoff for the search. With a cutoff per joint, the joints'
/// smoothed motions differ from their torques' differently, and the residual's minimum moves:
/// on a simulated SO-101 log with no delay (12-bit encoders), cutoffs of 2 to 16 Hz put it at
/// -1.2 ± 0.08 ms, one shared cutoff of 2.8 Hz at -0.25 ± 0.48 ms.

#include <sid/config.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <limits>
#include <vector>

namespace sid {

/// @brief What estimate_torque_delay searches.
struct TorqueDelaySearch {
  /// [s] The delays tried lie in [-max_delay, max_delay] (negative: the angles lag the torque);
  /// at most the fit's skips, which keep every shifted sample inside the log.
  double max_delay = 0.02;
};

/// @brief The delay found and how sure it is.
struct TorqueDelayEstimate {
  /// [s] The torque lags the angles by this: ChainIdentifyOptions::torque_delay for the fit.
  double delay = 0.0;
  /// [s] Its standard deviation: the delay as one more unknown of the linearised regression,
  /// with the HAC covariance of ChainIdentification::std_dev (the residuals of smoothed logs are
  /// correlated over many samples).
  double std_dev = std::numeric_limits<double>::quiet_NaN();
  /// [Hz] The one cutoff every joint was smoothed at for the search: the first stage of
  /// identify_chain's choice at no delay, unless the options give cutoffs.
  double cutoff_hz = 0.0;
  /// The coarse search: 33 delays evenly over [-max_delay, max_delay] and the fit's mean
  /// squared residual at each [N² m²].
  Eigen::VectorXd delays;
  Eigen::VectorXd mean_square_residual;
  /// The best delay is at the search's edge: the true one may lie beyond max_delay.
  bool at_bound = false;
};

/// @brief Estimates the delay of the runs' torque behind their angles (see the file comment).
/// options as for identify_chain; its torque_delay is ignored, and a cutoff per joint is used as
/// given (one shared cutoff is what the search needs; see the file comment).
/// @throws std::invalid_argument as identify_chain, or when max_delay is not in (0, skips].
SID_INLINE TorqueDelayEstimate estimate_torque_delay(
    const ChainModel& model, const std::vector<ChainTrajectory<double>>& runs,
    const ChainIdentifyOptions& options = {}, const TorqueDelaySearch& search = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/torque_delay-inl.hpp>
#endif
