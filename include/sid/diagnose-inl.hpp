#pragma once
// Definitions of sid/diagnose.hpp (see sid/config.hpp).

#include <sid/diagnose.hpp>

namespace sid {

namespace detail {

SID_INLINE IdentifyOptions diagnose_identify_defaults() {
  IdentifyOptions o;
  o.method = DerivativeMethod::SmoothingSpline;
  o.smoothing = SmoothingMode::Gcv;
  o.skip = 0.25;
  o.skip_end = 0.05;
  return o;
}

SID_INLINE std::string effect_note(Effect effect) {
  const std::string look_alike = effect_look_alike(effect);
  return look_alike.empty() ? "" : look_alike + " looks the same";
}

SID_INLINE Eigen::MatrixXd stack_term(const Term<double>& term, const Kinematics<double>& k) {
  Model<double> model;
  model.add(term);
  Eigen::MatrixXd z(2 * k.size(), term.size());
  stack_regressor<double>(model, k.q, k.qd, k.qdd, z);
  return z;
}

SID_INLINE Eigen::MatrixXd integrate_windows(const Eigen::Ref<const Eigen::MatrixXd>& rows,
                                             const Eigen::Ref<const Eigen::VectorXd>& t,
                                             int window) {
  if (window <= 1) return rows;
  const Eigen::Index n = t.size(), m = window, count = (n - 1) / m;
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(2 * count, rows.cols());
  for (Eigen::Index j = 0; j < 2; ++j)
    for (Eigen::Index w = 0; w < count; ++w)
      for (Eigen::Index i = w * m; i < (w + 1) * m; ++i)
        out.row(j * count + w) +=
            (0.5 * (t[i + 1] - t[i])) * (rows.row(j * n + i) + rows.row(j * n + i + 1));
  return out;
}

SID_INLINE Eigen::MatrixXd integrate_windows(const Eigen::Ref<const Eigen::MatrixXd>& rows,
                                             const Eigen::Ref<const Eigen::VectorXd>& t, int window,
                                             const Eigen::VectorXd& row_weight) {
  if (window <= 1) return rows.array().colwise() * row_weight.array();
  Eigen::MatrixXd out = integrate_windows(rows, t, window);
  const Eigen::Index n = t.size(), count = out.rows() / 2;
  for (Eigen::Index j = 0; j < 2; ++j)
    for (Eigen::Index w = 0; w < count; ++w)
      if (row_weight.segment(j * n + w * window, window + 1).minCoeff() < 1.0)
        out.row(j * count + w).setZero();
  return out;
}

SID_INLINE Eigen::MatrixXd time_scores(const Eigen::Ref<const Eigen::MatrixXd>& x,
                                       const Eigen::Ref<const Eigen::VectorXd>& e) {
  const Eigen::Index n = x.rows() / 2;
  return x.topRows(n).array().colwise() * e.head(n).array() +
         x.bottomRows(n).array().colwise() * e.tail(n).array();
}

SID_INLINE HacFit hac_fit(const Eigen::Ref<const Eigen::MatrixXd>& x,
                          const Eigen::Ref<const Eigen::VectorXd>& y) {
  const Eigen::Index n = x.rows() / 2;
  const LeastSquaresResult<double> ls = least_squares(x, y, 2);
  HacFit f;
  f.theta = ls.theta;
  f.residual = ls.residual;
  f.rss = Vector2<double>(f.residual.head(n).squaredNorm(), f.residual.tail(n).squaredNorm());
  const Eigen::MatrixXd bread = ls.inverse_gram();
  const Eigen::MatrixXd g = time_scores(x, f.residual);
  f.covariance = bread * hac_long_run_sum(g) * bread;
  f.std = f.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  return f;
}

SID_INLINE double blocked_cv_error(const Eigen::Ref<const Eigen::MatrixXd>& x,
                                   const Eigen::Ref<const Eigen::VectorXd>& y, int blocks) {
  const Eigen::Index n = x.rows() / 2, p = x.cols();
  const Eigen::VectorXd scale = x.colwise().norm().transpose().cwiseMax(1e-300);
  std::vector<Eigen::MatrixXd> gram(static_cast<std::size_t>(blocks));
  std::vector<Eigen::VectorXd> cross(static_cast<std::size_t>(blocks));
  std::vector<double> yy(static_cast<std::size_t>(blocks));
  Eigen::MatrixXd gram_all = Eigen::MatrixXd::Zero(p, p);
  Eigen::VectorXd cross_all = Eigen::VectorXd::Zero(p);
  for (int b = 0; b < blocks; ++b) {
    const Eigen::Index i0 = n * b / blocks, i1 = n * (b + 1) / blocks, m = i1 - i0;
    const auto ub = static_cast<std::size_t>(b);
    gram[ub] = Eigen::MatrixXd::Zero(p, p);
    cross[ub] = Eigen::VectorXd::Zero(p);
    yy[ub] = 0.0;
    for (Eigen::Index off : {Eigen::Index(0), n}) {
      const Eigen::MatrixXd xb = x.middleRows(off + i0, m) * scale.cwiseInverse().asDiagonal();
      const auto yb = y.segment(off + i0, m);
      gram[ub].selfadjointView<Eigen::Lower>().rankUpdate(xb.transpose());
      cross[ub] += xb.transpose() * yb;
      yy[ub] += yb.squaredNorm();
    }
    gram[ub] = gram[ub].selfadjointView<Eigen::Lower>();
    gram_all += gram[ub];
    cross_all += cross[ub];
  }
  double error = 0.0;
  for (int b = 0; b < blocks; ++b) {
    const auto ub = static_cast<std::size_t>(b);
    const Eigen::VectorXd beta = (gram_all - gram[ub]).ldlt().solve(cross_all - cross[ub]);
    error += yy[ub] - 2.0 * beta.dot(cross[ub]) + beta.dot(gram[ub] * beta);
  }
  return error;
}

SID_INLINE Projector::Projector(const Eigen::Ref<const Eigen::MatrixXd>& x) {
  const Eigen::VectorXd scale = x.colwise().norm().transpose().cwiseMax(1e-300);
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(x * scale.cwiseInverse().asDiagonal());
  q = qr.householderQ() * Eigen::MatrixXd::Identity(x.rows(), x.cols());
}

SID_INLINE Eigen::MatrixXd Projector::residualize(
    const Eigen::Ref<const Eigen::MatrixXd>& z) const {
  return z - q * (q.transpose() * z);
}

SID_INLINE std::vector<Eigen::Index> separable_columns(
    const Eigen::Ref<const Eigen::MatrixXd>& z, const Eigen::Ref<const Eigen::MatrixXd>& z_resid,
    double r2, double* max_r2) {
  std::vector<Eigen::Index> kept;
  Eigen::MatrixXd basis(z.rows(), 0);
  *max_r2 = 0.0;
  for (Eigen::Index c = 0; c < z.cols(); ++c) {
    const double total = z.col(c).squaredNorm();
    Eigen::VectorXd v = z_resid.col(c);
    for (Eigen::Index b = 0; b < basis.cols(); ++b) v -= basis.col(b).dot(v) * basis.col(b);
    const double explained = total > 0.0 ? 1.0 - v.squaredNorm() / total : 1.0;
    *max_r2 = std::max(*max_r2, explained);
    if (explained > r2) continue;
    kept.push_back(c);
    basis.conservativeResize(Eigen::NoChange, basis.cols() + 1);
    basis.col(basis.cols() - 1) = v / v.norm();
  }
  return kept;
}

SID_INLINE Eigen::MatrixXd select_columns(const Eigen::Ref<const Eigen::MatrixXd>& z,
                                          const std::vector<Eigen::Index>& cols) {
  Eigen::MatrixXd out(z.rows(), static_cast<Eigen::Index>(cols.size()));
  for (std::size_t i = 0; i < cols.size(); ++i)
    out.col(static_cast<Eigen::Index>(i)) = z.col(cols[i]);
  return out;
}

SID_INLINE void wald_test(CandidateTest& t, const Eigen::MatrixXd& z_resid_kept,
                          const Eigen::Ref<const Eigen::VectorXd>& r,
                          const Vector2<double>& rss_old) {
  const Eigen::Index n = r.size() / 2, m = z_resid_kept.cols();
  const Eigen::MatrixXd a = z_resid_kept.transpose() * z_resid_kept;
  const Eigen::LDLT<Eigen::MatrixXd> a_ldlt(a);
  t.gamma = a_ldlt.solve(z_resid_kept.transpose() * r);
  const Eigen::VectorXd change = z_resid_kept * t.gamma;
  const Eigen::VectorXd e = r - change;
  for (int j = 0; j < 2; ++j) {
    const double residual_norm = r.segment(j * n, n).norm();
    t.practical_size[j] =
        residual_norm > 0.0 ? change.segment(j * n, n).norm() / residual_norm : 0.0;
  }
  const Eigen::MatrixXd g = time_scores(z_resid_kept, e);
  const Eigen::MatrixXd a_inv = a_ldlt.solve(Eigen::MatrixXd::Identity(m, m));
  t.covariance = a_inv * hac_long_run_sum(g) * a_inv;
  t.wald = wald_statistic(t.gamma, t.covariance);
  t.p_raw = chi_square_tail(std::max(0.0, t.wald), static_cast<double>(m));
  const double rss1 = e.head(n).squaredNorm(), rss2 = e.tail(n).squaredNorm();
  t.bic_drop =
      static_cast<double>(n) * (std::log(rss_old[0] / rss1) + std::log(rss_old[1] / rss2)) -
      static_cast<double>(m) * std::log(2.0 * static_cast<double>(n));
}

SID_INLINE std::vector<double> default_stribeck_grid() {
  std::vector<double> grid;
  for (int i = 0; i <= 8; ++i) grid.push_back(0.05 * std::pow(20.0, i / 8.0));  // 0.05 .. 1 rad/s
  return grid;
}

SID_INLINE Eigen::VectorXd moving_rows(const Kinematics<double>& k, double rest_velocity,
                                       double margin) {
  const Eigen::Index n = k.size();
  Eigen::VectorXd weight = Eigen::VectorXd::Ones(2 * n);
  for (int j = 0; j < 2; ++j) {
    Eigen::Index cleared_to = -1;  // rows before this are already cleared
    for (Eigen::Index i = 0; i < n; ++i) {
      // A sign change passes through rest even when no sample falls below rest_velocity.
      const bool reverses = (i > 0 && (k.qd(i - 1, j) > 0.0) != (k.qd(i, j) > 0.0)) ||
                            (i + 1 < n && (k.qd(i + 1, j) > 0.0) != (k.qd(i, j) > 0.0));
      if (!(std::fabs(k.qd(i, j)) < rest_velocity) && !(reverses && rest_velocity > 0.0)) continue;
      Eigen::Index first = i, last = i;
      while (first > 0 && k.t[i] - k.t[first - 1] <= margin) --first;
      while (last + 1 < n && k.t[last + 1] - k.t[i] <= margin) ++last;
      for (Eigen::Index d = std::max(first, cleared_to + 1); d <= last; ++d)
        weight[j * n + d] = 0.0;
      cleared_to = std::max(cleared_to, last);
    }
  }
  return weight;
}

SID_INLINE Eigen::Index stribeck_support(int joint, double vs, const Kinematics<double>& k,
                                         const Eigen::VectorXd& row_weight) {
  const Eigen::Index n = k.size();
  const double half = vs * std::sqrt(std::log(2.0));
  Eigen::Index count = 0;
  for (Eigen::Index i = 0; i < n; ++i)
    if (row_weight[joint * n + i] > 0.0 && std::fabs(k.qd(i, joint)) < half) ++count;
  return count;
}

SID_INLINE double best_stribeck_velocity(Effect stribeck, const EffectSettings& base,
                                         const std::vector<double>& grid,
                                         const Kinematics<double>& k, int integration_window,
                                         const Eigen::VectorXd& row_weight, const Projector& proj,
                                         const Eigen::Ref<const Eigen::VectorXd>& r, double r2,
                                         Eigen::Index min_support) {
  const int joint = stribeck.joint;
  const auto explained = [&](double vs) {
    if (stribeck_support(joint, vs, k, row_weight) < min_support) return -1.0;
    EffectSettings s = base;
    s.stribeck_velocity = vs;
    const Eigen::MatrixXd z = integrate_windows(stack_term(effect_term(stribeck, s), k), k.t,
                                                integration_window, row_weight);
    const Eigen::MatrixXd zr = proj.residualize(z);
    double max_r2 = 0;
    const auto kept = separable_columns(z, zr, r2, &max_r2);
    if (kept.empty()) return 0.0;
    const Eigen::MatrixXd zk = select_columns(zr, kept);
    const Eigen::VectorXd gamma = (zk.transpose() * zk).ldlt().solve(zk.transpose() * r);
    return (zk * gamma).squaredNorm();
  };
  if (grid.size() == 1) return grid[0];
  std::size_t best = 0;
  std::vector<double> value(grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) {
    value[i] = explained(grid[i]);
    if (value[i] > value[best]) best = i;
  }
  if (value[best] < 0.0) return std::numeric_limits<double>::quiet_NaN();
  double lo = std::log(grid[best > 0 ? best - 1 : best]);
  double hi = std::log(grid[best + 1 < grid.size() ? best + 1 : best]);
  constexpr double kGolden = 0.6180339887498949;
  double x1 = hi - kGolden * (hi - lo), x2 = lo + kGolden * (hi - lo);
  double f1 = explained(std::exp(x1)), f2 = explained(std::exp(x2));
  for (int it = 0; it < 14; ++it) {
    if (f1 > f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - kGolden * (hi - lo);
      f1 = explained(std::exp(x1));
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + kGolden * (hi - lo);
      f2 = explained(std::exp(x2));
    }
  }
  const double x = f1 > f2 ? x1 : x2;
  return std::max(f1, f2) >= value[best] ? std::exp(x) : grid[best];
}

SID_INLINE std::vector<FlaggedWindow> flag_windows(
    const Eigen::Ref<const Eigen::VectorXd>& t, const Eigen::Ref<const Eigen::VectorXd>& residual,
    const Vector2<double>& floor, double length, double alpha) {
  std::vector<FlaggedWindow> out;
  const Eigen::Index n = t.size();
  if (n < 2) return out;
  const double t0 = t[0], span = t[n - 1] - t[0];
  const auto count = static_cast<Eigen::Index>(std::max(1.0, std::floor(span / length + 1e-9)));
  for (int j = 0; j < 2; ++j) {
    if (!(floor[j] > 0.0)) continue;
    Eigen::Index i = 0;
    for (Eigen::Index w = 0; w < count; ++w) {
      const double tb = t0 + static_cast<double>(w) * length;
      const double te = w + 1 == count ? t[n - 1] + 1e-12 : tb + length;
      double sum = 0;
      Eigen::Index m = 0;
      const Eigen::Index first = i;
      while (i < n && t[i] < te) {
        sum += residual[j * n + i] * residual[j * n + i];
        ++m;
        ++i;
      }
      if (m < 2) continue;
      const double ratio = std::sqrt(sum / static_cast<double>(m)) / floor[j];
      const double limit =
          chi_square_critical(alpha / static_cast<double>(count), static_cast<double>(m)) /
          static_cast<double>(m);
      if (ratio * ratio > limit && ratio > 1.1) out.push_back({j + 1, t[first], t[i - 1], ratio});
    }
  }
  return out;
}

SID_INLINE void check_diagnose_options(const DiagnoseOptions& o) {
  const std::string who = "sid::diagnose: ";
  if (!(o.family_alpha > 0.0 && o.family_alpha < 1.0))
    throw std::invalid_argument(who + "options.family_alpha must be in (0, 1), got " +
                                std::to_string(o.family_alpha));
  if (!(o.negligible_size >= 0.0 && o.negligible_size < 1.0))
    throw std::invalid_argument(who + "options.negligible_size must be in [0, 1), got " +
                                std::to_string(o.negligible_size));
  if (!(o.separability_r2 > 0.0 && o.separability_r2 < 1.0))
    throw std::invalid_argument(who + "options.separability_r2 must be in (0, 1), got " +
                                std::to_string(o.separability_r2));
  if (o.cv_blocks < 2)
    throw std::invalid_argument(who + "options.cv_blocks must be >= 2, got " +
                                std::to_string(o.cv_blocks));
  if (!(o.rest_velocity >= 0.0) || !std::isfinite(o.rest_velocity))
    throw std::invalid_argument(who + "options.rest_velocity must be finite and >= 0 [rad/s]");
  if (!(o.rest_margin >= 0.0) || !std::isfinite(o.rest_margin))
    throw std::invalid_argument(who + "options.rest_margin must be finite and >= 0 [s]");
  if (o.kinematic_noise_runs < 0)
    throw std::invalid_argument(who + "options.kinematic_noise_runs must be >= 0");
  if (o.stribeck_min_support < 0)
    throw std::invalid_argument(who + "options.stribeck_min_support must be >= 0 [samples]");
  if (o.integration_window < 1)
    throw std::invalid_argument(who + "options.integration_window must be >= 1 [samples], got " +
                                std::to_string(o.integration_window));
  if (!(o.window_length > 0.0) || !std::isfinite(o.window_length))
    throw std::invalid_argument(who + "options.window_length must be finite and > 0 [s]");
  for (const Effect& e : o.candidates)
    detail::check_effect_joint(e, "sid::diagnose: options.candidates");
  for (double v : o.stribeck_velocities)
    if (!(v > 0.0) || !std::isfinite(v))
      throw std::invalid_argument(who +
                                  "options.stribeck_velocities must be finite and > 0 [rad/s]");
  if (o.identify.method != DerivativeMethod::SmoothingSpline)
    throw std::invalid_argument(
        who + "options.identify.method must be css (the diagnosis needs q̈ at every sample)");
  check_effect_settings(o.effects, "sid::diagnose: options.effects");
  if (o.reference_theta && (o.reference_theta->size() != 7 || !o.reference_theta->allFinite()))
    throw std::invalid_argument(
        who + "options.reference_theta must hold 7 finite values (theta1..theta7)");
}

SID_INLINE Eigen::MatrixXd assemble_columns(const Eigen::MatrixXd& x0,
                                            const std::vector<SelectedTerm>& terms) {
  Eigen::Index p = x0.cols();
  for (const auto& t : terms) p += t.z.cols();
  Eigen::MatrixXd x(x0.rows(), p);
  x.leftCols(x0.cols()) = x0;
  Eigen::Index c = x0.cols();
  for (const auto& t : terms) {
    x.middleCols(c, t.z.cols()) = t.z;
    c += t.z.cols();
  }
  return x;
}

SID_INLINE Model<double> assemble_model(double g, const std::vector<SelectedTerm>& terms) {
  Model<double> model = two_link_arm_model<double>(g);
  for (const auto& t : terms) model.add(effect_term(t.effect, t.settings));
  return model;
}

SID_INLINE void fill_report(ModelReport& report, const HacFit& fit,
                            const std::vector<std::string>& names, const Kinematics<double>& k,
                            const Eigen::Ref<const Eigen::MatrixXd>& x_samples,
                            const Eigen::Ref<const Eigen::VectorXd>& y_samples,
                            const Eigen::VectorXd& row_weight, const Vector2<double>& floor,
                            double window_length, double alpha) {
  const Eigen::Index n = k.size();
  report.parameter_names = names;
  report.theta = fit.theta;
  report.std = fit.std;
  report.residual = y_samples - x_samples * fit.theta;
  const Eigen::VectorXd kept_residual = report.residual.cwiseProduct(row_weight);
  for (int j = 0; j < 2; ++j) {
    const double kept = std::max(1.0, row_weight.segment(j * n, n).sum());
    report.residual_rms[j] = std::sqrt(kept_residual.segment(j * n, n).squaredNorm() / kept);
    report.excess_resolution[j] = floor[j] * std::sqrt(2.0 * std::sqrt(2.0 / kept));
    report.excess_rms[j] = std::sqrt(
        std::max(0.0, report.residual_rms[j] * report.residual_rms[j] - floor[j] * floor[j]));
  }
  report.windows = flag_windows(k.t, kept_residual, floor, window_length, alpha);
}

SID_INLINE void fit_final_model(DiagnosisResult& result, const std::vector<SelectedTerm>& selected,
                                const Eigen::MatrixXd& x0, const Eigen::VectorXd& y,
                                const Eigen::MatrixXd& x0_samples, const Eigen::VectorXd& y_samples,
                                const Vector2<double>& floor, const DiagnoseOptions& options) {
  const Kinematics<double>& k = result.kinematics;
  result.final_model = assemble_model(options.identify.gravity, selected);
  result.final_settings.clear();
  for (const auto& s : selected) result.final_settings.push_back(s.settings);
  const Eigen::MatrixXd x_final = assemble_columns(x0, selected);
  const HacFit final_fit = hac_fit(x_final, y);
  Eigen::MatrixXd x_final_samples(x0_samples.rows(), x_final.cols());
  x_final_samples.leftCols(x0_samples.cols()) = x0_samples;
  Eigen::Index c = x0_samples.cols();
  for (const auto& s : selected) {
    const Eigen::MatrixXd z = stack_term(effect_term(s.effect, s.settings), k);
    x_final_samples.middleCols(c, z.cols()) = z;
    c += z.cols();
  }
  fill_report(result.final, final_fit, result.final_model.parameter_names(), k, x_final_samples,
              y_samples, result.kept, floor, options.window_length, options.family_alpha);
  for (auto& e : result.effects) {
    const auto s = std::find_if(selected.begin(), selected.end(),
                                [&](const auto& t) { return t.effect == e.effect; });
    const EffectEstimate est = effect_estimate(e.effect, final_fit.theta, final_fit.covariance,
                                               result.final_model, s->settings);
    e.estimate = est.value;
    e.std = est.std;
    if (e.effect.kind == EffectKind::Stribeck) {
      // vs came from a search over widths, not from the linear fit.
      e.std[2] = std::numeric_limits<double>::quiet_NaN();
      e.note += std::string(e.note.empty() ? "" : "; ") +
                "vs is the best width of a grid search (no standard deviation); the standard "
                "deviations of Fc and Fs hold at that vs";
    }
  }
  result.drift.clear();
  if (options.reference_theta) {
    const Eigen::VectorXd& ref = *options.reference_theta;
    const auto names = two_link_parameter_names();
    for (Eigen::Index i = 0; i < 7; ++i) {
      ParameterDrift d;
      d.name = names[static_cast<std::size_t>(i)];
      d.reference = ref[i];
      d.estimate = final_fit.theta[i];
      d.std = final_fit.std[i];
      d.z = (d.estimate - d.reference) / d.std;
      d.significant = std::fabs(d.z) > 3.0;
      result.drift.push_back(d);
    }
  }
}

}  // namespace detail

namespace detail {

constexpr Eigen::Index kDiagnoseMinSamples = 50;

SID_INLINE void check_diagnose_input(const Trajectory<double>& data,
                                     const DiagnoseOptions& options) {
  constexpr const char* who = "sid::diagnose";
  check_diagnose_options(options);
  data.validate(who);
  if (data.size() < kDiagnoseMinSamples)
    throw std::invalid_argument(std::string(who) + ": data has " + std::to_string(data.size()) +
                                " samples; at least " + std::to_string(kDiagnoseMinSamples) +
                                " are needed");
  const IdentifyOptions& io = options.identify;
  if (!(io.skip >= 0.0) || !std::isfinite(io.skip) || !(io.skip_end >= 0.0) ||
      !std::isfinite(io.skip_end))
    throw std::invalid_argument(std::string(who) +
                                ": options.identify.skip and skip_end must be finite and >= 0 [s]");
}

/// The equations every later stage works on: the smoothed record, the analysed span, the rows
/// kept (moving joints) and the nominal regression per sample and in integral form.
struct DiagnosisEquations {
  Kinematics<double> all;  ///< the whole smoothed record (the kinematic floor resamples its noise)
  SmoothingReport smoothing;
  Kinematics<double> k;  ///< the span after the skips
  Eigen::VectorXd kept;  ///< row weights (DiagnosisResult::kept)
  int window = 1;        ///< DiagnoseOptions::integration_window
  StackedRegression<double> nominal_samples;
  Eigen::MatrixXd x0;  ///< the nominal columns in integral form
  Eigen::VectorXd y;   ///< the torques in integral form

  Eigen::MatrixXd integral_form(const Eigen::Ref<const Eigen::MatrixXd>& rows) const {
    return integrate_windows(rows, k.t, window, kept);
  }
  Eigen::MatrixXd effect_columns(Effect effect, const EffectSettings& settings) const {
    return integral_form(stack_term(effect_term(effect, settings), k));
  }
};

SID_INLINE DiagnosisEquations diagnosis_equations(const Trajectory<double>& data,
                                                  const DiagnoseOptions& options) {
  constexpr const char* who = "sid::diagnose";
  const IdentifyOptions& io = options.identify;
  DiagnosisEquations eq;
  eq.all = estimate_kinematics(data, io, &eq.smoothing);
  eq.k = window(eq.all, data.t[0] + io.skip, data.t[data.size() - 1] - io.skip_end);
  const Eigen::Index n = eq.k.size();
  const Eigen::Index min_window =
      std::max<Eigen::Index>(kDiagnoseMinSamples, 10 * options.cv_blocks);
  if (n < min_window)
    throw std::invalid_argument(std::string(who) + ": only " + std::to_string(n) +
                                " samples are left after the skip " + "window; at least " +
                                std::to_string(min_window) + " are needed");
  eq.nominal_samples = stack_two_link_regression(eq.k, io.gravity);
  eq.window = options.integration_window;
  const int iw = eq.window;
  if ((n - 1) / iw < 4 * options.cv_blocks)
    throw std::invalid_argument(std::string(who) + ": only " + std::to_string((n - 1) / iw) +
                                " integration windows of " + std::to_string(iw) +
                                " samples fit in the data; at least " +
                                std::to_string(4 * options.cv_blocks) + " are needed");
  eq.kept = moving_rows(eq.k, options.rest_velocity, options.rest_margin);
  eq.x0 = eq.integral_form(eq.nominal_samples.X);
  eq.y = eq.integral_form(eq.nominal_samples.y);
  const auto check = least_squares(eq.x0, eq.y, 2);
  if (!check.ok())
    throw std::invalid_argument(std::string(who) +
                                ": the data do not excite the nominal model: " + check.message);
  return eq;
}

/// The residual a perfect model would leave per joint: torque sensor noise and, when the
/// smoothing's noise level is known, the torque error the smoothed kinematics carry.
struct TorqueFloors {
  Vector2<double> noise = Vector2<double>::Zero();
  Vector2<double> kinematic = Vector2<double>::Zero();
  Vector2<double> combined() const {
    return (noise.array().square() + kinematic.array().square()).sqrt();
  }
};

SID_INLINE TorqueFloors torque_floors(const DiagnosisEquations& eq, const Model<double>& nominal,
                                      const Eigen::VectorXd& nominal_theta,
                                      const DiagnoseOptions& options) {
  TorqueFloors floors;
  const Kinematics<double>& k = eq.k;
  for (int j = 0; j < 2; ++j) floors.noise[j] = noise_sigma_gcv(k.t, k.tau.col(j));
  const IdentifyOptions& io = options.identify;
  const bool cross_validated =
      io.smoothing == SmoothingMode::Gcv || io.smoothing == SmoothingMode::Cv;
  const SmoothingReport& smoothing = eq.smoothing;
  if (options.kinematic_noise_runs > 0 && io.method == DerivativeMethod::SmoothingSpline &&
      cross_validated && smoothing.sigma.allFinite() && (smoothing.sigma.array() > 0.0).all()) {
    const Kinematics<double>& all = eq.all;
    const Eigen::Index first =
        std::lower_bound(all.t.data(), all.t.data() + all.size(), k.t[0]) - all.t.data();
    floors.kinematic = kinematic_noise_rms(
        nominal, nominal_theta, all, smoothing.sigma, smoothing.p, first, k.size(), eq.kept,
        options.kinematic_noise_runs, options.kinematic_noise_seed);
  }
  return floors;
}

/// The candidates the selection may name, and those the nominal model cannot be told apart from.
struct CandidateScreen {
  std::vector<Effect> separable;
  std::vector<NotSeparable> not_separable;
};

SID_INLINE CandidateScreen screen_candidates(const DiagnosisEquations& eq,
                                             const DiagnoseOptions& options) {
  CandidateScreen screen;
  const std::vector<Effect>& candidates =
      options.candidates.empty() ? all_effects() : options.candidates;
  const Projector nominal_projector(eq.x0);
  for (const Effect& effect : candidates) {
    if (std::find(screen.separable.begin(), screen.separable.end(), effect) !=
        screen.separable.end())
      continue;
    const Eigen::MatrixXd z = eq.effect_columns(effect, options.effects);
    double max_r2 = 0;
    const auto kept =
        separable_columns(z, nominal_projector.residualize(z), options.separability_r2, &max_r2);
    if (!kept.empty()) {
      screen.separable.push_back(effect);
      continue;
    }
    std::string explanation =
        effect == Effect{EffectKind::Armature, 0}
            ? "its column equals theta1's (the rotor inertia adds to D11 "
              "only): visible only as theta1 drift from a "
              "reference theta"
            : "its columns are explained by the nominal model's (R^2 = " + format_value(max_r2) +
                  ")";
    screen.not_separable.push_back({effect, effect_name(effect), explanation});
  }
  return screen;
}

/// The model a selection round tests candidates against.
struct RoundModel {
  Model<double> model;  ///< whose parameters fit.theta holds
  Eigen::MatrixXd x;
  Projector projector;
  HacFit fit;
  double cv_error;

  RoundModel(const DiagnosisEquations& eq, const std::vector<SelectedTerm>& selected, double g,
             int cv_blocks)
      : model(assemble_model(g, selected)),
        x(assemble_columns(eq.x0, selected)),
        projector(x),
        fit(hac_fit(x, eq.y)),
        cv_error(blocked_cv_error(x, eq.y, cv_blocks)) {}
};

/// The state of the forward selection between rounds; its final value is the stage's result.
struct Selection {
  std::vector<Effect> remaining;
  std::vector<SelectedTerm> selected;
  std::vector<NamedEffect> named;
  std::vector<CandidateTest> last_round;                ///< the tests of the final round
  std::vector<std::pair<Effect, std::string>> dropped;  ///< why a candidate left untested
};

/// Tests every remaining candidate against the round's model; those that cannot be tested (no
/// resolved Stribeck width, columns explained by the named effects) leave `remaining`.
SID_INLINE std::vector<CandidateTest> test_round(const DiagnosisEquations& eq,
                                                 const RoundModel& model,
                                                 const std::vector<double>& stribeck_grid,
                                                 Selection& s, const DiagnoseOptions& options) {
  std::vector<CandidateTest> tests;
  for (auto it = s.remaining.begin(); it != s.remaining.end();) {
    CandidateTest t;
    t.effect = *it;
    t.settings = options.effects;
    if (t.effect.kind == EffectKind::Stribeck) {
      t.settings.stribeck_velocity = best_stribeck_velocity(
          t.effect, options.effects, stribeck_grid, eq.k, eq.window, eq.kept, model.projector,
          model.fit.residual, options.separability_r2, options.stribeck_min_support);
      if (std::isnan(t.settings.stribeck_velocity)) {
        s.dropped.emplace_back(t.effect, "no Stribeck width is resolved: fewer than " +
                                             std::to_string(options.stribeck_min_support) +
                                             " kept samples lie within the bump's half height "
                                             "for every vs tried");
        it = s.remaining.erase(it);
        continue;
      }
    }
    t.z = eq.effect_columns(t.effect, t.settings);
    const Eigen::MatrixXd z_resid = model.projector.residualize(t.z);
    t.kept = separable_columns(t.z, z_resid, options.separability_r2, &t.max_r2);
    if (t.kept.empty()) {
      std::string by;
      for (const auto& named : s.selected) by += (by.empty() ? "" : ", ") + named.effect.id();
      s.dropped.emplace_back(t.effect, "explained by the named effects (" + by + ")");
      it = s.remaining.erase(it);
      continue;
    }
    wald_test(t, select_columns(z_resid, t.kept), model.fit.residual, model.fit.rss);
    Eigen::MatrixXd xa(model.x.rows(), model.x.cols() + static_cast<Eigen::Index>(t.kept.size()));
    xa << model.x, select_columns(t.z, t.kept);
    t.cv_drop = (model.cv_error - blocked_cv_error(xa, eq.y, options.cv_blocks)) / model.cv_error;
    tests.push_back(std::move(t));
    ++it;
  }
  return tests;
}

/// Fills a tested candidate's detection limit and, if its tests pass, its admissibility, from a
/// fit of the model with the term (a Stribeck term replacing its joint's Coulomb term).
SID_INLINE void judge_candidate(CandidateTest& t, const DiagnosisEquations& eq,
                                const RoundModel& model, const Selection& s, double critical_alpha,
                                const DiagnoseOptions& options) {
  const Eigen::VectorXd a =
      select_columns(effect_signature(t.effect, model.fit.theta, model.model).transpose(), t.kept)
          .transpose();
  const double sensitivity = a.dot(t.covariance.ldlt().solve(a));
  if (sensitivity > 0.0)
    t.detection_limit = std::sqrt(
        chi_square_critical(critical_alpha, static_cast<double>(t.kept.size())) / sensitivity);
  if (!(t.p_adjusted < options.family_alpha && t.bic_drop > 0.0 && t.cv_drop > 0.0)) return;
  std::vector<SelectedTerm> trial;
  for (const auto& named : s.selected)
    if (named.effect != contained_effect(t.effect)) trial.push_back(named);
  trial.push_back({t.effect, t.settings, t.z});
  const Eigen::MatrixXd xt = assemble_columns(eq.x0, trial);
  const auto ls = least_squares(xt, eq.y, 2);
  if (!ls.ok()) {
    t.inadmissible = "rank deficient with the named effects";
    return;
  }
  const EffectEstimate e =
      effect_estimate(t.effect, ls.theta, ls.covariance,
                      assemble_model(options.identify.gravity, trial), t.settings);
  t.inadmissible = admissibility_violation(t.effect, e.value);
  t.admissible = t.inadmissible.empty();
  t.negligible = t.practical_size.maxCoeff() < options.negligible_size;
  t.passed = t.admissible && !t.negligible;
}

/// Adds the chosen candidate to the model; a Stribeck term replaces its joint's Coulomb term.
SID_INLINE void name_candidate(const CandidateTest& chosen, Selection& s) {
  NamedEffect effect;
  effect.effect = chosen.effect;
  effect.name = effect_name(chosen.effect);
  effect.value_names = effect_value_names(chosen.effect);
  effect.wald = chosen.wald;
  effect.p_value = chosen.p_adjusted;
  effect.information_drop = chosen.bic_drop;
  effect.cv_drop = chosen.cv_drop;
  effect.practical_size = chosen.practical_size;
  effect.note = effect_note(chosen.effect);
  const std::optional<Effect> superseded = contained_effect(chosen.effect);
  for (auto it = s.selected.begin(); it != s.selected.end();)
    it = it->effect == superseded ? s.selected.erase(it) : it + 1;
  for (auto e = s.named.begin(); e != s.named.end();) {
    if (e->effect == superseded) {
      effect.note =
          "contains the Coulomb level Fc; replaces " + superseded->id() + ", named earlier";
      e = s.named.erase(e);
    } else {
      ++e;
    }
  }
  s.selected.push_back({chosen.effect, chosen.settings, chosen.z});
  s.named.push_back(std::move(effect));
  s.remaining.erase(std::find(s.remaining.begin(), s.remaining.end(), chosen.effect));
}

/// Forward selection: each round names the passing candidate with the largest BIC drop, until
/// none passes.
SID_INLINE Selection forward_selection(const DiagnosisEquations& eq, std::vector<Effect> candidates,
                                       const DiagnoseOptions& options) {
  const std::vector<double> grid =
      options.stribeck_velocities.empty() ? default_stribeck_grid() : options.stribeck_velocities;
  Selection s;
  s.remaining = std::move(candidates);
  while (!s.remaining.empty()) {
    const RoundModel model(eq, s.selected, options.identify.gravity, options.cv_blocks);
    std::vector<CandidateTest> tests = test_round(eq, model, grid, s, options);
    if (tests.empty()) break;
    std::vector<double> p_raw;
    for (const auto& t : tests) p_raw.push_back(t.p_raw);
    const std::vector<double> p_adjusted = holm_adjusted(p_raw);
    for (std::size_t i = 0; i < tests.size(); ++i) tests[i].p_adjusted = p_adjusted[i];
    const double critical_alpha = options.family_alpha / static_cast<double>(tests.size());
    int best = -1;
    for (std::size_t i = 0; i < tests.size(); ++i) {
      CandidateTest& t = tests[i];
      judge_candidate(t, eq, model, s, critical_alpha, options);
      if (t.passed && (best < 0 || t.bic_drop > tests[static_cast<std::size_t>(best)].bic_drop))
        best = static_cast<int>(i);
    }
    if (best < 0) {
      s.last_round = std::move(tests);
      break;
    }
    name_candidate(tests[static_cast<std::size_t>(best)], s);
  }
  return s;
}

/// Why each candidate tested but not named was left out, with its detection limit.
SID_INLINE std::vector<UnnamedEffect> unnamed_effects(const Selection& s,
                                                      const DiagnoseOptions& options) {
  std::vector<UnnamedEffect> out;
  for (const auto& d : s.dropped)
    out.push_back({d.first, effect_name(d.first), d.second, std::nan("")});
  for (const auto& t : s.last_round) {
    std::string reason;
    if (!(t.p_adjusted < options.family_alpha))
      reason = "not significant (HAC Wald p = " + format_value(t.p_adjusted) + " after Holm)";
    else if (!(t.bic_drop > 0.0))
      reason = "no BIC drop";
    else if (!(t.cv_drop > 0.0))
      reason = "no blocked-CV gain";
    else if (!t.admissible)
      reason = "not admissible: " + t.inadmissible;
    else
      reason = "significant but negligible: it would change the torque prediction by " +
               format_value(std::round(1000.0 * t.practical_size.maxCoeff()) / 10.0) +
               " % of the residual RMS at most (below " +
               format_value(100.0 * options.negligible_size) + " %)";
    out.push_back({t.effect, effect_name(t.effect), reason, t.detection_limit});
  }
  return out;
}

}  // namespace detail

SID_INLINE DiagnosisResult diagnose(const Trajectory<double>& data,
                                    const DiagnoseOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  detail::check_diagnose_input(data, options);
  detail::DiagnosisEquations eq = detail::diagnosis_equations(data, options);

  DiagnosisResult result;
  result.nominal_model = two_link_arm_model<double>(options.identify.gravity);
  const detail::HacFit nominal_fit = detail::hac_fit(eq.x0, eq.y);
  const detail::TorqueFloors floors =
      detail::torque_floors(eq, result.nominal_model, nominal_fit.theta, options);
  result.noise_floor = floors.noise;
  result.kinematic_floor = floors.kinematic;
  const Vector2<double> floor = floors.combined();
  detail::fill_report(result.nominal, nominal_fit, result.nominal_model.parameter_names(), eq.k,
                      eq.nominal_samples.X, eq.nominal_samples.y, eq.kept, floor,
                      options.window_length, options.family_alpha);

  detail::CandidateScreen screen = detail::screen_candidates(eq, options);
  result.not_separable = std::move(screen.not_separable);
  detail::Selection selection = detail::forward_selection(eq, std::move(screen.separable), options);

  result.kinematics = std::move(eq.k);
  result.kept = std::move(eq.kept);
  result.effects = std::move(selection.named);
  detail::fit_final_model(result, selection.selected, eq.x0, eq.y, eq.nominal_samples.X,
                          eq.nominal_samples.y, floor, options);
  const std::vector<UnnamedEffect> unnamed = detail::unnamed_effects(selection, options);
  result.not_named.insert(result.not_named.end(), unnamed.begin(), unnamed.end());
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

SID_INLINE DiagnosisResult refit_final_model(DiagnosisResult result,
                                             const DiagnoseOptions& options) {
  if (result.effects.size() != result.final_settings.size())
    throw std::invalid_argument(
        "sid::refit_final_model: result.effects has " + std::to_string(result.effects.size()) +
        " entries but result.final_settings has " + std::to_string(result.final_settings.size()));
  const Kinematics<double>& k = result.kinematics;
  const int iw = options.integration_window;
  const StackedRegression<double> nominal = stack_two_link_regression(k, options.identify.gravity);
  const Eigen::MatrixXd x0 = detail::integrate_windows(nominal.X, k.t, iw, result.kept);
  const Eigen::VectorXd y = detail::integrate_windows(nominal.y, k.t, iw, result.kept);
  std::vector<detail::SelectedTerm> selected;
  for (std::size_t i = 0; i < result.effects.size(); ++i) {
    const Effect effect = result.effects[i].effect;
    const auto& settings = result.final_settings[i];
    selected.push_back(
        {effect, settings,
         detail::integrate_windows(detail::stack_term(effect_term(effect, settings), k), k.t, iw,
                                   result.kept)});
  }
  const Vector2<double> floor =
      (result.noise_floor.array().square() + result.kinematic_floor.array().square()).sqrt();
  detail::fit_final_model(result, selected, x0, y, nominal.X, nominal.y, floor, options);
  return result;
}

}  // namespace sid
