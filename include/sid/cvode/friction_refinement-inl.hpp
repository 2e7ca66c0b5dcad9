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
  const std::string j = std::to_string(joint);
  return std::any_of(result.effects.begin(), result.effects.end(), [&](const auto& e) {
    return e.id == "coulomb_j" + j || e.id == "stribeck_j" + j;
  });
}

}  // namespace detail

SID_INLINE FrictionRefinement refine_friction(const DiagnosisResult& result,
                                              const Trajectory<double>& data, int joint,
                                              const FrictionRefinementOptions& options) {
  const std::string who = "sid::refine_friction: ";
  if (joint != 1 && joint != 2) throw std::invalid_argument(who + "joint must be 1 or 2");
  const std::string j = std::to_string(joint);
  const std::string coulomb_id = "coulomb_j" + j, stribeck_id = "stribeck_j" + j;
  std::size_t friction = result.effects.size();
  for (std::size_t i = 0; i < result.effects.size(); ++i)
    if (result.effects[i].id == coulomb_id || result.effects[i].id == stribeck_id) friction = i;
  if (friction == result.effects.size())
    throw std::invalid_argument(who + "the diagnosis names no friction of joint " + j);
  if (result.effects.size() != result.final_settings.size())
    throw std::invalid_argument(who + "result.effects and result.final_settings differ in size");

  const Kinematics<double>& k = result.kinematics;
  const Eigen::Index n = k.size();
  const double* td = data.t.data();
  const Eigen::Index first = std::lower_bound(td, td + data.size(), k.t[0]) - td;
  if (first + n > data.size() ||
      std::fabs(data.t[first] - k.t[0]) > 1e-9 * (1.0 + std::fabs(k.t[0])) ||
      std::fabs(data.t[first + n - 1] - k.t[n - 1]) > 1e-9 * (1.0 + std::fabs(k.t[n - 1])))
    throw std::invalid_argument(who + "data does not hold the samples the diagnosis used");

  FrictionRefinement out;
  FrictionCheck& check = out.check;
  check.joint = joint;
  check.named = result.effects[friction].id;
  check.chosen = check.named;

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
  problem.windows = detail::reversal_windows(k, joint - 1, options);
  check.windows = static_cast<Eigen::Index>(problem.windows.size());
  if (problem.windows.empty()) {
    check.message = "joint " + j + " has no velocity reversal to simulate around";
    return out;
  }
  // Parameter layouts of the two models: θ1..θ7, then each named effect's coefficients.
  std::vector<std::string> ids;
  for (const auto& e : result.effects) ids.push_back(e.id);
  Eigen::Index friction_offset = 7;
  for (std::size_t i = 0; i < friction; ++i)
    friction_offset += effect_term(ids[i], result.final_settings[i]).size();
  const Eigen::VectorXd& theta = result.final.theta;
  const bool named_stribeck = check.named == stribeck_id;
  const Eigen::Index tail = theta.size() - friction_offset - (named_stribeck ? 2 : 1);
  const double fc = theta[friction_offset];
  const double bump = named_stribeck ? theta[friction_offset + 1] : 0.0;
  const double named_velocity = result.final_settings[friction].stribeck_velocity;

  const auto model_with = [&](const std::string& friction_id, double vs) {
    Model<double> model = two_link_arm_model<double>(options.gravity);
    for (std::size_t i = 0; i < ids.size(); ++i) {
      EffectSettings s = result.final_settings[i];
      if (i == friction) s.stribeck_velocity = vs;
      model.add(effect_term(i == friction ? friction_id : ids[i], s));
    }
    return model;
  };
  const auto fixed_except = [&](Eigen::Index free_count, Eigen::Index size) {
    std::vector<Eigen::Index> fixed;
    for (Eigen::Index u = 0; u < size; ++u) {
      const bool viscous = u == 4 + joint;  // θ6 (joint 1) or θ7 (joint 2)
      const bool friction_term = u >= friction_offset && u < friction_offset + free_count;
      if (!viscous && !friction_term) fixed.push_back(u);
    }
    return fixed;
  };

  // Priors from the torque-domain fit on θ1..θ7 (only the joint's viscous term is free: the
  // prior keeps it near what the whole record says) and, with prior_on_coulomb_level, on Fc,
  // which the sliding away from the reversals fixes better than the windows.
  const auto priors = [&](OutputErrorProblem& pb) {
    pb.prior_mean = pb.theta0;
    pb.prior_std =
        Eigen::VectorXd::Constant(pb.theta0.size(), std::numeric_limits<double>::infinity());
    pb.prior_std.head(7) = result.final.std.head(7).cwiseMax(1e-12);
    if (options.prior_on_coulomb_level)
      pb.prior_std[friction_offset] = std::max(result.final.std[friction_offset], 1e-12);
  };
  OutputErrorProblem coulomb = problem;
  coulomb.model_at = [&](double) { return model_with(coulomb_id, named_velocity); };
  coulomb.theta0.resize(theta.size() - (named_stribeck ? 1 : 0));
  coulomb.theta0 << theta.head(friction_offset + 1), theta.tail(tail);
  coulomb.fixed_parameters = fixed_except(1, coulomb.theta0.size());
  priors(coulomb);

  OutputErrorProblem stribeck = problem;
  stribeck.model_at = [&](double vs) { return model_with(stribeck_id, vs); };
  stribeck.estimate_nonlinear = true;
  stribeck.theta0.resize(coulomb.theta0.size() + 1);
  // From Coulomb, start with a bump as large as Fc: at a zero bump vs has no gradient.
  stribeck.theta0 << theta.head(friction_offset + 1),
      named_stribeck && bump > 0.0 ? bump : std::max(std::fabs(fc), 1e-3), theta.tail(tail);
  stribeck.s_min = 0.5 * options.min_velocity;
  stribeck.s_max = 2.0 * options.max_velocity;
  stribeck.s0 = std::clamp(named_stribeck ? named_velocity : options.start_velocity, stribeck.s_min,
                           stribeck.s_max);
  stribeck.fixed_parameters = fixed_except(2, stribeck.theta0.size());
  priors(stribeck);
  const auto normalized_rms = [](const OutputErrorFit& f) {
    return f.residuals > 0 ? std::sqrt(f.data_cost / static_cast<double>(f.residuals))
                           : std::numeric_limits<double>::quiet_NaN();
  };
  const Eigen::Index a = friction_offset;
  const auto fit_stribeck = [&] {
    out.stribeck = fit_output_error(stribeck, options.fit);
    check.stribeck_fitted = true;
    check.normalized_rms_stribeck = normalized_rms(out.stribeck);
    if (!out.stribeck.ok) check.message = "a simulation failed: " + out.stribeck.message;
    return out.stribeck.ok;
  };
  const auto fit_coulomb = [&](const OutputErrorOptions& fit_options) {
    out.coulomb = fit_output_error(coulomb, fit_options);
    check.normalized_rms_coulomb = normalized_rms(out.coulomb);
    if (!out.coulomb.ok) check.message = "a simulation failed: " + out.coulomb.message;
    return out.coulomb.ok;
  };
  const auto take_coulomb_estimate = [&] {
    out.estimate = Eigen::VectorXd::Constant(1, out.coulomb.theta[a]);
    out.std = Eigen::VectorXd::Constant(1, std::sqrt(std::max(0.0, out.coulomb.covariance(a, a))));
  };
  if (named_stribeck) {
    // The torque-domain tests saw a bump: fit it first, so that the Coulomb fit, which then
    // misfits, need only fix the likelihood ratio to a percent (comparison_cost).
    if (!fit_stribeck()) return out;
    OutputErrorOptions against = options.fit;
    against.comparison_cost = out.stribeck.cost;
    // Start from the Stribeck fit with the bump dropped and the rest re-adjusted to first
    // order: with the bump merely dropped the fit began at 50 times its final cost. A fit whose
    // last Jacobian failed has no normal matrix to do that with: its windows are still a start.
    if (out.stribeck.normal.size() > 0) {
      const OutputErrorStart start = nested_start(out.stribeck, {a + 1}, Eigen::VectorXd::Zero(1));
      coulomb.theta0 << start.theta.head(a + 1), start.theta.tail(tail);
      coulomb.windows = start.windows;
    } else {
      coulomb.windows = out.stribeck.windows;
    }
    if (!fit_coulomb(against)) return out;
  } else {
    if (!fit_coulomb(options.fit)) return out;
    // The screen: a bump added to the Coulomb fit (parameters with a zero bump after Fc).
    bool screened_out = !options.screen_velocities.empty();
    if (screened_out) {
      Eigen::VectorXd with_bump(out.coulomb.theta.size() + 1);
      with_bump << out.coulomb.theta.head(a + 1), 0.0,
          out.coulomb.theta.tail(out.coulomb.theta.size() - a - 1);
      const double step = std::max(0.05 * std::fabs(out.coulomb.theta[a]), 1e-3);
      check.score = 0.0;
      for (double vs : options.screen_velocities) {
        const OutputErrorScore score = output_error_score_test(
            coulomb, out.coulomb, model_with(stribeck_id, vs), with_bump, a + 1, step, options.fit);
        if (!score.ok) {  // cannot screen: fit
          screened_out = false;
          break;
        }
        if (score.direction > 0.0 && score.statistic > check.score) {
          check.score = score.statistic;
          check.score_velocity = vs;
        }
      }
      if (!(check.score < options.screen_level)) screened_out = false;
    }
    if (screened_out) {
      check.chosen = coulomb_id;
      check.statistic = check.p_value = std::numeric_limits<double>::quiet_NaN();
      out.ok = true;
      take_coulomb_estimate();
      return out;
    }
    if (std::isfinite(check.score_velocity))
      stribeck.s0 = std::clamp(check.score_velocity, stribeck.s_min, stribeck.s_max);
    if (!fit_stribeck()) return out;
  }
  // Likelihood ratio with the noise level the Stribeck fit implies (never below the estimate).
  const double dof = std::max<double>(
      1.0, static_cast<double>(out.stribeck.residuals - out.stribeck.free_unknowns));
  const double scale = std::max(1.0, out.stribeck.data_cost / dof);
  check.statistic = (out.coulomb.cost - out.stribeck.cost) / scale;
  check.p_value = chi_square_tail(std::max(0.0, check.statistic), 2.0);
  const double fitted_fc = out.stribeck.theta[a], fitted_bump = out.stribeck.theta[a + 1];
  const double vs = out.stribeck.s;
  const bool admissible = fitted_fc > 0.0 && fitted_bump > 0.0 && vs >= options.min_velocity &&
                          vs <= options.max_velocity;
  check.chosen = check.p_value < options.alpha && admissible ? stribeck_id : coulomb_id;
  if (named_stribeck && check.chosen == coulomb_id) {
    // Its values are now the answer: take the Coulomb fit to its minimum, from where it stopped.
    coulomb.theta0 = out.coulomb.theta;
    coulomb.windows = out.coulomb.windows;
    if (!fit_coulomb(options.fit)) return out;
  }
  out.ok = true;
  if (check.chosen == stribeck_id) {
    const Eigen::MatrixXd& c = out.stribeck.covariance;
    const Eigen::Index s = out.stribeck.theta.size();
    out.estimate = Eigen::Vector3d(fitted_fc, fitted_fc + fitted_bump, vs);
    out.std =
        Eigen::Vector3d(std::sqrt(std::max(0.0, c(a, a))),
                        std::sqrt(std::max(0.0, c(a, a) + c(a + 1, a + 1) + 2.0 * c(a, a + 1))),
                        std::sqrt(std::max(0.0, c(s, s))));
  } else {
    take_coulomb_estimate();
  }
  return out;
}

SID_INLINE void refine_named_friction(DiagnosisResult& result, const Trajectory<double>& data,
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
    if (!r.ok) continue;
    for (std::size_t i = 0; i < result.effects.size(); ++i) {
      if (result.effects[i].id != r.check.named) continue;
      if (r.check.chosen != r.check.named) {
        result.effects[i].id = r.check.chosen;
        result.effects[i].name = effect_name(r.check.chosen);
        result.effects[i].value_names = effect_value_names(r.check.chosen);
        changed = true;
      }
      if (detail::starts_with(r.check.chosen, "stribeck_j")) {
        result.final_settings[i].stribeck_velocity = r.estimate[2];
        changed = true;
      }
    }
  }
  if (changed) refit_final_model(result, options);
  for (const auto& r : refinements) {
    if (!r.ok) continue;
    for (auto& e : result.effects) {
      if (e.id != r.check.chosen) continue;
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
      if (detail::starts_with(e.id, "stribeck_j")) {
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
}

}  // namespace sid
