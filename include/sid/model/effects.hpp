#pragma once
/// @file
/// @brief A library of physical effects the paper's arm model leaves out, each a model term that is
/// linear in its own parameters: Coulomb and Stribeck friction, torque-sensor and
/// angle-sensor offsets, rotor inertia (armature) and joint springs.
///
/// Every effect is a torque added to the left side of D(q) qdd + C(q, qd) qd + G(q) + friction,
/// written in MEASURED coordinates (what the regressor sees). Two kinds exist:
/// - dynamic effects change the motion (coulomb, stribeck, armature, spring); effectful_arm puts
///   them into the simulated model;
/// - measurement effects change only what is recorded (torque_offset: measured tau = applied tau +
///   b; angle_offset: measured q = true q - delta); effectful_arm returns them separately so that
///   the simulator applies them to its outputs.
///
/// Look-alikes that no data can tell apart (reports must say so):
/// - armature_j1 adds Ia to D11 only, exactly theta1's column: it shows as theta1 drifting;
/// - angle_offset_q1 and a tilt of the base in the plane of motion rotate gravity identically;
/// - torque_offset_jX and a constant load torque on joint X add the same constant.

#include <sid/config.hpp>
#include <sid/model/effect.hpp>
#include <sid/model/model.hpp>
#include <sid/model/terms.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <array>
#include <cmath>
#include <cstdlib>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief Hyper-parameters shared by the effect terms (fixed, not estimated).
/// @brief The smooth stand-in for sign(qd) in the friction terms.
enum class CoulombShape {
  Tanh,  ///< tanh(qd / ε): 99.5 % of the level at |qd| = 3 ε
  /// (2/π) atan(qd / ε): approaches the level slowly (80 % at 3 ε, 94 % at 10 ε), as the
  /// friction of geared drives often does at low speed.
  Atan
};

struct EffectSettings {
  /// epsilon of the sign stand-in tanh(qd / epsilon) (or atan, see coulomb_shape) [rad/s],
  /// finite and > 0. At |qd| = 3 epsilon tanh has reached 99.5 % of Fc.
  double coulomb_epsilon = 0.01;
  CoulombShape coulomb_shape = CoulombShape::Tanh;  ///< of the Coulomb and Stribeck terms
  /// A Coulomb term with a second column |sign(qd)| and parameter "<id>.dFc": the level is
  /// Fc + dFc moving forward and Fc − dFc backward.
  bool coulomb_asymmetric = false;
  /// g used by the angle-offset columns [m/s^2], finite.
  double gravity = kPaperGravity;
  /// vs [rad/s], the Stribeck term's nonlinear parameter, fixed so the term stays linear (a
  /// caller that wants to estimate it searches a grid of settings), finite and > 0.
  double stribeck_velocity = 0.2;
};

namespace detail {

SID_INLINE void check_effect_settings(const EffectSettings& settings, const char* who);

/// @throws std::invalid_argument (message starts with who) for a joint outside 0..kEffectJoints-1.
SID_INLINE void check_effect_joint(Effect effect, const char* who);

/// The smooth sign of the friction terms.
inline double smooth_sign(double v, double epsilon, CoulombShape shape) noexcept {
  constexpr double kTwoOverPi = 0.63661977236758134308;
  return shape == CoulombShape::Tanh ? std::tanh(v / epsilon) : kTwoOverPi * std::atan(v / epsilon);
}

/// exp(-(v / vs)^2), 0 beyond |v / vs| = 40 (where it underflows anyway), so that huge or
/// infinite velocities give 0 instead of a NaN from inf * 0 later on.
SID_INLINE double stribeck_bump(double v, double vs) noexcept;

SID_INLINE std::string format_value(double v);

/// The names of the rigid-body parameters whose gravity (or centripetal) columns an angle offset
/// rotates: theta4, theta5 for q1; theta3, theta5 for q2.
SID_INLINE std::array<const char*, 2> rotated_parameters(Effect angle_offset);

}  // namespace detail

/// @brief Words for reports, e.g. "Coulomb friction on joint 2", "torque sensor offset on joint 1
/// (or a constant load torque on joint 1: indistinguishable)".
SID_INLINE std::string effect_name(Effect effect);

/// @brief The physical cause that no data can tell apart from the effect, e.g. "a constant load
/// torque on joint 1" for torque_offset_j1; empty if there is none.
SID_INLINE std::string effect_look_alike(Effect effect);

/// @brief The effect whose term is part of this effect's term: a Stribeck term holds its joint's
/// Coulomb column, so naming Stribeck friction replaces Coulomb friction on that joint.
SID_INLINE std::optional<Effect> contained_effect(Effect effect);

/// @brief Names of the physical values a user gives and a fit reports, in order: {"Fc"} [N m],
/// {"Fc", "Fs", "vs"} [N m, N m, rad/s], {"b"} [N m], {"delta"} [rad], {"Ia"} [kg m^2],
/// {"k"} [N m/rad].
SID_INLINE std::vector<std::string> effect_value_names(Effect effect);

/// @brief Units of effect_value_names(effect), e.g. {"N m", "N m", "rad/s"} for Stribeck friction.
SID_INLINE std::vector<std::string> effect_value_units(Effect effect);

/// @brief True for effects that change the motion (coulomb, stribeck, armature, spring), false for
/// those that change only the recorded signals (torque and angle offsets).
inline bool is_dynamic_effect(Effect effect) noexcept {
  return effect_kind_info(effect.kind).dynamic;
}

/// @brief Why an effect's physical values (effect_value_names order) are not admissible, e.g.
/// "Fc must be > 0 [N m], got -0.1"; empty if they are. Checks count, finiteness and the
/// descriptor's bounds (Fc > 0, Fs > Fc, vs > 0, Ia > 0, k > 0, |delta| < pi/2, b any).
SID_INLINE std::string admissibility_violation(Effect effect,
                                               const Eigen::Ref<const Eigen::VectorXd>& values);

/// @brief The regression term of an effect, named effect.id(), in measured coordinates, linear in
/// its parameters (row 0 = joint 1, row 1 = joint 2; c = cos, s = sin, g = settings.gravity):
/// - coulomb_jX: tanh(qd_j / epsilon) on joint j's row; parameter "<id>.Fc". With the settings'
///   coulomb_shape Atan, (2/π) atan(qd_j / eps) instead (also for stribeck); with
///   coulomb_asymmetric a second column |tanh(qd_j / eps)|, parameter "<id>.dFc".
/// - stribeck_jX: tanh(qd_j / eps) and exp(-(qd_j / vs)^2) tanh(qd_j / eps) at the settings' vs;
///   parameters "<id>.Fc", "<id>.Fs_minus_Fc".
/// - torque_offset_jX: e_j; "<id>.b".
/// - angle_offset_q1: true q1 = measured q1 + delta turns the gravity columns into
///   cos(delta) (old) + sin(delta) (new) with new columns [g c1; 0] (coefficient theta4 sin delta)
///   and [g c12; g c12] (theta5 sin delta); "<id>.theta4_sin", "<id>.theta5_sin".
/// - angle_offset_q2: new columns d/dq2 of theta3's column, [-s2 (2 qdd1 + qdd2) - c2 (2 qd1 +
///   qd2) qd2; -s2 qdd1 + c2 qd1^2] (theta3 sin delta), and [g c12; g c12] (theta5 sin delta);
///   "<id>.theta3_sin", "<id>.theta5_sin".
///   With these the angle-offset model is exact, not linearised: the old columns' coefficients
///   become theta cos(delta) (sin(a + d) = cos d sin a + sin d cos a).
/// - armature_jX: [qdd1; 0] for j1 (identical to theta1's column), [0; qdd2] for j2; "<id>.Ia".
/// - spring_jX: q_j on joint j's row; "<id>.k".
/// @throws std::invalid_argument for a joint the library does not serve or bad settings.
SID_INLINE Term<double> effect_term(Effect effect, const EffectSettings& settings = {});

/// @brief How the term's coefficients grow with a unit change of the effect's main physical value
/// (Fc, Fs − Fc, b, δ for small δ, Ia, k), given the parameters theta of a model that contains
/// the rigid-body term: used to turn a test's covariance into a detection limit in physical
/// units.
SID_INLINE Eigen::VectorXd effect_signature(Effect effect,
                                            const Eigen::Ref<const Eigen::VectorXd>& theta,
                                            const Model<double>& model);

/// @brief Physical values of a fitted effect and their standard deviations.
struct EffectEstimate {
  Effect effect;
  Eigen::VectorXd value;  ///< in effect_value_names(effect) order
  Eigen::VectorXd std;    ///< standard deviations by the delta method, same order
};

/// @brief Physical values of an effect from a fit of a model that contains the term
/// effect_term(effect), with standard deviations by the delta method from the covariance block.
///
/// - coulomb: Fc; torque_offset: b; armature: Ia; spring: k (the coefficient itself).
/// - stribeck: Fc = a, Fs = a + b (a, b the term's coefficients); vs = settings.stribeck_velocity,
///   the value the term was built with, reported with std 0 because it was not estimated.
/// - angle offsets: the fit gives pairs (c_k, s_k) = r_k (cos delta, sin delta) for the affected
///   parameters (theta4, theta5 for q1; theta3, theta5 for q2; c_k from the "rigid_body" term,
///   s_k from the effect term). delta = atan2(sum c_k s_k, sum c_k^2), the least-squares slope
///   of s on c through the origin turned into an angle: exact for exact data, and for |delta| <
///   pi/2 (cos delta > 0) on the right branch.
/// A rank-deficient fit (NaN covariance) gives NaN standard deviations.
/// @param theta_full the fitted parameters of model; covariance_full their covariance (p x p).
/// @throws std::invalid_argument for a model without the term (or, for angle offsets, without
///         "rigid_body"), or wrongly sized theta/covariance.
SID_INLINE EffectEstimate effect_estimate(Effect effect,
                                          const Eigen::Ref<const Eigen::VectorXd>& theta_full,
                                          const Eigen::Ref<const Eigen::MatrixXd>& covariance_full,
                                          const Model<double>& model,
                                          const EffectSettings& settings = {});

/// @brief A user-given effect with its physical values in effect_value_names(effect) order, e.g.
/// {"stribeck_j1", {0.1, 0.3, 0.2}} (Fc, Fs, vs).
struct EffectSpec {
  Effect effect;
  std::vector<double> values;
};

/// @brief Checks an effect's values as admissibility_violation does.
/// @throws std::invalid_argument (message starts with who) naming the problem.
SID_INLINE void validate_effect(const EffectSpec& spec, const char* who = "sid::validate_effect");

/// @brief Parses "ID:V1,V2,..." such as "coulomb_j2:0.1", "stribeck_j1:0.1,0.3,0.2" (Fc, Fs,
/// vs) or "angle_offset_q1:0.05", and validates it as validate_effect does.
/// @throws std::invalid_argument naming the problem: unknown id (listing the valid ones), missing
///         ':', a value that is not a number, the wrong number of values, a non-finite or
///         inadmissible value.
SID_INLINE EffectSpec parse_effect(const std::string& text);

/// @brief The true arm of a simulation with hidden effects.
struct EffectfulArm {
  /// two_link_arm_model(g) plus one term per dynamic effect (named by its id()).
  Model<double> model;
  /// The parameters of model: theta1..theta7, then each dynamic effect's coefficients (Stribeck:
  /// Fc, Fs - Fc, with its columns built at the spec's vs).
  Eigen::VectorXd theta;
  /// b per joint: measured tau = applied tau + b [N m].
  Vector2<double> torque_offset = Vector2<double>::Zero();
  /// delta per joint: measured q = true q - delta [rad].
  Vector2<double> angle_offset = Vector2<double>::Zero();
};

/// @brief The true-arm model with the dynamic effects (coulomb, stribeck, armature, spring) added
/// as terms and the measurement effects (torque and angle offsets) returned separately.
/// @param theta the arm's theta1..theta7; effects each validated as validate_effect does; the
///        settings give g and epsilon (vs comes from each Stribeck spec).
/// @throws std::invalid_argument for an invalid spec, an effect given twice, non-finite theta or
///         bad settings.
SID_INLINE EffectfulArm effectful_arm(const TwoLinkParameters<double>& theta,
                                      const std::vector<EffectSpec>& effects,
                                      const EffectSettings& settings = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/model/effects-inl.hpp>
#endif
