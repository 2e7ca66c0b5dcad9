#pragma once
// Definitions of sid/diagnose_runs.hpp (see sid/config.hpp).

#include <sid/diagnose_runs.hpp>

namespace sid {

namespace detail {

SID_INLINE RunsEquations runs_equations(const Model<double>& model,
                                        const std::vector<Kinematics<double>>& kinematics,
                                        int folds_per_run) {
  RunsEquations e;
  const Eigen::Index p = model.num_parameters();
  e.scale = Eigen::VectorXd::Zero(p);
  for (const auto& k : kinematics) {
    e.runs.push_back(stack_regression(model, k));
    e.scale += e.runs.back().X.colwise().squaredNorm().transpose();
  }
  e.scale = e.scale.cwiseSqrt().cwiseMax(1e-300);
  const bool by_run = kinematics.size() >= 3;
  for (std::size_t r = 0; r < kinematics.size(); ++r) {
    const Eigen::Index n = kinematics[r].size();
    const int blocks = by_run ? 1 : folds_per_run;
    for (int b = 0; b < blocks; ++b) {
      RunsEquations::Group g;
      g.run = r;
      g.begin = n * b / blocks;
      g.size = n * (b + 1) / blocks - g.begin;
      for (int j = 0; j < 2; ++j) {
        const Eigen::MatrixXd x =
            e.runs[r].X.middleRows(j * n + g.begin, g.size) * e.scale.cwiseInverse().asDiagonal();
        const auto y = e.runs[r].y.segment(j * n + g.begin, g.size);
        g.gram[j] = x.transpose() * x;
        g.cross[j] = x.transpose() * y;
        g.yy[j] = y.squaredNorm();
      }
      e.groups.push_back(std::move(g));
    }
  }
  e.gram = Eigen::MatrixXd::Zero(p, p);
  e.cross = Eigen::VectorXd::Zero(p);
  for (const auto& g : e.groups) {
    e.gram += g.gram[0] + g.gram[1];
    e.cross += g.cross[0] + g.cross[1];
  }
  return e;
}

SID_INLINE Vector2<double> left_out_mean_square(const RunsEquations& e) {
  Vector2<double> sse = Vector2<double>::Zero();
  double count = 0.0;
  for (const auto& g : e.groups) {
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(e.gram - g.gram[0] - g.gram[1]);
    if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().array() > 0.0).all())
      return Vector2<double>::Constant(std::numeric_limits<double>::infinity());
    const Eigen::VectorXd beta = ldlt.solve(e.cross - g.cross[0] - g.cross[1]);
    for (int j = 0; j < 2; ++j)
      sse[j] += g.yy[j] - 2.0 * beta.dot(g.cross[j]) + beta.dot(g.gram[j] * beta);
    count += static_cast<double>(g.size);
  }
  return sse / count;
}

SID_INLINE std::pair<Eigen::VectorXd, Eigen::MatrixXd> fit_with_hac(const RunsEquations& e) {
  const Eigen::Index p = e.scale.size();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(e.gram);
  const Eigen::VectorXd beta = ldlt.solve(e.cross);
  Eigen::MatrixXd long_run = Eigen::MatrixXd::Zero(p, p);
  for (const auto& r : e.runs) {
    const Eigen::MatrixXd x = r.X * e.scale.cwiseInverse().asDiagonal();
    const Eigen::VectorXd res = r.y - x * beta;
    long_run += hac_long_run_sum(time_scores(x, res));
  }
  const Eigen::MatrixXd inverse = ldlt.solve(Eigen::MatrixXd::Identity(p, p));
  const Eigen::MatrixXd unscale = e.scale.cwiseInverse().asDiagonal();
  return {unscale * beta, unscale * inverse * long_run * inverse * unscale};
}

SID_INLINE Model<double> model_with(double g,
                                    const std::vector<std::pair<Effect, EffectSettings>>& named) {
  Model<double> model = two_link_arm_model<double>(g);
  for (const auto& [effect, settings] : named) model.add(effect_term(effect, settings));
  return model;
}

SID_INLINE std::vector<std::pair<Effect, EffectSettings>> with_candidate(
    std::vector<std::pair<Effect, EffectSettings>> named, Effect effect,
    const EffectSettings& settings) {
  const std::optional<Effect> superseded = contained_effect(effect);
  named.erase(std::remove_if(named.begin(), named.end(),
                             [&](const auto& e) { return e.first == superseded; }),
              named.end());
  named.emplace_back(effect, settings);
  return named;
}

SID_INLINE RunsEffectTest
test_candidate(Effect effect, const EffectSettings& settings,
               const std::vector<std::pair<Effect, EffectSettings>>& named,
               const std::vector<Kinematics<double>>& kinematics, const Vector2<double>& base_ms,
               const RunsDiagnoseOptions& options) {
  RunsEffectTest t;
  t.effect = effect;
  t.settings = settings;
  const Model<double> model = model_with(settings.gravity, with_candidate(named, effect, settings));
  const RunsEquations e = runs_equations(model, kinematics, options.identify.folds_per_run);
  const Vector2<double> ms = left_out_mean_square(e);
  t.prediction_gain = (base_ms - ms).cwiseQuotient(base_ms);
  t.gain = t.prediction_gain.mean();
  const auto [theta, covariance] = fit_with_hac(e);
  const Eigen::Index at = model.parameter_offset(effect.id()),
                     size = effect_term(effect, settings).size();
  t.wald = wald_statistic(theta.segment(at, size), covariance.block(at, at, size, size));
  t.p_value = std::isfinite(t.wald)
                  ? chi_square_tail(std::max(0.0, t.wald), static_cast<double>(size))
                  : 1.0;
  t.estimate = effect_estimate(effect, theta, covariance, model, settings);
  return t;
}

SID_INLINE double best_stribeck_width(Effect stribeck,
                                      const std::vector<std::pair<Effect, EffectSettings>>& named,
                                      const std::vector<Kinematics<double>>& kinematics,
                                      const RunsDiagnoseOptions& options) {
  const std::vector<double> grid =
      options.stribeck_velocities.empty() ? default_stribeck_grid() : options.stribeck_velocities;
  double best = grid.front(), best_ms = std::numeric_limits<double>::infinity();
  for (double vs : grid) {
    EffectSettings s = options.effects;
    s.stribeck_velocity = vs;
    const Vector2<double> ms = left_out_mean_square(
        runs_equations(model_with(s.gravity, with_candidate(named, stribeck, s)), kinematics,
                       options.identify.folds_per_run));
    if (ms.sum() < best_ms) {
      best_ms = ms.sum();
      best = vs;
    }
  }
  return best;
}

SID_INLINE Vector2<double> torque_above_cutoff(const Trajectory<double>& run, double cutoff_hz,
                                               const RunsIdentifyOptions& options) {
  const Eigen::Index n = run.size();
  const double lambda = smoothing_lambda_for_cutoff(
      cutoff_hz, (run.t[n - 1] - run.t[0]) / static_cast<double>(n - 1));
  const SmoothingSpline<double> spline(run.t);
  const double t0 = run.t[0] + options.skip, t1 = run.t[n - 1] - options.skip_end;
  Vector2<double> rms = Vector2<double>::Zero();
  for (int j = 0; j < 2; ++j) {
    const auto fit = spline.fit_penalized(run.tau.col(j), 1.0, 1.0 / lambda);
    Eigen::VectorXd smooth(n);
    fit.spline.derivatives_at_knots(0, smooth);
    double sum = 0.0;
    Eigen::Index count = 0;
    for (Eigen::Index i = 0; i < n; ++i)
      if (run.t[i] >= t0 && run.t[i] <= t1) {
        sum += (run.tau(i, j) - smooth[i]) * (run.tau(i, j) - smooth[i]);
        ++count;
      }
    rms[j] = count > 0 ? std::sqrt(sum / static_cast<double>(count)) : 0.0;
  }
  return rms;
}

SID_INLINE void check_runs_diagnose_options(const RunsDiagnoseOptions& o) {
  const std::string who = "sid::diagnose_runs: ";
  if (!(o.family_alpha > 0.0 && o.family_alpha < 1.0))
    throw std::invalid_argument(who + "family_alpha must be in (0, 1)");
  if (!(o.min_prediction_gain >= 0.0 && o.min_prediction_gain < 1.0))
    throw std::invalid_argument(who + "min_prediction_gain must be in [0, 1)");
  for (const Effect& e : o.candidates) check_effect_joint(e, "sid::diagnose_runs: candidates");
  for (double vs : o.stribeck_velocities)
    if (!(vs > 0.0) || !std::isfinite(vs))
      throw std::invalid_argument(who + "stribeck_velocities must be finite and > 0");
  check_effect_settings(o.effects, "sid::diagnose_runs");
}

SID_INLINE std::string mean_square_change(const Vector2<double>& gain) {
  char text[64];
  std::snprintf(text, sizeof text, "%+.2f %% / %+.2f %%", -100.0 * gain[0], -100.0 * gain[1]);
  return text;
}

SID_INLINE std::string rejection(const RunsEffectTest& t, const RunsDiagnoseOptions& o) {
  if (!(t.p_value < o.family_alpha))
    return "not significant (HAC Wald p = " + format_value(t.p_value) + " after Holm)";
  if (!(t.gain > o.min_prediction_gain))
    return "does not predict held-out torques better (their mean square " +
           mean_square_change(t.prediction_gain) + " on joint 1 / 2)";
  const std::string inadmissible = admissibility_violation(t.effect, t.estimate.value);
  return inadmissible.empty() ? "" : "not admissible: " + inadmissible;
}

SID_INLINE std::vector<RunsEffectTest> selection_round(
    const std::vector<Effect>& remaining,
    const std::vector<std::pair<Effect, EffectSettings>>& named,
    const std::vector<Kinematics<double>>& kinematics, const RunsDiagnoseOptions& options) {
  const Vector2<double> base_ms = left_out_mean_square(runs_equations(
      model_with(options.effects.gravity, named), kinematics, options.identify.folds_per_run));
  std::vector<RunsEffectTest> tests;
  for (const Effect effect : remaining) {
    EffectSettings settings = options.effects;
    if (effect.kind == EffectKind::Stribeck)
      settings.stribeck_velocity = best_stribeck_width(effect, named, kinematics, options);
    tests.push_back(test_candidate(effect, settings, named, kinematics, base_ms, options));
  }
  std::vector<double> p;
  for (const auto& t : tests) p.push_back(t.p_value);
  const std::vector<double> adjusted = holm_adjusted(p);
  for (std::size_t i = 0; i < tests.size(); ++i) tests[i].p_value = adjusted[i];
  for (auto& t : tests) t.reason = rejection(t, options);
  return tests;
}

SID_INLINE const RunsEffectTest* best_candidate(const std::vector<RunsEffectTest>& tests,
                                                double min_gain) {
  const RunsEffectTest* best = nullptr;
  for (const auto& t : tests)
    if (t.reason.empty() && (!best || t.gain > best->gain)) best = &t;
  if (!best) return best;
  const std::optional<Effect> contained = contained_effect(best->effect);
  for (const auto& t : tests)
    if (t.reason.empty() && t.effect == contained && t.gain >= best->gain - min_gain) return &t;
  return best;
}

SID_INLINE void directional_levels(FrictionShapeTest& s, const Eigen::VectorXd& theta,
                                   const Eigen::MatrixXd& covariance, Eigen::Index at) {
  s.forward = theta[at] + theta[at + 1];
  s.backward = theta[at] - theta[at + 1];
  const double cross = covariance(at, at + 1);
  s.forward_std =
      std::sqrt(std::max(0.0, covariance(at, at) + covariance(at + 1, at + 1) + 2.0 * cross));
  s.backward_std =
      std::sqrt(std::max(0.0, covariance(at, at) + covariance(at + 1, at + 1) - 2.0 * cross));
}

SID_INLINE std::vector<FrictionShapeTest> test_friction_shapes(
    std::vector<std::pair<Effect, EffectSettings>>& named, std::vector<RunsEffectTest>& chosen,
    const std::vector<Kinematics<double>>& kinematics, const RunsDiagnoseOptions& options) {
  std::vector<FrictionShapeTest> shapes;
  const auto equations = [&](const std::vector<std::pair<Effect, EffectSettings>>& terms) {
    return runs_equations(model_with(options.effects.gravity, terms), kinematics,
                          options.identify.folds_per_run);
  };
  for (auto& term : named) {
    if (term.first.kind != EffectKind::Coulomb) continue;
    FrictionShapeTest s;
    s.coulomb = term.first;
    Vector2<double> base = left_out_mean_square(equations(named));
    const EffectSettings kept = term.second;
    term.second.coulomb_shape = CoulombShape::Atan;
    const Vector2<double> with_atan = left_out_mean_square(equations(named));
    s.atan_gain = (base - with_atan).cwiseQuotient(base);
    if (s.atan_gain.mean() > options.min_prediction_gain) {
      s.shape = CoulombShape::Atan;
      base = with_atan;
    } else {
      term.second = kept;
    }
    term.second.coulomb_asymmetric = true;
    const RunsEquations e = equations(named);
    s.asymmetric_gain = (base - left_out_mean_square(e)).cwiseQuotient(base);
    const auto [theta, covariance] = fit_with_hac(e);
    const Eigen::Index at =
        model_with(options.effects.gravity, named).parameter_offset(s.coulomb.id());
    s.asymmetric_p_value = chi_square_tail(
        std::max(0.0, theta[at + 1] * theta[at + 1] / covariance(at + 1, at + 1)), 1.0);
    directional_levels(s, theta, covariance, at);
    s.asymmetric = s.asymmetric_gain.mean() > options.min_prediction_gain &&
                   s.asymmetric_p_value < options.family_alpha && s.forward > 0.0 &&
                   s.backward > 0.0;
    term.second.coulomb_asymmetric = s.asymmetric;
    for (auto& c : chosen)
      if (c.effect == s.coulomb) c.settings = term.second;
    shapes.push_back(s);
  }
  return shapes;
}

}  // namespace detail

namespace detail {

/// The forward selection's result: the effects named, in the model's order, with their tests.
struct RunsSelection {
  std::vector<std::pair<Effect, EffectSettings>> named;
  std::vector<RunsEffectTest> chosen;
  std::vector<RunsEffectTest> not_named;  ///< the final round's tests
};

SID_INLINE RunsSelection select_effects(const std::vector<Kinematics<double>>& k,
                                        const RunsDiagnoseOptions& fixed) {
  // The rotor inertia of joint 1 is theta1's own column: no data separate it.
  const Effect not_separable{EffectKind::Armature, 0};
  std::vector<Effect> remaining;
  for (const Effect e : fixed.candidates.empty() ? all_effects() : fixed.candidates)
    if (e != not_separable && std::find(remaining.begin(), remaining.end(), e) == remaining.end())
      remaining.push_back(e);
  RunsSelection s;
  while (!remaining.empty()) {
    std::vector<RunsEffectTest> tests = selection_round(remaining, s.named, k, fixed);
    const RunsEffectTest* best = best_candidate(tests, fixed.min_prediction_gain);
    if (!best) {
      s.not_named = std::move(tests);
      break;
    }
    s.named = with_candidate(s.named, best->effect, best->settings);
    const std::optional<Effect> superseded = contained_effect(best->effect);
    s.chosen.erase(std::remove_if(s.chosen.begin(), s.chosen.end(),
                                  [&](const auto& c) { return c.effect == superseded; }),
                   s.chosen.end());
    s.chosen.push_back(*best);
    remaining.erase(std::find(remaining.begin(), remaining.end(), best->effect));
    if (superseded)
      remaining.erase(std::remove(remaining.begin(), remaining.end(), *superseded),
                      remaining.end());
  }
  return s;
}

/// The rotor coupling's test against the final model, unless it was named: from the last round
/// if it was tested there, otherwise tested now.
SID_INLINE std::optional<RunsEffectTest> rotor_coupling_test(
    const std::vector<std::pair<Effect, EffectSettings>>& named,
    const std::vector<RunsEffectTest>& not_named, const std::vector<Kinematics<double>>& k,
    const RunsDiagnoseOptions& fixed) {
  const bool rotor_named = std::any_of(named.begin(), named.end(),
                                       [](const auto& e) { return e.first == kRotorCoupling; });
  if (rotor_named) return std::nullopt;
  const auto it = std::find_if(not_named.begin(), not_named.end(),
                               [](const RunsEffectTest& t) { return t.effect == kRotorCoupling; });
  if (it != not_named.end()) return *it;
  return selection_round({kRotorCoupling}, named, k, fixed).front();
}

/// The final model's residual in excess of the floor, fitted and held out, over all runs.
SID_INLINE void excess_over_floor(RunsDiagnosis& result) {
  Vector2<double> residual_ss = Vector2<double>::Zero(), left_out_ss = Vector2<double>::Zero(),
                  floor_ss = Vector2<double>::Zero();
  double samples = 0.0;
  for (std::size_t r = 0; r < result.floor.size(); ++r) {
    const double n = static_cast<double>(result.final.kinematics[r].size());
    residual_ss += n * result.final.residual_rms[r].cwiseAbs2();
    if (!result.final.left_out_prediction_rms.empty())
      left_out_ss += n * result.final.left_out_prediction_rms[r].cwiseAbs2();
    floor_ss += n * result.floor[r].cwiseAbs2();
    samples += n;
  }
  for (int j = 0; j < 2; ++j) {
    result.excess_rms[j] = std::sqrt(std::max(0.0, (residual_ss[j] - floor_ss[j]) / samples));
    result.left_out_excess_rms[j] =
        result.final.left_out_prediction_rms.empty()
            ? std::nan("")
            : std::sqrt(std::max(0.0, (left_out_ss[j] - floor_ss[j]) / samples));
  }
}

}  // namespace detail

SID_INLINE RunsDiagnosis diagnose_runs(const std::vector<Trajectory<double>>& runs,
                                       const RunsDiagnoseOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  detail::check_runs_diagnose_options(options);
  const double g = options.effects.gravity;
  RunsDiagnosis result;
  result.nominal_model = two_link_arm_model<double>(g);
  result.nominal = identify_runs(runs, result.nominal_model, options.identify);
  if (!result.nominal.fit.ok())
    throw std::invalid_argument("sid::diagnose_runs: the runs do not excite the nominal model: " +
                                result.nominal.fit.message);
  result.cutoff_hz = result.nominal.cutoff_hz;
  result.cutoff_chosen = result.nominal.cutoff_chosen;
  RunsDiagnoseOptions fixed = options;
  fixed.identify.cutoff_hz = result.cutoff_hz;
  const std::vector<Kinematics<double>>& k = result.nominal.kinematics;
  for (const auto& run : runs)
    result.floor.push_back(detail::torque_above_cutoff(run, result.cutoff_hz, options.identify));

  detail::RunsSelection selection = detail::select_effects(k, fixed);
  result.not_named = std::move(selection.not_named);
  result.friction_shapes =
      detail::test_friction_shapes(selection.named, selection.chosen, k, fixed);
  result.final_model = detail::model_with(g, selection.named);
  result.final = identify_runs(runs, result.final_model, fixed.identify);
  const StackedRegression<double> all = stack_runs(result.final_model, result.final.kinematics);
  result.final_covariance = hac_covariance(all, result.final.kinematics, result.final.fit);
  for (auto& c : selection.chosen) {
    c.estimate = effect_estimate(c.effect, result.final.fit.theta, result.final_covariance,
                                 result.final_model, c.settings);
    result.named.push_back(std::move(c));
  }
  for (auto& shape : result.friction_shapes)
    if (shape.asymmetric)
      detail::directional_levels(shape, result.final.fit.theta, result.final_covariance,
                                 result.final_model.parameter_offset(shape.coulomb.id()));
  result.rotor_coupling = detail::rotor_coupling_test(selection.named, result.not_named, k, fixed);
  detail::excess_over_floor(result);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace sid
