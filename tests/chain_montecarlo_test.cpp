// The Monte Carlo study of a chain: the oracle is unbiased, the smoothing spline beats raw
// differences, the numbers do not depend on the thread count, bad settings are refused.
#include <sid/study/chain_montecarlo.hpp>

#include <gtest/gtest.h>

#include <sid/cvode/chain_experiment.hpp>
#include <sid/fourier_trajectory.hpp>
#include <sid/model/link_inertia.hpp>

#include <cmath>
#include <random>
#include <vector>

namespace {

// A two-joint arm (standard DH: a vertical shoulder, then an elbow) with the drive terms the
// study fits, and its true trajectory under a random Fourier excitation: 4 s at 200 Hz, enough
// for every method (the filtered one drops its first 1.75 s) and quick under the sanitizers.
struct StudyArm {
  sid::ChainModel model;
  Eigen::VectorXd theta;
  sid::ChainKinematics<double> truth;

  static sid::ChainModel make_model() {
    const std::vector<sid::DhJoint<double>> dh = {{0.4, M_PI / 2, 0.3, 0.0}, {0.35, 0.0, 0.0, 0.0}};
    const sid::Transmission t(2);
    return sid::ChainModel(
        sid::SerialChain<double>(sid::DhConvention::Standard, dh), {"shoulder", "elbow"},
        sid::drive_terms({sid::DriveTermKind::Viscous, sid::DriveTermKind::Coulomb,
                          sid::DriveTermKind::Armature},
                         t),
        t, 0.01);
  }

  StudyArm() : model(make_model()), theta(model.parameters()) {
    const double mass[2] = {3.0, 2.0};
    for (int i = 0; i < 2; ++i) {
      sid::LinkInertia<double> link;
      link.mass = mass[i];
      link.com = sid::Vector3<double>(-0.15, 0.02 + 0.01 * i, 0.01);
      link.inertia_com = sid::Vector3<double>(0.02, 0.04, 0.03 + 0.01 * i).asDiagonal();
      theta.segment<10>(10 * i) = sid::standard_parameters(link);
    }
    theta.tail(6) << 0.8, 0.6, 0.05, 0.5, 0.3, 0.03;  // fv, fc, Ia per joint
    std::mt19937_64 rng(7);
    const sid::FourierTrajectory desired = sid::random_fourier_trajectory(
        Eigen::VectorXd::Zero(2), 3, 0.25, Eigen::VectorXd::Constant(2, 1.0),
        Eigen::VectorXd::Constant(2, 2.0), rng);
    sid::ChainExperiment experiment;
    experiment.duration = 4.0;
    experiment.sample_time = 0.005;
    const sid::ChainExperimentResult run =
        sid::simulate_chain_experiment(model, theta, desired, experiment);
    EXPECT_TRUE(run.ok()) << run.message;
    truth = run.truth;
  }

  static const StudyArm& get() {
    static const StudyArm arm;
    return arm;
  }
};

sid::ChainMonteCarloOptions small_study(std::vector<sid::StudyMethod> methods, int runs) {
  sid::ChainMonteCarloOptions o;
  o.methods = std::move(methods);
  o.runs = runs;
  o.sigma_q2_levels = {1e-6};
  o.seed = 5;
  o.threads = 1;
  // The paper's filters at 200 Hz: the same cutoffs in Hz as at its 400 Hz.
  o.kinematics.filters.q_cutoff *= 2.0;
  o.kinematics.filters.qd_cutoff *= 2.0;
  o.kinematics.filters.qdd_cutoff *= 2.0;
  return o;
}

const sid::MethodSummary& summary_of(const sid::ChainMonteCarloResult& r, sid::StudyMethod m) {
  for (const auto& s : r.levels.front().methods)
    if (s.method == m) return s;
  throw std::invalid_argument("no such method in the result");
}

}  // namespace

TEST(ChainMonteCarlo, OracleIsUnbiasedWithinItsStandardError) {
  const StudyArm& arm = StudyArm::get();
  const auto r = sid::run_chain_monte_carlo(arm.model, arm.theta, arm.truth,
                                            small_study({sid::StudyMethod::Oracle}, 20));
  const sid::MethodSummary& oracle = summary_of(r, sid::StudyMethod::Oracle);
  ASSERT_EQ(oracle.failed_runs, 0) << oracle.failures.front();
  ASSERT_EQ(r.beta.size(), oracle.mean.size());
  EXPECT_GT(r.beta.size(), 6);  // links regroup, but more than the drive terms remain
  // Exact kinematics: the estimate errs by the torque noise alone, so its mean is the truth to
  // within a few standard errors (4.5: the largest of some 20 normal deviates stays below it).
  constexpr double kStandardErrors = 4.5;
  for (Eigen::Index k = 0; k < r.beta.size(); ++k)
    EXPECT_LE(std::abs(oracle.mean[k] - r.beta[k]),
              kStandardErrors * oracle.standard_error[k] + 1e-12 * std::abs(r.beta[k]))
        << r.parameter_names[static_cast<std::size_t>(k)];
  // And it predicts the true torque within the noise's share of it.
  for (Eigen::Index run = 0; run < oracle.torque_error_pct.size(); ++run)
    EXPECT_LT(oracle.torque_error_pct[run], 1.0) << "run " << run;
}

TEST(ChainMonteCarlo, SmoothingSplineBeatsRawDifferencesAtTheMiddleNoiseLevel) {
  const StudyArm& arm = StudyArm::get();
  const auto r = sid::run_chain_monte_carlo(
      arm.model, arm.theta, arm.truth,
      small_study({sid::StudyMethod::Raw, sid::StudyMethod::Css, sid::StudyMethod::Oracle}, 6));
  const sid::MethodSummary &raw = summary_of(r, sid::StudyMethod::Raw),
                           &css = summary_of(r, sid::StudyMethod::Css),
                           &oracle = summary_of(r, sid::StudyMethod::Oracle);
  for (const auto* s : {&raw, &css, &oracle}) ASSERT_EQ(s->failed_runs, 0);
  EXPECT_LT(css.rms_rel_error_pct, 0.5 * raw.rms_rel_error_pct);
  EXPECT_LE(oracle.rms_rel_error_pct, css.rms_rel_error_pct);
  EXPECT_LT(css.torque_error_pct.mean(), 0.5 * raw.torque_error_pct.mean());
}

TEST(ChainMonteCarlo, SameSeedGivesTheSameNumbersForAnyThreadCount) {
  const StudyArm& arm = StudyArm::get();
  sid::ChainMonteCarloOptions o =
      small_study({sid::StudyMethod::Filtered, sid::StudyMethod::CssGcv, sid::StudyMethod::CssWls,
                   sid::StudyMethod::CssTorqueCv},
                  3);
  o.sigma_q2_levels = {1e-6, 1e-4};
  const auto one = sid::run_chain_monte_carlo(arm.model, arm.theta, arm.truth, o);
  o.threads = 2;
  const auto two = sid::run_chain_monte_carlo(arm.model, arm.theta, arm.truth, o);
  ASSERT_EQ(one.levels.size(), two.levels.size());
  for (std::size_t l = 0; l < one.levels.size(); ++l)
    for (std::size_t m = 0; m < one.levels[l].methods.size(); ++m) {
      const auto &a = one.levels[l].methods[m], &b = two.levels[l].methods[m];
      EXPECT_EQ(a.failed_runs, 0) << sid::study_method_name(a.method) << ": "
                                  << (a.failures.empty() ? "" : a.failures.front());
      EXPECT_TRUE(a.estimates.cwiseEqual(b.estimates).all()) << sid::study_method_name(a.method);
      EXPECT_TRUE(a.torque_error_pct.cwiseEqual(b.torque_error_pct).all());
    }
  // Another seed draws other noise.
  o.seed = 6;
  const auto other = sid::run_chain_monte_carlo(arm.model, arm.theta, arm.truth, o);
  EXPECT_FALSE(one.levels[0].methods[0].estimates.isApprox(other.levels[0].methods[0].estimates));
}

TEST(ChainMonteCarlo, RefusesCssIvAndSettingsThatDoNotFit) {
  const StudyArm& arm = StudyArm::get();
  const auto refused = [&](sid::ChainMonteCarloOptions o, const Eigen::VectorXd& theta,
                           const sid::ChainKinematics<double>& truth) {
    EXPECT_THROW((void)sid::run_chain_monte_carlo(arm.model, theta, truth, o),
                 std::invalid_argument);
  };
  const auto oracle = small_study({sid::StudyMethod::Oracle}, 2);
  refused(small_study({sid::StudyMethod::CssIv}, 2), arm.theta, arm.truth);
  refused(small_study({sid::StudyMethod::Oracle}, 1), arm.theta, arm.truth);
  auto no_levels = oracle;
  no_levels.sigma_q2_levels.clear();
  refused(no_levels, arm.theta, arm.truth);
  refused(oracle, arm.theta.head(arm.theta.size() - 1), arm.truth);
  sid::ChainKinematics<double> one_joint = arm.truth;
  one_joint.q = arm.truth.q.leftCols(1);
  refused(oracle, arm.theta, one_joint);
  auto too_long_skips = oracle;
  too_long_skips.kinematics.skip = 2.0;
  too_long_skips.kinematics.skip_end = 2.0;
  refused(too_long_skips, arm.theta, arm.truth);
}
