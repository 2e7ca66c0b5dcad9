#pragma once
// Definitions of sid/cvode/friction_refinement.hpp (see sid/config.hpp).

#include <sid/cvode/friction_refinement.hpp>

namespace sid {

namespace detail {

SID_INLINE std::vector<OutputErrorWindow> reversal_windows(const Kinematics<double>& k, int joint,
                                                           const FrictionRefinementOptions& o) {
  const Eigen::Index n = k.size();
  const double* t = k.t.data();
  std::vector<std::pair<double, double>> events;  // first and last sign change
  for (Eigen::Index i = 1; i < n; ++i) {
    if ((k.qd(i - 1, joint) > 0.0) == (k.qd(i, joint) > 0.0)) continue;
    if (!events.empty() && t[i] - events.back().second < o.before)
      events.back().second = t[i];
    else
      events.emplace_back(t[i], t[i]);
  }
  std::vector<OutputErrorWindow> all;
  for (const auto& [first, last] : events) {
    const Eigen::Index previous_end = all.empty() ? 0 : all.back().end;
    const Eigen::Index begin =
        std::max<Eigen::Index>(std::lower_bound(t, t + n, first - o.before) - t, previous_end);
    const Eigen::Index end = std::lower_bound(t, t + n, std::min(t[n - 1], last + o.after)) - t;
    if (begin >= n || end <= begin || t[end - 1] - t[begin] < o.min_window) continue;
    OutputErrorWindow w;
    w.begin = begin;
    w.end = end;
    w.q0 = k.q.row(begin).transpose();
    w.qd0 = k.qd.row(begin).transpose();
    all.push_back(w);
  }
  const auto count = static_cast<std::size_t>(std::max(0, o.max_windows));
  if (all.size() <= count) return all;
  std::vector<OutputErrorWindow> spread;
  for (std::size_t i = 0; i < count; ++i) spread.push_back(all[i * all.size() / count]);
  return spread;
}

SID_INLINE bool names_friction_of(const DiagnosisResult& result, int joint) {
  const Effect coulomb{EffectKind::Coulomb, joint - 1}, stribeck{EffectKind::Stribeck, joint - 1};
  return std::any_of(result.effects.begin(), result.effects.end(),
                     [&](const auto& e) { return e.effect == coulomb || e.effect == stribeck; });
}

/// The friction effect of one joint that a diagnosis named.
struct NamedFriction {
  int joint = 1;
  std::string j;  ///< the joint as written in messages
  Effect coulomb, stribeck;
  std::size_t index = 0;  ///< in result.effects and result.final_settings
};

/// Checks that refine_friction can test `joint` of `result` and finds its named friction.
SID_INLINE NamedFriction find_named_friction(const DiagnosisResult& result, int joint,
                                             const std::string& who) {
  if (joint != 1 && joint != 2) throw std::invalid_argument(who + "joint must be 1 or 2");
  NamedFriction named;
  named.joint = joint;
  named.j = std::to_string(joint);
  named.coulomb = {EffectKind::Coulomb, joint - 1};
  named.stribeck = {EffectKind::Stribeck, joint - 1};
  named.index = result.effects.size();
  for (std::size_t i = 0; i < result.effects.size(); ++i)
    if (result.effects[i].effect == named.coulomb || result.effects[i].effect == named.stribeck)
      named.index = i;
  if (named.index == result.effects.size())
    throw std::invalid_argument(who + "the diagnosis names no friction of joint " + named.j);
  if (result.effects.size() != result.final_settings.size())
    throw std::invalid_argument(who + "result.effects and result.final_settings differ in size");
  return named;
}

/// Index of the diagnosis's first sample k.t[0] in `data`, checked to hold all of k's samples.
SID_INLINE Eigen::Index first_diagnosed_sample(const Kinematics<double>& k,
                                               const Trajectory<double>& data,
                                               const std::string& who) {
  const Eigen::Index n = k.size();
  const double* td = data.t.data();
  const Eigen::Index first = std::lower_bound(td, td + data.size(), k.t[0]) - td;
  if (first + n > data.size() ||
      std::fabs(data.t[first] - k.t[0]) > 1e-9 * (1.0 + std::fabs(k.t[0])) ||
      std::fabs(data.t[first + n - 1] - k.t[n - 1]) > 1e-9 * (1.0 + std::fabs(k.t[n - 1])))
    throw std::invalid_argument(who + "data does not hold the samples the diagnosis used");
  return first;
}

/// The output-error problem both curves share: the measured angles of the diagnosed samples,
/// driven by the GCV-smoothed measured torque, over the windows around the joint's reversals.
SID_INLINE OutputErrorProblem reversal_problem(const Kinematics<double>& k,
                                               const Trajectory<double>& data, Eigen::Index first,
                                               int joint,
                                               const FrictionRefinementOptions& options) {
  const Eigen::Index n = k.size();
  OutputErrorProblem problem;
  problem.t = k.t;
  problem.q_measured = data.q.middleRows(first, n);
  problem.tau.resize(n, 2);
  const SmoothingSpline<double> spline(k.t);
  for (int c = 0; c < 2; ++c) {
    const Eigen::VectorXd tau = data.tau.col(c).segment(first, n);
    problem.tau.col(c) = spline.fit_cross_validated(tau, 1.0, SmoothingCriterion::Gcv)
                             .spline.derivatives_at_knots(0);
    problem.sigma_q[c] = noise_sigma_gcv(k.t, problem.q_measured.col(c));
  }
  problem.windows = reversal_windows(k, joint - 1, options);
  return problem;
}

/// Where the named friction's coefficients sit in the diagnosis's final θ. Parameter layouts of
/// the two models: the nominal model's, then each named effect's coefficients; the friction's
/// are Fc, then the bump Fs − Fc in the Stribeck model only.
struct FrictionLayout {
  NamedFriction named;
  bool named_stribeck = false;  ///< the diagnosis named the Stribeck curve
  Eigen::Index offset = 0;      ///< index of Fc
  Eigen::Index viscous = 0;     ///< index of the joint's viscous coefficient
  Eigen::Index tail = 0;        ///< coefficients after the friction's
  double named_velocity = 0;    ///< the diagnosis's Stribeck velocity setting
};

SID_INLINE FrictionLayout friction_layout(const DiagnosisResult& result, NamedFriction named) {
  FrictionLayout l;
  l.named = std::move(named);
  const Effect named_effect = result.effects[l.named.index].effect;
  l.offset = result.final_model.parameter_offset(named_effect.id());
  l.viscous = result.final_model.parameter_offset("viscous_friction") + (l.named.joint - 1);
  l.named_stribeck = named_effect == l.named.stribeck;
  l.tail = result.final.theta.size() - l.offset - (l.named_stribeck ? 2 : 1);
  l.named_velocity = result.final_settings[l.named.index].stribeck_velocity;
  return l;
}

/// The diagnosis's final model with the named friction replaced by `friction_id` at Stribeck
/// velocity `vs`.
SID_INLINE Model<double> model_with_friction(const DiagnosisResult& result, const FrictionLayout& l,
                                             double gravity, Effect friction, double vs) {
  Model<double> model = two_link_arm_model<double>(gravity);
  for (std::size_t i = 0; i < result.effects.size(); ++i) {
    EffectSettings s = result.final_settings[i];
    if (i == l.named.index) s.stribeck_velocity = vs;
    model.add(effect_term(i == l.named.index ? friction : result.effects[i].effect, s));
  }
  return model;
}

/// Every parameter but the joint's viscous term and the first `free_count` friction
/// coefficients.
SID_INLINE std::vector<Eigen::Index> fixed_but_friction(const FrictionLayout& l,
                                                        Eigen::Index free_count,
                                                        Eigen::Index size) {
  std::vector<Eigen::Index> fixed;
  for (Eigen::Index u = 0; u < size; ++u) {
    const bool viscous = u == l.viscous;
    const bool friction_term = u >= l.offset && u < l.offset + free_count;
    if (!viscous && !friction_term) fixed.push_back(u);
  }
  return fixed;
}

// Priors from the torque-domain fit on θ1..θ7 (only the joint's viscous term is free: the
// prior keeps it near what the whole record says) and, with prior_on_coulomb_level, on Fc,
// which the sliding away from the reversals fixes better than the windows.
SID_INLINE void set_torque_domain_priors(OutputErrorProblem& pb, const DiagnosisResult& result,
                                         const FrictionLayout& l,
                                         const FrictionRefinementOptions& options) {
  pb.prior_mean = pb.theta0;
  pb.prior_std =
      Eigen::VectorXd::Constant(pb.theta0.size(), std::numeric_limits<double>::infinity());
  const Eigen::Index nominal = result.nominal_model.num_parameters();
  pb.prior_std.head(nominal) = result.final.std.head(nominal).cwiseMax(1e-12);
  if (options.prior_on_coulomb_level)
    pb.prior_std[l.offset] = std::max(result.final.std[l.offset], 1e-12);
}

/// The Coulomb curve's problem, started from the diagnosis's final fit (its bump dropped).
/// `l` must outlive it: its model refers to it.
SID_INLINE OutputErrorProblem coulomb_problem(const OutputErrorProblem& problem,
                                              const DiagnosisResult& result,
                                              const FrictionLayout& l,
                                              const FrictionRefinementOptions& options) {
  const Eigen::VectorXd& theta = result.final.theta;
  OutputErrorProblem coulomb = problem;
  coulomb.model_at = [&result, &l, gravity = options.gravity](double) {
    return model_with_friction(result, l, gravity, l.named.coulomb, l.named_velocity);
  };
  coulomb.theta0.resize(theta.size() - (l.named_stribeck ? 1 : 0));
  coulomb.theta0 << theta.head(l.offset + 1), theta.tail(l.tail);
  coulomb.fixed_parameters = fixed_but_friction(l, 1, coulomb.theta0.size());
  set_torque_domain_priors(coulomb, result, l, options);
  return coulomb;
}

/// The Stribeck curve's problem (vs estimated), started from the diagnosis's final fit.
/// `l` must outlive it: its model refers to it.
SID_INLINE OutputErrorProblem stribeck_problem(const OutputErrorProblem& problem,
                                               const DiagnosisResult& result,
                                               const FrictionLayout& l,
                                               const FrictionRefinementOptions& options) {
  const Eigen::VectorXd& theta = result.final.theta;
  const double fc = theta[l.offset];
  const double bump = l.named_stribeck ? theta[l.offset + 1] : 0.0;
  OutputErrorProblem stribeck = problem;
  stribeck.model_at = [&result, &l, gravity = options.gravity](double vs) {
    return model_with_friction(result, l, gravity, l.named.stribeck, vs);
  };
  stribeck.estimate_nonlinear = true;
  stribeck.theta0.resize(theta.size() - (l.named_stribeck ? 1 : 0) + 1);
  // From Coulomb, start with a bump as large as Fc: at a zero bump vs has no gradient.
  stribeck.theta0 << theta.head(l.offset + 1),
      l.named_stribeck && bump > 0.0 ? bump : std::max(std::fabs(fc), 1e-3), theta.tail(l.tail);
  stribeck.s_min = 0.5 * options.min_velocity;
  stribeck.s_max = 2.0 * options.max_velocity;
  stribeck.s0 = std::clamp(l.named_stribeck ? l.named_velocity : options.start_velocity,
                           stribeck.s_min, stribeck.s_max);
  stribeck.fixed_parameters = fixed_but_friction(l, 2, stribeck.theta0.size());
  set_torque_domain_priors(stribeck, result, l, options);
  return stribeck;
}

/// RMS of the angle errors in units of the noise; NaN without residuals.
SID_INLINE double normalized_rms(const OutputErrorFit& f) {
  return f.residuals > 0 ? std::sqrt(f.data_cost / static_cast<double>(f.residuals))
                         : std::numeric_limits<double>::quiet_NaN();
}

/// Fits the Stribeck curve into out.stribeck; false (with out.check.message) if it failed.
SID_INLINE bool fit_stribeck_curve(const OutputErrorProblem& stribeck,
                                   const OutputErrorOptions& fit_options, FrictionRefinement& out) {
  out.stribeck = fit_output_error(stribeck, fit_options);
  out.check.stribeck_fitted = true;
  out.check.normalized_rms_stribeck = normalized_rms(out.stribeck);
  if (!out.stribeck.ok()) out.check.message = "a simulation failed: " + out.stribeck.message;
  return out.stribeck.ok();
}

/// Fits the Coulomb curve into out.coulomb; false (with out.check.message) if it failed.
SID_INLINE bool fit_coulomb_curve(const OutputErrorProblem& coulomb,
                                  const OutputErrorOptions& fit_options, FrictionRefinement& out) {
  out.coulomb = fit_output_error(coulomb, fit_options);
  out.check.normalized_rms_coulomb = normalized_rms(out.coulomb);
  if (!out.coulomb.ok()) out.check.message = "a simulation failed: " + out.coulomb.message;
  return out.coulomb.ok();
}

/// Fc (at index a of the fits' θ) from the Coulomb fit, as the estimate.
SID_INLINE void take_coulomb_estimate(FrictionRefinement& out, Eigen::Index a) {
  out.estimate = Eigen::VectorXd::Constant(1, out.coulomb.theta[a]);
  out.std = Eigen::VectorXd::Constant(1, std::sqrt(std::max(0.0, out.coulomb.covariance(a, a))));
}

/// Fc, Fs = Fc + bump and vs (Fc at index a of the fits' θ) from the Stribeck fit, as the
/// estimate.
SID_INLINE void take_stribeck_estimate(FrictionRefinement& out, Eigen::Index a) {
  const double fitted_fc = out.stribeck.theta[a], fitted_bump = out.stribeck.theta[a + 1];
  const double vs = out.stribeck.s;
  const Eigen::MatrixXd& c = out.stribeck.covariance;
  const Eigen::Index s = out.stribeck.theta.size();
  out.estimate = Eigen::Vector3d(fitted_fc, fitted_fc + fitted_bump, vs);
  out.std = Eigen::Vector3d(std::sqrt(std::max(0.0, c(a, a))),
                            std::sqrt(std::max(0.0, c(a, a) + c(a + 1, a + 1) + 2.0 * c(a, a + 1))),
                            std::sqrt(std::max(0.0, c(s, s))));
}

/// Where the diagnosis named Stribeck: fits the Stribeck curve, then the Coulomb one from it.
/// False if a fit failed.
SID_INLINE bool fit_stribeck_then_coulomb(OutputErrorProblem& coulomb,
                                          const OutputErrorProblem& stribeck,
                                          const FrictionLayout& l,
                                          const FrictionRefinementOptions& options,
                                          FrictionRefinement& out) {
  const Eigen::Index a = l.offset;
  // The torque-domain tests saw a bump: fit it first, so that the Coulomb fit, which then
  // misfits, need only fix the likelihood ratio to a percent (comparison_cost).
  if (!fit_stribeck_curve(stribeck, options.fit, out)) return false;
  OutputErrorOptions against = options.fit;
  against.comparison_cost = out.stribeck.cost;
  // Start from the Stribeck fit with the bump dropped and the rest re-adjusted to first
  // order: with the bump merely dropped the fit began at 50 times its final cost. A fit whose
  // last Jacobian failed has no normal matrix to do that with: its windows are still a start.
  if (out.stribeck.normal.size() > 0) {
    const OutputErrorStart start = nested_start(out.stribeck, {a + 1}, Eigen::VectorXd::Zero(1));
    coulomb.theta0 << start.theta.head(a + 1), start.theta.tail(l.tail);
    coulomb.windows = start.windows;
  } else {
    coulomb.windows = out.stribeck.windows;
  }
  return fit_coulomb_curve(coulomb, against, out);
}

/// The screen: whether the score test of a bump added to the Coulomb fit (parameters with a
/// zero bump after Fc) stays below options.screen_level at every screened vs, so that the
/// Stribeck fit is not needed. Sets out.check.score and score_velocity.
SID_INLINE bool bump_screened_out(const OutputErrorProblem& coulomb, const DiagnosisResult& result,
                                  const FrictionLayout& l, const FrictionRefinementOptions& options,
                                  FrictionRefinement& out) {
  if (options.screen_velocities.empty()) return false;
  const Eigen::Index a = l.offset;
  FrictionCheck& check = out.check;
  Eigen::VectorXd with_bump(out.coulomb.theta.size() + 1);
  with_bump << out.coulomb.theta.head(a + 1), 0.0,
      out.coulomb.theta.tail(out.coulomb.theta.size() - a - 1);
  const double step = std::max(0.05 * std::fabs(out.coulomb.theta[a]), 1e-3);
  check.score = 0.0;
  for (double vs : options.screen_velocities) {
    const OutputErrorScore score = output_error_score_test(
        coulomb, out.coulomb, model_with_friction(result, l, options.gravity, l.named.stribeck, vs),
        with_bump, a + 1, step, options.fit);
    if (!score.ok()) return false;  // cannot screen: fit
    if (score.direction > 0.0 && score.statistic > check.score) {
      check.score = score.statistic;
      check.score_velocity = vs;
    }
  }
  return check.score < options.screen_level;
}

/// Where the diagnosis named Coulomb: fits the Coulomb curve and, unless the screen finds no
/// bump, the Stribeck one. True if both were fitted; false if a fit failed or the screen kept
/// Coulomb, which then is out's final answer.
SID_INLINE bool fit_coulomb_then_screened_stribeck(
    const OutputErrorProblem& coulomb, OutputErrorProblem& stribeck, const DiagnosisResult& result,
    const FrictionLayout& l, const FrictionRefinementOptions& options, FrictionRefinement& out) {
  if (!fit_coulomb_curve(coulomb, options.fit, out)) return false;
  if (bump_screened_out(coulomb, result, l, options, out)) {
    out.check.chosen = l.named.coulomb;
    out.check.statistic = out.check.p_value = std::numeric_limits<double>::quiet_NaN();
    out.completed = true;
    take_coulomb_estimate(out, l.offset);
    return false;
  }
  if (std::isfinite(out.check.score_velocity))
    stribeck.s0 = std::clamp(out.check.score_velocity, stribeck.s_min, stribeck.s_max);
  return fit_stribeck_curve(stribeck, options.fit, out);
}

/// Chooses between the two fitted curves: Stribeck if the likelihood ratio passes the test at
/// options.alpha and its fitted values are admissible.
SID_INLINE void choose_by_likelihood_ratio(const FrictionLayout& l,
                                           const FrictionRefinementOptions& options,
                                           FrictionRefinement& out) {
  FrictionCheck& check = out.check;
  // Likelihood ratio with the noise level the Stribeck fit implies (never below the estimate).
  const double dof = std::max<double>(
      1.0, static_cast<double>(out.stribeck.residuals - out.stribeck.free_unknowns));
  const double scale = std::max(1.0, out.stribeck.data_cost / dof);
  check.statistic = (out.coulomb.cost - out.stribeck.cost) / scale;
  check.p_value = chi_square_tail(std::max(0.0, check.statistic), 2.0);
  const double fitted_fc = out.stribeck.theta[l.offset];
  const double fitted_bump = out.stribeck.theta[l.offset + 1];
  const double vs = out.stribeck.s;
  const bool admissible = fitted_fc > 0.0 && fitted_bump > 0.0 && vs >= options.min_velocity &&
                          vs <= options.max_velocity;
  check.chosen = check.p_value < options.alpha && admissible ? l.named.stribeck : l.named.coulomb;
}

}  // namespace detail

SID_INLINE FrictionRefinement refine_friction(const DiagnosisResult& result,
                                              const Trajectory<double>& data, int joint,
                                              const FrictionRefinementOptions& options) {
  const std::string who = "sid::refine_friction: ";
  detail::NamedFriction named = detail::find_named_friction(result, joint, who);
  const Kinematics<double>& k = result.kinematics;
  const Eigen::Index first = detail::first_diagnosed_sample(k, data, who);

  FrictionRefinement out;
  FrictionCheck& check = out.check;
  check.joint = joint;
  check.named = result.effects[named.index].effect;
  check.chosen = check.named;

  const OutputErrorProblem problem = detail::reversal_problem(k, data, first, joint, options);
  check.windows = static_cast<Eigen::Index>(problem.windows.size());
  if (problem.windows.empty()) {
    check.message = "joint " + named.j + " has no velocity reversal to simulate around";
    return out;
  }
  const detail::FrictionLayout layout = detail::friction_layout(result, std::move(named));
  OutputErrorProblem coulomb = detail::coulomb_problem(problem, result, layout, options);
  OutputErrorProblem stribeck = detail::stribeck_problem(problem, result, layout, options);
  const bool both_fitted =
      layout.named_stribeck
          ? detail::fit_stribeck_then_coulomb(coulomb, stribeck, layout, options, out)
          : detail::fit_coulomb_then_screened_stribeck(coulomb, stribeck, result, layout, options,
                                                       out);
  if (!both_fitted) return out;
  detail::choose_by_likelihood_ratio(layout, options, out);
  if (layout.named_stribeck && check.chosen == layout.named.coulomb) {
    // Its values are now the answer: take the Coulomb fit to its minimum, from where it stopped.
    coulomb.theta0 = out.coulomb.theta;
    coulomb.windows = out.coulomb.windows;
    if (!detail::fit_coulomb_curve(coulomb, options.fit, out)) return out;
  }
  out.completed = true;
  if (check.chosen == layout.named.stribeck)
    detail::take_stribeck_estimate(out, layout.offset);
  else
    detail::take_coulomb_estimate(out, layout.offset);
  return out;
}

SID_INLINE DiagnosisResult refine_named_friction(DiagnosisResult result,
                                                 const Trajectory<double>& data,
                                                 const DiagnoseOptions& options,
                                                 FrictionRefinementOptions friction) {
  friction.gravity = options.identify.gravity;
  std::vector<FrictionRefinement> refinements;
  for (int joint = 1; joint <= 2; ++joint)
    if (detail::names_friction_of(result, joint))
      refinements.push_back(refine_friction(result, data, joint, friction));
  bool changed = false;
  for (const auto& r : refinements) {
    result.friction_checks.push_back(r.check);
    if (!r.ok()) continue;
    for (std::size_t i = 0; i < result.effects.size(); ++i) {
      if (result.effects[i].effect != r.check.named) continue;
      if (r.check.chosen != r.check.named) {
        result.effects[i].effect = r.check.chosen;
        result.effects[i].name = effect_name(r.check.chosen);
        result.effects[i].value_names = effect_value_names(r.check.chosen);
        changed = true;
      }
      if (r.check.chosen.kind == EffectKind::Stribeck) {
        result.final_settings[i].stribeck_velocity = r.estimate[2];
        changed = true;
      }
    }
  }
  if (changed) result = refit_final_model(std::move(result), options);
  for (const auto& r : refinements) {
    if (!r.ok()) continue;
    for (auto& e : result.effects) {
      if (e.effect != r.check.chosen) continue;
      const std::string test =
          r.check.stribeck_fitted
              ? "output-error test around the joint's reversals: likelihood ratio " +
                    detail::format_value(r.check.statistic) +
                    " (p = " + detail::format_value(r.check.p_value) +
                    ") for Stribeck against Coulomb"
              : "output-error test around the joint's reversals: no Stribeck bump would lower the "
                "angle "
                "error beyond the noise (largest score statistic " +
                    detail::format_value(r.check.score) + " over vs " +
                    detail::format_value(friction.screen_velocities.front()) + "-" +
                    detail::format_value(friction.screen_velocities.back()) + " rad/s, below " +
                    detail::format_value(friction.screen_level) + ")";
      if (e.effect.kind == EffectKind::Stribeck) {
        e.estimate = r.estimate;
        e.std = r.std;
        e.note =
            "Fc, Fs, vs fitted to the measured angles by the " + test +
            (r.check.named == r.check.chosen ? ""
                                             : "; the torque-domain tests named Coulomb friction");
      } else {
        e.note =
            "Coulomb, not Stribeck, by the " + test +
            (r.check.named == r.check.chosen ? ""
                                             : "; the torque-domain tests named Stribeck friction");
      }
    }
  }
  return result;
}

}  // namespace sid
