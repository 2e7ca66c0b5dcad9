#pragma once
/// @file
/// @brief The torque the outside applies at each joint of an identified arm, from a log of its
/// angles and drive torques, and the contacts it makes, as `sid_external` computes them: by the
/// generalized-momentum observer (sid::MomentumObserver: no acceleration; run forwards, then the
/// same first-order lag backwards, which cancels its phase) or by the inverse-dynamics residual
/// on the smoothed accelerations. A joint is in contact where |τ_ext| exceeds a multiple of the
/// larger of the fit's own residual and this estimate's robust spread.

#include <sid/config.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <string>
#include <vector>

namespace sid {

enum class ExternalTorqueMethod {
  MomentumObserver,         ///< rates only; lags a change by about 3/K, undone offline
  InverseDynamicsResidual,  ///< needs accelerations: the fit's cutoffs by default
};

/// @brief Options of estimate_external_torque().
struct ExternalTorqueOptions {
  ExternalTorqueMethod method = ExternalTorqueMethod::MomentumObserver;
  /// The observer's rate K [1/s]; 0: min(300, 1 / (2 dt), 2 pi x the slowest rate cutoff). 300
  /// follows a 20 ms ramp to about 10 % of its height at its corners on a simulated UR5 with
  /// 1e-6 rad of angle noise; a faster one passes more of the rates' noise, and one faster than
  /// the rates' smoothing passes the torque the smoothed momentum no longer explains.
  double gain = 0.0;
  /// The smoothing of the angles before their rates are taken [Hz]: one value or one per joint.
  /// Empty: the fit's cutoffs for the residual; for the observer, those of the GCV spline of the
  /// log's angles (as much of the motion as their noise lets through: the fit's cutoffs are
  /// chosen for accelerations and smooth away a contact's jolt), unless the log is a measured one
  /// (angles on a grid, or GCV leaving them unsmoothed): GCV assumes white angle noise and takes
  /// quantised angles for motion, so such a log takes the fit's cutoffs scaled by the half octave
  /// (1/2 to 4) at which the model best predicts its torque.
  std::vector<double> cutoff_hz;
  bool fit_cutoffs = false;  ///< the fit's cutoffs whatever the method
  /// Contact where |τ_ext| exceeds this many times the larger of the fit's residual RMS on its
  /// own logs (as recorded) and this estimate's robust spread.
  double threshold_factor = 5.0;
  double min_duration = 0.01;  ///< [s]: shorter excursions are noise
  double merge_gap = 0.05;     ///< [s]: contacts closer than this are one
  /// [s] at each end where no contact is looked for: the spline's rates are least sure there.
  double skip = 0.1;
  /// Per joint, what its drive can give [N m or N] (a URDF's `<limit effort>`; NaN: not known;
  /// empty: none known). An excursion beyond it is the model's failure, not a contact.
  Eigen::VectorXd effort_limit;
  /// [s] How far the log's torque lags its angles (the fit's, ChainIdentifyOptions::torque_delay):
  /// each torque is compared with the motion this much earlier, and contacts are looked for
  /// |delay| further from the ends than skip. |delay| at most the skip.
  double torque_delay = 0.0;
};

/// @brief One contact: from the first to the last sample above threshold.
struct ExternalContact {
  double start = 0.0, end = 0.0;  ///< [s]
  std::vector<int> joints;        ///< those above their threshold during it
  Eigen::VectorXd peak;           ///< per joint, the largest |τ_ext| during it, signed
};

/// @brief What estimate_external_torque() found.
struct ExternalTorque {
  Eigen::VectorXd t;
  Eigen::MatrixXd external;    ///< samples x joints [N m or N]
  Eigen::VectorXi contact;     ///< per sample, 1 inside a contact
  Eigen::VectorXd thresholds;  ///< per joint
  Eigen::VectorXd noise;       ///< per joint, the estimate's robust spread (1.4826 MAD)
  std::vector<ExternalContact> contacts;
  /// Excursions above threshold whose estimate exceeds a joint's effort limit: not contacts
  /// but the model's failure (each also a warning).
  std::vector<ExternalContact> beyond_effort;
  double gain = 0.0;                  ///< the observer's K [1/s] (0 for the residual)
  Eigen::VectorXd rate_cutoff_hz;     ///< the angles' smoothing, per joint
  std::string rate_cutoff_choice;     ///< how it was chosen, in words
  std::vector<std::string> warnings;  ///< a spread above twice the fit's residual
};

/// @brief The external torque on run (joint side) under an identified arm.
/// @param theta every parameter of model (the physically consistent fit)
/// @param fit_cutoff_hz the smoothing the fit used, per joint
/// @param fit_residual_rms the fit's residual per joint on its own logs, as recorded [N m]
/// @throws std::invalid_argument naming what is wrong: sizes that are not the model's, invalid
///         options (a gain not > 0, negative durations, skips that leave nothing), a run the
///         smoothing cannot take.
SID_INLINE ExternalTorque estimate_external_torque(const ChainModel& model,
                                                   const Eigen::VectorXd& theta,
                                                   const Eigen::VectorXd& fit_cutoff_hz,
                                                   const Eigen::VectorXd& fit_residual_rms,
                                                   const ChainTrajectory<double>& run,
                                                   const ExternalTorqueOptions& options = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/external_torque-inl.hpp>
#endif
