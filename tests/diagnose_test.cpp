// Tests of sid::diagnose on data simulated with hidden effects (sid/model/effects.hpp): the
// simulator's true arm contains the effect, the diagnosis starts from the paper's 7-parameter model
// and must name what was hidden, estimate it and close the residual gap.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <map>
#include <random>
#include <sid/cvode/experiment.hpp>
#include <sid/diagnose.hpp>
#include <sid/measurement_noise.hpp>
#include <sid/model/effects.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "hidden_effect_data.hpp"
#include "test_support.hpp"

namespace {

using sid::test::Excitation;
using sid::test::excitation_name;
using sid::test::kQVariance;
using sid::test::kTauVariance;
using sid::test::simulate;

constexpr double kEstimateTolerance = 0.15;  // relative error allowed on an effect's main value
constexpr double kExcessShrink = 0.5;        // the affected joint's excess must at least halve

std::vector<std::string> named_ids(const sid::DiagnosisResult& r) {
  std::vector<std::string> ids;
  for (const auto& e : r.effects) ids.push_back(e.effect.id());
  std::sort(ids.begin(), ids.end());
  return ids;
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ",") + x;
  return s.empty() ? "(none)" : s;
}

/// Collects what every data set gave, printed once at the end: a confusion summary (hidden →
/// named) and the mean time per data set, for the lead's report.
struct Summary {
  std::map<std::string, std::map<std::string, int>> confusion;
  std::vector<std::string> lines;
  double seconds = 0;
  int runs = 0;

  void add(const std::string& hidden, const sid::DiagnosisResult& r, const std::string& line) {
    ++confusion[hidden][join(named_ids(r))];
    seconds += r.seconds;
    ++runs;
    lines.push_back(line);
  }
};

Summary& summary() {
  static Summary s;
  return s;
}

class SummaryPrinter : public ::testing::Environment {
 public:
  void TearDown() override {
    const Summary& s = summary();
    if (s.runs == 0) return;
    std::cout
        << "\n[diagnose summary] per data set: hidden | excitation seed | named | main estimate "
           "(rel. error) | excess nominal -> final on the affected joint\n";
    for (const auto& l : s.lines) std::cout << "  " << l << "\n";
    std::cout << "[diagnose summary] confusion (hidden -> named: count)\n";
    for (const auto& [hidden, row] : s.confusion)
      for (const auto& [named, count] : row)
        std::cout << "  " << hidden << " -> " << named << ": " << count << "\n";
    std::cout << "[diagnose summary] " << s.runs << " data sets, mean diagnose() time "
              << s.seconds / s.runs << " s\n";
  }
};
[[maybe_unused]] const auto* const kSummaryPrinter =
    ::testing::AddGlobalTestEnvironment(new SummaryPrinter);

/// One hidden effect at one size.
struct EffectCase {
  std::string spec;  // "id:values" as sid_simulate --effect takes it
  int joint;         // the joint whose torque residual the effect shows in (1 or 2)
};

std::ostream& operator<<(std::ostream& os, const EffectCase& c) { return os << c.spec; }

struct Outcome {
  sid::DiagnosisResult result;
  double truth = 0, estimate = 0, relative_error = 0, excess_before = 0, excess_after = 0;
};

Outcome run_case(const EffectCase& c, Excitation excitation, unsigned seed) {
  const sid::EffectSpec spec = sid::parse_effect(c.spec);
  Outcome o;
  o.result = sid::diagnose(simulate({spec}, excitation, seed));
  o.truth = spec.values[0];
  for (const auto& e : o.result.effects)
    if (e.effect == spec.effect) o.estimate = e.estimate[0];
  o.relative_error = (o.estimate - o.truth) / o.truth;
  o.excess_before = o.result.nominal.excess_rms[c.joint - 1];
  o.excess_after = o.result.final.excess_rms[c.joint - 1];
  std::ostringstream line;
  line << std::setprecision(3) << c.spec << " | " << excitation_name(excitation) << " " << seed
       << " | " << join(named_ids(o.result)) << " | " << o.estimate << " ("
       << 100 * o.relative_error << " %) | " << o.excess_before << " -> " << o.excess_after;
  summary().add(c.spec, o.result, line.str());
  return o;
}

// --- A hidden effect at a clearly visible size: named exactly, estimated within 15 %, and the
// affected joint's excess residual at least halves. Two seeds, both excitations.

class DiagnoseVisibleEffect : public ::testing::TestWithParam<EffectCase> {};

TEST_P(DiagnoseVisibleEffect, NamesExactlyItEstimatesItAndHalvesTheExcess) {
  const EffectCase& c = GetParam();
  const std::string id = sid::parse_effect(c.spec).effect.id();
  for (const auto& [excitation, seed] : sid::test::case_data_sets(11u, 12u)) {
    SCOPED_TRACE(c.spec + " " + excitation_name(excitation) + " seed " + std::to_string(seed));
    const Outcome o = run_case(c, excitation, seed);
    ASSERT_EQ(named_ids(o.result), std::vector<std::string>{id});
    EXPECT_LE(std::fabs(o.relative_error), kEstimateTolerance) << "estimate " << o.estimate;
    EXPECT_LE(o.excess_after, kExcessShrink * o.excess_before);
    EXPECT_GT(o.excess_before, 0.0);
  }
}

// Sizes: Coulomb on joint 1 needs 0.2 N m before its excess dominates joint 1's smoothing excess
// (about 0.02-0.035 N m from CSS errors in q̈); an armature of 4 θ2 on joint 2 (at 2 θ2 the
// estimate's own HAC std is about 7 %, so 15 % would hold only at 2 σ: 2 θ2 is tested for
// detection below); springs of
// 0.02 N m/rad (the arm turns over, so k q is far from the gravity columns).
INSTANTIATE_TEST_SUITE_P(
    Sizes, DiagnoseVisibleEffect,
    ::testing::Values(EffectCase{"coulomb_j1:0.3", 1}, EffectCase{"coulomb_j1:0.2", 1},
                      EffectCase{"coulomb_j2:0.3", 2}, EffectCase{"coulomb_j2:0.1", 2},
                      EffectCase{"torque_offset_j1:0.1", 1}, EffectCase{"torque_offset_j2:0.1", 2},
                      EffectCase{"torque_offset_j2:0.05", 2}, EffectCase{"angle_offset_q1:0.1", 1},
                      EffectCase{"angle_offset_q2:0.1", 2},
                      EffectCase{"armature_j2:0.012256543232", 2}, EffectCase{"spring_j1:0.02", 1},
                      EffectCase{"spring_j2:0.02", 2}));

// --- Near the detection limit: exactly the hidden effect is named, its estimate is within 15 %
// or, where its own HAC std is larger than 5 % (angle offset q2 at 0.05 rad: std about 20 %),
// within 3 std of the truth, and the affected joint's excess (over the torque noise and the
// kinematic floor) at least halves or ends below the excess resolution (what the sampling noise
// of the residual RMS alone reaches, about 0.021 N m here: an excess of 0.03 N m cannot be shown
// to halve). Two seeds, both excitations.

class DiagnoseSmallEffect : public ::testing::TestWithParam<EffectCase> {};

TEST_P(DiagnoseSmallEffect, NamesExactlyItEstimatesItAndHalvesTheExcess) {
  const EffectCase& c = GetParam();
  const std::string id = sid::parse_effect(c.spec).effect.id();
  for (const auto& [excitation, seed] : sid::test::case_data_sets(13u, 14u)) {
    SCOPED_TRACE(c.spec + " " + excitation_name(excitation) + " seed " + std::to_string(seed));
    const Outcome o = run_case(c, excitation, seed);
    ASSERT_EQ(named_ids(o.result), std::vector<std::string>{id});
    const double std = o.result.effects[0].std[0];
    EXPECT_LE(std::fabs(o.estimate - o.truth),
              std::max(kEstimateTolerance * std::fabs(o.truth), 3.0 * std))
        << "estimate " << o.estimate << " +- " << std;
    const double resolution = o.result.final.excess_resolution[c.joint - 1];
    EXPECT_LE(o.excess_after, std::max(kExcessShrink * o.excess_before, resolution));
    EXPECT_GT(o.excess_before, 0.0);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Sizes, DiagnoseSmallEffect,
    ::testing::Values(EffectCase{"coulomb_j1:0.05", 1}, EffectCase{"coulomb_j2:0.05", 2},
                      EffectCase{"torque_offset_j1:0.05", 1}, EffectCase{"angle_offset_q1:0.02", 1},
                      EffectCase{"angle_offset_q2:0.05", 2}, EffectCase{"armature_j2:0.003", 2},
                      EffectCase{"armature_j2:0.006128271616", 2}, EffectCase{"spring_j1:0.005", 1},
                      EffectCase{"spring_j2:0.005", 2}));

// --- No effect, nothing named.

TEST(Diagnose, NamesNothingInEffectFreeData) {
  struct Set {
    Excitation excitation;
    unsigned seed;
    double q_variance;
  };
  for (const Set& s : {Set{Excitation::Paper, 21u, 1e-6}, Set{Excitation::Multisine, 22u, 1e-6},
                       Set{Excitation::Paper, 23u, 1e-4}, Set{Excitation::Multisine, 24u, 1e-4},
                       Set{Excitation::Paper, 25u, 1e-6}, Set{Excitation::Multisine, 26u, 1e-4}}) {
    SCOPED_TRACE(excitation_name(s.excitation) + " seed " + std::to_string(s.seed) +
                 " q variance " + std::to_string(s.q_variance));
    const sid::DiagnosisResult r = sid::diagnose(simulate({}, s.excitation, s.seed, s.q_variance));
    std::ostringstream line;
    line << "none | " << excitation_name(s.excitation) << " " << s.seed << " (q var "
         << s.q_variance << ") | " << join(named_ids(r)) << " | - | "
         << r.nominal.excess_rms.transpose();
    summary().add("none", r, line.str());
    EXPECT_TRUE(r.effects.empty()) << join(named_ids(r));
    EXPECT_EQ(r.final_model.num_parameters(), 7);
    // The noise floor is the τ noise the data were made with.
    for (int j = 0; j < 2; ++j)
      EXPECT_NEAR(r.noise_floor[j], std::sqrt(kTauVariance), 0.1 * std::sqrt(kTauVariance));
    // Every candidate but armature_j1 was tested and got a finite detection limit.
    ASSERT_EQ(r.not_separable.size(), 1u);
    EXPECT_EQ(r.not_separable[0].effect.id(), "armature_j1");
    EXPECT_EQ(r.not_named.size(), sid::all_effects().size() - 1);
    for (const auto& u : r.not_named)
      EXPECT_TRUE(std::isfinite(u.detection_limit) && u.detection_limit > 0) << u.effect.id();
  }
}

// --- Two effects at once.

TEST(Diagnose, NamesTwoHiddenEffects) {
  for (Excitation excitation : {Excitation::Paper, Excitation::Multisine}) {
    SCOPED_TRACE(excitation_name(excitation));
    const sid::DiagnosisResult r = sid::diagnose(
        simulate({sid::parse_effect("coulomb_j2:0.1"), sid::parse_effect("torque_offset_j1:0.1")},
                 excitation, 31u));
    summary().add("coulomb_j2:0.1+torque_offset_j1:0.1", r,
                  "coulomb_j2:0.1 + torque_offset_j1:0.1 | " + excitation_name(excitation) +
                      " 31 | " + join(named_ids(r)));
    EXPECT_EQ(named_ids(r), (std::vector<std::string>{"coulomb_j2", "torque_offset_j1"}));
    for (const auto& e : r.effects) {
      constexpr double kTruth = 0.1;  // both effects' main value
      EXPECT_NEAR(e.estimate[0], kTruth, kEstimateTolerance * kTruth) << e.effect.id();
      if (e.effect.id() == "torque_offset_j1") {
        EXPECT_NE(e.note.find("constant load"), std::string::npos) << e.note;
      }
    }
    // Each effect's excess gone: both joints' excess at least halve.
    for (int j = 0; j < 2; ++j)
      EXPECT_LE(r.final.excess_rms[j], kExcessShrink * r.nominal.excess_rms[j]) << j;
  }
}

// --- Joint-1 armature: the same column as θ1, so not separable, and visible as θ1 drift.

TEST(Diagnose, ReportsJointOneArmatureAsNotSeparableAndAsThetaOneDrift) {
  const sid::TwoLinkParameters<double> theta = sid::paper_arm_parameters<double>();
  const double armature = 0.2 * theta[0];
  sid::DiagnoseOptions options;
  options.reference_theta = Eigen::VectorXd(theta);
  const sid::DiagnosisResult r = sid::diagnose(
      simulate({sid::EffectSpec{"armature_j1", {armature}}}, Excitation::Multisine, 41u), options);
  summary().add("armature_j1", r, "armature_j1:0.2 theta1 | multisine 41 | " + join(named_ids(r)));
  EXPECT_TRUE(r.effects.empty()) << join(named_ids(r));
  const auto ns = std::find_if(r.not_separable.begin(), r.not_separable.end(),
                               [](const auto& x) { return x.effect.id() == "armature_j1"; });
  ASSERT_NE(ns, r.not_separable.end());
  EXPECT_NE(ns->explanation.find("theta1"), std::string::npos) << ns->explanation;
  ASSERT_EQ(r.drift.size(), 7u);
  EXPECT_EQ(r.drift[0].name, "theta1");
  EXPECT_TRUE(r.drift[0].significant) << "z = " << r.drift[0].z;
  // D11 = θ1 + Ia + ...: the drift is the armature.
  EXPECT_NEAR(r.drift[0].estimate - r.drift[0].reference, armature, kEstimateTolerance * armature);
  // The other parameters stay where they were.
  for (std::size_t i = 1; i < 7; ++i)
    EXPECT_FALSE(r.drift[i].significant) << r.drift[i].name << " z " << r.drift[i].z;
}

// --- Stribeck friction (Fc 0.1, Fs 0.3, vs 0.2). The bump lives where the joint reverses: there
// the joint sticks (its friction is static, left out by DiagnoseOptions::rest_velocity), and it
// slides through |q̇| < vs in a few tens of milliseconds, about the spline's bandwidth. On the
// multisine excitation Stribeck is named on both joints. Fs is within 15 % on joint 2; on joint 1
// it scatters more (0.21-0.31 over seeds 1-8, 6 of 8 within 15 %), so there the test holds Fc.

sid::DiagnosisResult run_stribeck(int joint, Excitation excitation, unsigned seed) {
  const std::string spec = "stribeck_j" + std::to_string(joint) + ":0.1,0.3,0.2";
  const sid::DiagnosisResult r =
      sid::diagnose(simulate({sid::parse_effect(spec)}, excitation, seed));
  std::ostringstream line;
  line << spec << " | " << excitation_name(excitation) << " " << seed << " | " << join(named_ids(r))
       << " | ";
  for (const auto& e : r.effects) line << e.estimate.transpose() << " ";
  line << "| " << r.nominal.excess_rms[joint - 1] << " -> " << r.final.excess_rms[joint - 1];
  summary().add(spec, r, line.str());
  return r;
}

TEST(Diagnose, NamesStribeckFrictionOnTheMultisineExcitation) {
  for (int joint : {1, 2})
    for (unsigned seed : {11u, 12u}) {
      SCOPED_TRACE("joint " + std::to_string(joint) + " seed " + std::to_string(seed));
      const sid::DiagnosisResult r = run_stribeck(joint, Excitation::Multisine, seed);
      ASSERT_EQ(named_ids(r), std::vector<std::string>{"stribeck_j" + std::to_string(joint)});
      const Eigen::VectorXd& e = r.effects[0].estimate;  // Fc, Fs, vs
      EXPECT_NEAR(e[0], 0.1, kEstimateTolerance * 0.1) << "Fc";
      if (joint == 2) {
        EXPECT_NEAR(e[1], 0.3, kEstimateTolerance * 0.3) << "Fs";
      }
      EXPECT_GT(e[1], e[0]) << "Fs > Fc";
      EXPECT_GT(r.effects[0].std[1], 0.0);
      EXPECT_TRUE(std::isnan(r.effects[0].std[2])) << "vs comes from a grid search";
      EXPECT_LE(r.final.excess_rms[joint - 1], kExcessShrink * r.nominal.excess_rms[joint - 1]);
    }
}

// On the paper's excitation the joints reverse fast and then stick: the torque-domain data fix
// the bump's area (about (Fs − Fc) vs) better than its height, so Fs comes out 20-40 % low with
// vs high (joint 2), and on joint 1 (reversals at 13 rad/s², |q̇| < vs for 30 ms) the bump is
// named in about half of the seeds, otherwise Coulomb. What holds for diagnose() alone: a
// friction effect of the right joint and nothing else, Fc within 15 %, the excess at least
// halved; on joint 2 it is Stribeck. The output-error friction test that diagnose_with_simulation
// runs next names Stribeck with Fc and Fs within 15 % (tests/friction_refinement_test.cpp).
TEST(Diagnose, SeesStribeckFrictionOnThePaperExcitationAsFrictionOnItsJoint) {
  for (int joint : {1, 2})
    for (unsigned seed : {11u, 12u}) {
      SCOPED_TRACE("joint " + std::to_string(joint) + " seed " + std::to_string(seed));
      const sid::DiagnosisResult r = run_stribeck(joint, Excitation::Paper, seed);
      const std::string j = std::to_string(joint);
      const auto ids = named_ids(r);
      ASSERT_EQ(ids.size(), 1u) << join(ids);
      if (joint == 2)
        EXPECT_EQ(ids[0], "stribeck_j2");
      else
        EXPECT_TRUE(ids[0] == "stribeck_j1" || ids[0] == "coulomb_j1") << ids[0];
      EXPECT_NEAR(r.effects[0].estimate[0], 0.1, kEstimateTolerance * 0.1) << "Fc";
      EXPECT_LE(r.final.excess_rms[joint - 1], kExcessShrink * r.nominal.excess_rms[joint - 1]);
    }
}

TEST(Diagnose, LeavesOutTheEquationsOfAJointAtRestAndNearIt) {
  sid::Kinematics<double> k;
  const Eigen::Index n = 101;
  k.t = Eigen::VectorXd::LinSpaced(n, 0.0, 1.0);  // 10 ms steps
  k.q = k.qdd = k.tau = sid::MatrixX2<double>::Zero(n, 2);
  k.qd.resize(n, 2);
  k.qd.col(0) = (k.t.array() - 0.5) * 2.0;  // joint 1 reverses at 0.5 s: |q̇| < 0.03 on 0.49..0.51
  k.qd.col(1).setConstant(1.0);             // joint 2 never rests
  const Eigen::VectorXd kept = sid::detail::moving_rows(k, 0.03, 0.025);
  for (Eigen::Index i = 0; i < n; ++i) {
    const bool near_rest = std::fabs(k.t[i] - 0.5) < 0.035;  // 0.49..0.51 and 2 samples' margin
    EXPECT_EQ(kept[i], near_rest ? 0.0 : 1.0) << "t = " << k.t[i];
    EXPECT_EQ(kept[n + i], 1.0);
  }
  EXPECT_EQ(sid::detail::moving_rows(k, 0.0, 0.02), Eigen::VectorXd::Ones(2 * n));
  // A reversal fast enough to step over |q̇| < 0.03 between two samples is still one.
  k.qd.col(1) = (k.t.array() - 0.505) * 20.0;  // q̇ = -0.1 at 0.50 s, +0.1 at 0.51 s
  const Eigen::VectorXd fast = sid::detail::moving_rows(k, 0.03, 0.025);
  for (Eigen::Index i = 0; i < n; ++i) {
    const bool near_reversal = k.t[i] > 0.475 - 1e-9 && k.t[i] < 0.535 + 1e-9;  // 0.48..0.53
    EXPECT_EQ(fast[n + i], near_reversal ? 0.0 : 1.0) << "t = " << k.t[i];
  }
}

TEST(Diagnose, DoesNotTryAStribeckBumpTheSamplesDoNotResolve) {
  sid::DiagnoseOptions options;
  options.candidates = {"coulomb_j2", "stribeck_j2"};
  options.stribeck_min_support = 100000;  // more samples than the data have
  const sid::DiagnosisResult r = sid::diagnose(
      simulate({sid::parse_effect("stribeck_j2:0.1,0.3,0.2")}, Excitation::Multisine, 11u),
      options);
  EXPECT_EQ(named_ids(r), std::vector<std::string>{"coulomb_j2"});
  const auto s = std::find_if(r.not_named.begin(), r.not_named.end(),
                              [](const auto& u) { return u.effect.id() == "stribeck_j2"; });
  ASSERT_NE(s, r.not_named.end());
  EXPECT_NE(s->reason.find("no Stribeck width is resolved"), std::string::npos) << s->reason;
}

// --- The result is self-consistent (what the app and the CVODE layer rely on).

TEST(Diagnose, FinalModelMatchesItsReport) {
  const sid::DiagnosisResult r =
      sid::diagnose(simulate({sid::parse_effect("coulomb_j2:0.3")}, Excitation::Paper, 61u));
  ASSERT_EQ(r.effects.size(), 1u);
  const auto& e = r.effects[0];
  EXPECT_EQ(e.value_names, sid::effect_value_names(e.effect));
  EXPECT_EQ(e.estimate.size(), static_cast<Eigen::Index>(e.value_names.size()));
  EXPECT_EQ(e.std.size(), e.estimate.size());
  EXPECT_GT(e.wald, 0.0);
  EXPECT_LT(e.p_value, 0.01);
  EXPECT_GT(e.information_drop, 0.0);
  EXPECT_GT(e.cv_drop, 0.0);
  EXPECT_EQ(r.final_model.parameter_names(), r.final.parameter_names);
  ASSERT_EQ(r.final.theta.size(), r.final_model.num_parameters());
  EXPECT_EQ(r.nominal.theta.size(), 7);
  EXPECT_EQ(r.kinematics.size() * 2, r.final.residual.size());
  // The final report's residual is the data minus the final model's inverse dynamics.
  const sid::Kinematics<double>& k = r.kinematics;
  constexpr double kResidualTolerance = 1e-9;
  for (Eigen::Index i = 0; i < k.size(); i += 97) {
    const sid::Vector2<double> tau = r.final_model.inverse_dynamics(
        r.final.theta, k.q.row(i).transpose(), k.qd.row(i).transpose(), k.qdd.row(i).transpose());
    EXPECT_NEAR(k.tau(i, 0) - tau[0], r.final.residual[i], kResidualTolerance);
    EXPECT_NEAR(k.tau(i, 1) - tau[1], r.final.residual[k.size() + i], kResidualTolerance);
  }
  // Residual RMS is the RMS of that residual over the equations kept (the joint moving).
  const Eigen::Index n = k.size();
  ASSERT_EQ(r.kept.size(), 2 * n);
  double sum = 0.0, count = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (r.kept[n + i] == 0.0) continue;
    sum += r.final.residual[n + i] * r.final.residual[n + i];
    count += 1.0;
  }
  EXPECT_GT(count, 0.9 * static_cast<double>(n));
  EXPECT_NEAR(r.final.residual_rms[1], std::sqrt(sum / count), 1e-12);
  // The nominal model's flagged windows include joint 2's and lie within the data's time span.
  EXPECT_TRUE(std::any_of(r.nominal.windows.begin(), r.nominal.windows.end(),
                          [](const auto& w) { return w.joint == 2; }));
  for (const auto& w : r.nominal.windows) {
    EXPECT_GE(w.t_begin, k.t[0]);
    EXPECT_LE(w.t_end, k.t[n - 1]);
    EXPECT_GT(w.ratio, 1.0);
  }
  EXPECT_LT(r.final.windows.size(), r.nominal.windows.size());
  EXPECT_TRUE(std::isnan(r.final.sim_error_rms[0]));
  EXPECT_GT(r.seconds, 0.0);
}

TEST(Diagnose, RestrictsTheSearchToTheGivenCandidates) {
  sid::DiagnoseOptions options;
  options.candidates = {"torque_offset_j1", "spring_j2"};
  const sid::DiagnosisResult r = sid::diagnose(
      simulate({sid::parse_effect("coulomb_j2:0.3")}, Excitation::Paper, 62u), options);
  for (const auto& e : r.effects)
    EXPECT_TRUE(e.effect.id() == "torque_offset_j1" || e.effect.id() == "spring_j2")
        << e.effect.id();
  EXPECT_EQ(r.effects.size() + r.not_named.size() + r.not_separable.size(), 2u);
}

// --- Practical size: a Coulomb level of 0.014 N m on joint 2 passes the tests next to a hidden
// one of 0.5 N m on joint 1 (of 500 data sets with Coulomb friction on joint 1 alone, seeds 11-110,
// this is the only one where anything else passed), but it would change joint 2's torque
// prediction by 5.5 % of its residual RMS: reported as negligible, not named. Without the rule it
// is named, so the test shows the rule at work.

TEST(Diagnose, ReportsASignificantButNegligibleEffectWithoutNamingIt) {
  const sid::Trajectory<double> data =
      simulate({sid::parse_effect("coulomb_j1:0.5")}, Excitation::Paper, 66u);
  const sid::DiagnosisResult r = sid::diagnose(data);
  EXPECT_EQ(named_ids(r), std::vector<std::string>{"coulomb_j1"});
  ASSERT_FALSE(r.effects.empty());
  EXPECT_GE(r.effects[0].practical_size.maxCoeff(), sid::DiagnoseOptions{}.negligible_size);
  const auto negligible = std::find_if(r.not_named.begin(), r.not_named.end(),
                                       [](const auto& u) { return u.effect.id() == "coulomb_j2"; });
  ASSERT_NE(negligible, r.not_named.end());
  EXPECT_NE(negligible->reason.find("significant but negligible"), std::string::npos)
      << negligible->reason;

  sid::DiagnoseOptions without_rule;
  without_rule.negligible_size = 0.0;
  const sid::DiagnosisResult unruled = sid::diagnose(data, without_rule);
  EXPECT_EQ(named_ids(unruled), (std::vector<std::string>{"coulomb_j1", "coulomb_j2"}));
  for (const auto& e : unruled.effects)
    if (e.effect.id() == "coulomb_j2") {
      EXPECT_LT(e.practical_size.maxCoeff(), sid::DiagnoseOptions{}.negligible_size);
      EXPECT_LT(e.estimate[0], 0.03);
    }
}

// --- Bad input.

TEST(Diagnose, ThrowsOnBadInput) {
  const sid::Trajectory<double> good = simulate({}, Excitation::Paper, 71u);
  sid::Trajectory<double> short_data{good.t.head(30), good.q.topRows(30), good.tau.topRows(30)};
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(short_data); }, "sid::diagnose",
                                    "samples");
  sid::Trajectory<double> nan_data = good;
  nan_data.tau(100, 1) = std::nan("");
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(nan_data); }, "sid::diagnose", "tau");
  sid::DiagnoseOptions unknown;
  unknown.candidates = {sid::Effect{sid::EffectKind::Coulomb, 2}};
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(good, unknown); }, "sid::diagnose",
                                    "effect joint 2 is outside 0..1");
  sid::DiagnoseOptions alpha;
  alpha.family_alpha = 1.5;
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(good, alpha); }, "sid::diagnose",
                                    "family_alpha");
  sid::DiagnoseOptions negligible;
  negligible.negligible_size = 1.0;
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(good, negligible); }, "sid::diagnose",
                                    "negligible_size");
  sid::DiagnoseOptions blocks;
  blocks.cv_blocks = 1;
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(good, blocks); }, "sid::diagnose",
                                    "cv_blocks");
  sid::DiagnoseOptions reference;
  reference.reference_theta = Eigen::VectorXd::Ones(5);
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(good, reference); }, "sid::diagnose",
                                    "reference_theta");
  sid::DiagnoseOptions window;
  window.window_length = 0.0;
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(good, window); }, "sid::diagnose",
                                    "window_length");
  sid::DiagnoseOptions velocities;
  velocities.stribeck_velocities = {0.1, -0.2};
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(good, velocities); }, "sid::diagnose",
                                    "stribeck_velocities");
  sid::DiagnoseOptions rest;
  rest.rest_velocity = -0.1;
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(good, rest); }, "sid::diagnose",
                                    "rest_velocity");
  sid::DiagnoseOptions margin;
  margin.rest_margin = std::nan("");
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(good, margin); }, "sid::diagnose",
                                    "rest_margin");
  sid::DiagnoseOptions support;
  support.stribeck_min_support = -1;
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(good, support); }, "sid::diagnose",
                                    "stribeck_min_support");
  sid::DiagnoseOptions skip;
  skip.identify.skip = 9.9;
  sid_test::expect_invalid_argument([&] { (void)sid::diagnose(good, skip); }, "sid::diagnose",
                                    "samples");
}

}  // namespace

// --- The integral form (DiagnoseOptions::integration_window).

TEST(Diagnose, IntegrateWindowsIsTheTrapezoidalIntegralPerJointAndWindow) {
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(21, 0.0, 2.0);  // 20 intervals of 0.1 s
  Eigen::MatrixXd rows(42, 2);
  for (Eigen::Index i = 0; i < 21; ++i) {
    rows.row(i) << 1.0, 3.0 * t[i];         // joint 1: 1 and 3t
    rows.row(21 + i) << -2.0, t[i] * t[i];  // joint 2: -2 and t² (trapezoid: + h²/6 per window)
  }
  const Eigen::MatrixXd w = sid::detail::integrate_windows(rows, t, 6);  // 3 windows of 0.6 s
  ASSERT_EQ(w.rows(), 6);
  for (Eigen::Index k = 0; k < 3; ++k) {
    const double a = 0.6 * static_cast<double>(k), b = a + 0.6;
    EXPECT_NEAR(w(k, 0), b - a, 1e-12);
    EXPECT_NEAR(w(k, 1), 1.5 * (b * b - a * a), 1e-12);
    EXPECT_NEAR(w(3 + k, 0), -2.0 * (b - a), 1e-12);
    EXPECT_NEAR(w(3 + k, 1), (b * b * b - a * a * a) / 3.0 + (b - a) * 0.01 / 6.0, 1e-12);
  }
  EXPECT_EQ(sid::detail::integrate_windows(rows, t, 1), rows);
}

TEST(Diagnose, IntegralFormEstimatesCoulombFrictionWithoutTheSmearingBias) {
  sid::DiagnoseOptions options;
  options.integration_window = 20;
  for (Excitation excitation : {Excitation::Paper, Excitation::Multisine}) {
    SCOPED_TRACE(excitation_name(excitation));
    const sid::DiagnosisResult r =
        sid::diagnose(simulate({sid::parse_effect("coulomb_j2:0.3")}, excitation, 51u), options);
    ASSERT_EQ(named_ids(r), std::vector<std::string>{"coulomb_j2"});
    EXPECT_NEAR(r.effects[0].estimate[0], 0.3, 0.05 * 0.3);
  }
  options.integration_window = 0;
  EXPECT_THROW((void)sid::diagnose(simulate({}, Excitation::Paper, 51u), options),
               std::invalid_argument);
}
