// Tests of the output-error friction test (sid/cvode/friction_refinement.hpp) on data simulated
// with hidden friction: Stribeck friction is named as such on both excitations, with Fc and Fs
// within 15 % (the torque-domain stage alone leaves Fs 20-40 % low on the paper's excitation and
// names joint 1's bump as Coulomb friction in half the seeds), and Coulomb friction stays
// Coulomb.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <sid/cvode/friction_refinement.hpp>
#include <sid/diagnose.hpp>
#include <string>
#include <vector>

#include "hidden_effect_data.hpp"
#include "test_support.hpp"

namespace {

using sid::test::Excitation;
using sid::test::simulate;

constexpr double kFrictionLevelTolerance = 0.15;  // relative error allowed on Fc and Fs
constexpr double kVelocityTolerance = 0.25;       // on vs, the bump's width (its std is 5-15 %)

struct Refined {
  sid::DiagnosisResult before, after;
};

Refined refine(const std::string& spec, Excitation excitation, unsigned seed) {
  const sid::Trajectory<double> data = simulate({sid::parse_effect(spec)}, excitation, seed);
  Refined r;
  r.before = sid::diagnose(data);
  r.after = r.before;
  r.after = sid::refine_named_friction(r.after, data, sid::DiagnoseOptions());
  return r;
}

std::vector<std::string> ids(const sid::DiagnosisResult& r) {
  std::vector<std::string> out;
  for (const auto& e : r.effects) out.push_back(e.effect.id());
  return out;
}

TEST(FrictionRefinement, NamesStribeckFrictionAndItsValuesOnBothExcitations) {
  for (const auto& [excitation, seed] : sid::test::case_data_sets(11u, 12u))
    for (int joint : {1, 2}) {
      const std::string j = std::to_string(joint);
      SCOPED_TRACE(sid::test::excitation_name(excitation) + " joint " + j + " seed " +
                   std::to_string(seed));
      const Refined r = refine("stribeck_j" + j + ":0.1,0.3,0.2", excitation, seed);
      ASSERT_EQ(ids(r.after), std::vector<std::string>{"stribeck_j" + j});
      ASSERT_EQ(r.after.friction_checks.size(), 1u);
      const sid::FrictionCheck& c = r.after.friction_checks[0];
      EXPECT_EQ(c.joint, joint);
      EXPECT_EQ(c.chosen.id(), "stribeck_j" + j);
      EXPECT_TRUE(c.stribeck_fitted) << "the screen must let a real bump through";
      if (c.named.id() == "coulomb_j" + j)
        EXPECT_GE(c.score, sid::FrictionRefinementOptions().screen_level);
      else  // the torque-domain tests saw the bump: it is fitted first, without the screen
        EXPECT_TRUE(std::isnan(c.score)) << c.score;
      EXPECT_LT(c.p_value, 1e-6);
      EXPECT_TRUE(c.message.empty()) << c.message;
      // The fit leaves about the angle noise (0.95-1.12 here: what the smoothed torque's
      // error leaves beyond the windows' offsets and slopes).
      EXPECT_NEAR(c.normalized_rms_stribeck, 1.0, 0.2);
      EXPECT_GT(c.normalized_rms_coulomb, c.normalized_rms_stribeck);
      const sid::NamedEffect& e = r.after.effects[0];
      EXPECT_NEAR(e.estimate[0], 0.1, kFrictionLevelTolerance * 0.1) << "Fc";
      EXPECT_NEAR(e.estimate[1], 0.3, kFrictionLevelTolerance * 0.3) << "Fs";
      EXPECT_NEAR(e.estimate[2], 0.2, kVelocityTolerance * 0.2) << "vs";
      for (int v = 0; v < 3; ++v) EXPECT_GT(e.std[v], 0.0) << "every value has a std";
      EXPECT_NE(e.note.find("output-error"), std::string::npos) << e.note;
      // The torque-domain report follows the chosen curve, and the gap closes.
      EXPECT_DOUBLE_EQ(r.after.final_settings[0].stribeck_velocity, e.estimate[2]);
      EXPECT_LE(r.after.final.excess_rms[joint - 1], 0.5 * r.after.nominal.excess_rms[joint - 1]);
    }
}

TEST(FrictionRefinement, KeepsCoulombFrictionCoulomb) {
  for (const auto& [excitation, seed] : sid::test::case_data_sets(11u, 12u))
    for (const std::string spec : {"coulomb_j1:0.1", "coulomb_j2:0.2"}) {
      SCOPED_TRACE(sid::test::excitation_name(excitation) + " " + spec + " seed " +
                   std::to_string(seed));
      const Refined r = refine(spec, excitation, seed);
      const std::string id = spec.substr(0, spec.find(':'));
      ASSERT_EQ(ids(r.after), std::vector<std::string>{id});
      ASSERT_EQ(r.after.friction_checks.size(), 1u);
      const sid::FrictionCheck& c = r.after.friction_checks[0];
      EXPECT_EQ(c.chosen.id(), id);
      // Either the screen found no bump worth fitting, or the fit found none significant.
      if (c.stribeck_fitted)
        EXPECT_GT(c.p_value, 0.01) << "score " << c.score;
      else
        EXPECT_LT(c.score, sid::FrictionRefinementOptions().screen_level);
      // Nothing changed but the note: the torque-domain estimate stands.
      EXPECT_EQ(r.after.effects[0].estimate, r.before.effects[0].estimate);
      EXPECT_NE(r.after.effects[0].note.find("Coulomb, not Stribeck"), std::string::npos);
    }
}

// Coulomb data that the torque-domain tests had named Stribeck (here by hand: a bump of 0.05
// put after Fc): the Stribeck curve is fitted first and the Coulomb one only to 1 % of the gap,
// but when Coulomb is chosen its values are those of a Coulomb fit taken to its minimum, as if
// Coulomb had been named.
TEST(FrictionRefinement, ChoosesCoulombOverANamedBumpWithTheValuesOfAFullCoulombFit) {
  const sid::Trajectory<double> data =
      simulate({sid::parse_effect("coulomb_j2:0.2")}, Excitation::Paper, 11u);
  const sid::DiagnosisResult coulomb = sid::diagnose(data);
  ASSERT_EQ(ids(coulomb), std::vector<std::string>{"coulomb_j2"});
  sid::DiagnosisResult bump = coulomb;
  bump.effects[0].effect = "stribeck_j2";
  bump.final_settings[0].stribeck_velocity = 0.2;
  bump.final_model = sid::two_link_arm_model<double>(sid::kPaperGravity);
  bump.final_model.add(sid::effect_term(bump.effects[0].effect, bump.final_settings[0]));
  const Eigen::Index fc = coulomb.final_model.parameter_offset("coulomb_j2");
  auto insert_after_fc = [&](const Eigen::VectorXd& v, double value) {
    Eigen::VectorXd out(v.size() + 1);
    out << v.head(fc + 1), value, v.tail(v.size() - fc - 1);
    return out;
  };
  bump.final.theta = insert_after_fc(coulomb.final.theta, 0.05);
  bump.final.std = insert_after_fc(coulomb.final.std, 0.01);

  const sid::FrictionRefinement as_named_coulomb = sid::refine_friction(coulomb, data, 2);
  const sid::FrictionRefinement as_named_stribeck = sid::refine_friction(bump, data, 2);
  ASSERT_TRUE(as_named_coulomb.ok() && as_named_stribeck.ok()) << as_named_stribeck.check.message;
  const sid::FrictionCheck& c = as_named_stribeck.check;
  EXPECT_EQ(c.named.id(), "stribeck_j2");
  EXPECT_EQ(c.chosen.id(), "coulomb_j2") << "likelihood ratio " << c.statistic;
  EXPECT_TRUE(c.stribeck_fitted);
  EXPECT_TRUE(std::isnan(c.score)) << "no screen when the bump was named";
  EXPECT_TRUE(as_named_stribeck.coulomb.converged) << as_named_stribeck.coulomb.message;
  ASSERT_EQ(as_named_stribeck.estimate.size(), 1);
  EXPECT_NEAR(as_named_stribeck.estimate[0], 0.2, kFrictionLevelTolerance * 0.2);
  // The same minimum from either start: within a fifth of its std.
  EXPECT_NEAR(as_named_stribeck.estimate[0], as_named_coulomb.estimate[0],
              0.2 * as_named_coulomb.std[0]);
  EXPECT_NEAR(as_named_stribeck.coulomb.cost, as_named_coulomb.coulomb.cost, 1.0);
}

TEST(FrictionRefinement, LeavesDataWithoutFrictionAlone) {
  const sid::Trajectory<double> data =
      simulate({sid::parse_effect("torque_offset_j2:0.1")}, Excitation::Paper, 11u);
  sid::DiagnosisResult r = sid::diagnose(data);
  const auto before = ids(r);
  r = sid::refine_named_friction(std::move(r), data, sid::DiagnoseOptions());
  EXPECT_EQ(ids(r), before);
  EXPECT_TRUE(r.friction_checks.empty());
}

TEST(FrictionRefinement, WindowsCoverEachReversalOnceAndAStickAsOne) {
  sid::Kinematics<double> k;
  const Eigen::Index n = 1001;
  k.t = Eigen::VectorXd::LinSpaced(n, 0.0, 10.0);  // 10 ms steps
  k.q = k.qdd = k.tau = sid::MatrixX2<double>::Zero(n, 2);
  k.qd.resize(n, 2);
  k.qd.col(0) = (k.t.array() * 0.5).cos();  // reversals at pi and 3 pi
  k.qd.col(1).setConstant(1.0);
  // A stick at t = 6..6.2 s that chatters around zero: one event, not four.
  for (Eigen::Index i = 0; i < n; ++i)
    if (k.t[i] > 6.0 && k.t[i] < 6.2) k.qd(i, 1) = (i % 5 < 2) ? -1e-3 : 1e-3;
  sid::FrictionRefinementOptions o;
  const auto first = sid::detail::reversal_windows(k, 0, o);
  ASSERT_EQ(first.size(), 2u);
  for (const auto& w : first) {
    const double mid = k.t[w.begin] + o.before;
    EXPECT_NEAR(std::remainder(mid - M_PI, 2.0 * M_PI), 0.0, 0.011);
    EXPECT_NEAR(k.t[w.end - 1] - k.t[w.begin], o.before + o.after, 0.011);
    EXPECT_EQ(w.q0, k.q.row(w.begin).transpose());
  }
  const auto second = sid::detail::reversal_windows(k, 1, o);
  ASSERT_EQ(second.size(), 1u);
  EXPECT_NEAR(k.t[second[0].begin], 6.0 - o.before, 0.011);
  double last_change = 0;
  for (Eigen::Index i = 1; i < n; ++i)
    if ((k.qd(i - 1, 1) > 0.0) != (k.qd(i, 1) > 0.0)) last_change = k.t[i];
  EXPECT_GT(last_change, 6.1);
  EXPECT_NEAR(k.t[second[0].end - 1], last_change + o.after, 0.011);
  o.max_windows = 1;
  EXPECT_EQ(sid::detail::reversal_windows(k, 0, o).size(), 1u);
}

TEST(FrictionRefinement, RefusesWhatItCannotTest) {
  const sid::Trajectory<double> data =
      simulate({sid::parse_effect("coulomb_j2:0.2")}, Excitation::Paper, 11u);
  const sid::DiagnosisResult r = sid::diagnose(data);
  sid_test::expect_invalid_argument([&] { (void)sid::refine_friction(r, data, 3); },
                                    "sid::refine_friction: ", "joint must be 1 or 2");
  sid_test::expect_invalid_argument([&] { (void)sid::refine_friction(r, data, 1); },
                                    "sid::refine_friction: ", "no friction of joint 1");
  sid::Trajectory<double> shorter = data;
  shorter.t.conservativeResize(100);
  shorter.q.conservativeResize(100, 2);
  shorter.tau.conservativeResize(100, 2);
  sid_test::expect_invalid_argument([&] { (void)sid::refine_friction(r, shorter, 2); },
                                    "sid::refine_friction: ", "does not hold the samples");
}

}  // namespace
