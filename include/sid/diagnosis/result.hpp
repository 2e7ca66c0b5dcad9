#pragma once
/// @file
/// @brief What the model-discrepancy diagnosis found (sid/diagnose.hpp fills it, the CVODE
/// layer adds the simulations): the data types alone, so that a report or a caller that only
/// reads a result does not compile the diagnosis.

#include <sid/model/effects.hpp>
#include <sid/model/model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <limits>
#include <string>
#include <vector>

namespace sid {

/// @brief A time window in which one joint's residual exceeds the noise.
struct FlaggedWindow {
  int joint = 1;                  ///< 1 or 2
  double t_begin = 0, t_end = 0;  ///< [s]
  double ratio = 0;  ///< window residual RMS / noise floor (torque) or / q noise (simulation)
};

/// @brief How well one model explains the data.
struct ModelReport {
  std::vector<std::string> parameter_names;  ///< the regression parameters of this model
  Eigen::VectorXd theta;                     ///< their estimates
  Eigen::VectorXd std;                       ///< their HAC (Newey–West) standard deviations
  /// Torque residual RMS per joint over the equations the fits kept (DiagnosisResult::kept) [N m].
  Vector2<double> residual_rms = Vector2<double>::Zero();
  /// sqrt(max(0, residual_rms² − noise_floor² − kinematic_floor²)) per joint [N m].
  Vector2<double> excess_rms = Vector2<double>::Zero();
  /// The excess that the sampling noise of residual_rms alone reaches at 2 standard deviations,
  /// floor sqrt(2 sqrt(2 / N)) with N the joint's kept equations [N m]: an excess below it is
  /// indistinguishable from none (about 0.021 N m for σ_τ = 0.1 N m and 3881 samples).
  Vector2<double> excess_resolution = Vector2<double>::Zero();
  /// Free-simulation q error RMS [rad]; filled by the CVODE layer, NaN otherwise.
  Vector2<double> sim_error_rms =
      Vector2<double>::Constant(std::numeric_limits<double>::quiet_NaN());
  std::vector<FlaggedWindow> windows;      ///< torque-residual windows beyond the noise
  std::vector<FlaggedWindow> sim_windows;  ///< filled by the CVODE layer
  Eigen::VectorXd residual;                ///< y − X θ̂, joint 1's samples then joint 2's [N m]
};

/// @brief An effect the diagnosis named.
struct NamedEffect {
  Effect effect;
  std::string name;  ///< effect_name(effect)
  std::vector<std::string> value_names;
  /// Physical values (effect_estimate) from the final fit and their HAC standard deviations
  /// (NaN for a Stribeck vs, which a grid search chose).
  Eigen::VectorXd estimate, std;
  double wald = 0, p_value = 1;  ///< HAC Wald statistic and its Holm-corrected p-value at selection
  double information_drop = 0;   ///< drop of BIC at selection
  double cv_drop = 0;            ///< relative drop of the blocked-CV prediction error
  /// Per joint at selection: RMS of the change it made to the torque prediction / RMS of the
  /// residual before it (DiagnoseOptions::negligible_size).
  Vector2<double> practical_size = Vector2<double>::Zero();
  std::string note;  ///< e.g. the indistinguishability remark
};

/// @brief A candidate that was tried and not named.
struct UnnamedEffect {
  Effect effect;
  std::string name;
  std::string reason;  ///< "not significant", "not admissible: ...", "no CV gain", ...
  /// Smallest |value| of the effect's main physical parameter that the Wald test would have
  /// detected in the final model (Fc, Fs − Fc for stribeck, b, δ, Ia, k) [its unit]; NaN if n/a.
  double detection_limit = std::numeric_limits<double>::quiet_NaN();
};

/// @brief A candidate the data cannot tell apart from the nominal model.
struct NotSeparable {
  Effect effect;
  std::string name;
  std::string explanation;
};

/// @brief A parameter of the final model compared with a reference.
struct ParameterDrift {
  std::string name;
  double reference = 0, estimate = 0, std = 0, z = 0;
  bool significant = false;  ///< |z| > 3
};

/// @brief The output-error test of one joint's friction curve (sid/cvode/friction_refinement.hpp,
/// run by diagnose_with_simulation where friction was named): simulations of the angles around
/// the joint's velocity reversals decide between Coulomb and Stribeck friction.
struct FrictionCheck {
  int joint = 1;  ///< 1 or 2
  Effect named;   ///< what the torque-domain selection named (Coulomb or Stribeck friction)
  Effect chosen;  ///< what the output-error test chose (of the same two)
  /// Likelihood ratio of Stribeck against Coulomb friction (χ² with 2 degrees of freedom under
  /// Coulomb) and its p-value; NaN when the screen made the Stribeck fit unnecessary.
  double statistic = 0, p_value = 1;
  /// The screen before the Stribeck fit: the largest score statistic of a Stribeck bump at the
  /// Coulomb fit over a grid of vs (first-order the likelihood ratio at that vs), and its vs.
  /// NaN where the torque-domain tests named Stribeck friction (fitted without a screen).
  double score = std::numeric_limits<double>::quiet_NaN();
  double score_velocity = std::numeric_limits<double>::quiet_NaN();
  bool stribeck_fitted = false;  ///< false: the score stayed below the screen's level
  Eigen::Index windows = 0;      ///< simulation windows (one per reversal used)
  /// RMS of (measured − simulated q) / σq over the windows for each curve (1 = the noise).
  double normalized_rms_coulomb = std::numeric_limits<double>::quiet_NaN();
  double normalized_rms_stribeck = std::numeric_limits<double>::quiet_NaN();
  std::string message;  ///< empty when both fits went through; otherwise why nothing changed
};

/// @brief Everything diagnose() found.
struct DiagnosisResult {
  Vector2<double> noise_floor = Vector2<double>::Zero();  ///< torque noise σ per joint [N m]
  /// RMS per joint of the torque error the angle noise leaves through the smoothed q̇, q̈
  /// (kinematic_noise_rms; DiagnoseOptions::kinematic_noise_runs) [N m]; 0 when not computed.
  /// Residual excesses and windows are judged against sqrt(noise_floor² + kinematic_floor²).
  Vector2<double> kinematic_floor = Vector2<double>::Zero();
  ModelReport nominal, final;
  std::vector<NamedEffect> effects;  ///< in selection order
  std::vector<NotSeparable> not_separable;
  std::vector<UnnamedEffect> not_named;
  std::vector<ParameterDrift> drift;  ///< empty without reference_theta
  /// One per joint with named friction, filled by diagnose_with_simulation (empty otherwise).
  std::vector<FrictionCheck> friction_checks;
  Kinematics<double> kinematics;  ///< the smoothed samples the fits used
  /// Per equation (joint 1's samples, then joint 2's): 1 if the fits used it, 0 if that joint was
  /// at rest there (DiagnoseOptions::rest_velocity).
  Eigen::VectorXd kept;
  Model<double> final_model;  ///< two_link_arm_model + named effect terms
  Model<double> nominal_model;
  /// The settings the final model's effect terms were built with, per named effect (stribeck
  /// at its chosen vs), in final_model's term order after rigid_body and viscous_friction.
  std::vector<EffectSettings> final_settings;
  double seconds = 0;  ///< wall time of diagnose()
};

}  // namespace sid
