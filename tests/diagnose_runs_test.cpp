#include <sid/diagnose_runs.hpp>

#include <gtest/gtest.h>

#include <sid/model/effects.hpp>
#include <sid/model/two_link_arm.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "runs_test_support.hpp"

namespace {

// Three runs of the paper's arm with one effect of the given value added, torques with white
// noise of sigma_tau [N m] (fixed seed).
std::vector<sid::Trajectory<double>> runs_with(const std::string& effect,
                                               const Eigen::VectorXd& values, double sigma_tau,
                                               const sid::EffectSettings& settings = {}) {
  sid::Model<double> model = sid::two_link_arm_model<double>(sid::kPaperGravity);
  model.add(sid::effect_term(sid::Effect(effect), settings));
  Eigen::VectorXd theta(7 + values.size());
  theta << sid::paper_arm_parameters(), values;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, sigma_tau);
  std::vector<sid::Trajectory<double>> runs;
  for (int r = 0; r < 3; ++r) {
    runs.push_back(sid_test::synthetic_run(model, theta, 0.9 * r, 2500, 0.002, 20 + r));
    for (Eigen::Index i = 0; i < runs.back().size(); ++i)
      for (int j = 0; j < 2; ++j) runs.back().tau(i, j) += noise(rng);
  }
  return runs;
}

std::vector<sid::Trajectory<double>> runs_with(const std::string& effect, double value,
                                               double sigma_tau) {
  return runs_with(effect, Eigen::VectorXd::Constant(1, value), sigma_tau);
}

std::vector<std::string> named_ids(const sid::RunsDiagnosis& d) {
  std::vector<std::string> ids;
  for (const auto& e : d.named) ids.push_back(e.effect.id());
  return ids;
}

TEST(DiagnoseRuns, NamesTheCoulombFrictionThatIsThereAndNothingElse) {
  const sid::RunsDiagnosis d = sid::diagnose_runs(runs_with("coulomb_j2", 0.1, 0.01));
  ASSERT_EQ(named_ids(d), std::vector<std::string>{"coulomb_j2"});
  EXPECT_NEAR(d.named[0].estimate.value[0], 0.1, 0.01);
  EXPECT_GT(d.named[0].gain, 0.005);
  EXPECT_LT(d.named[0].p_value, 0.01);
  EXPECT_TRUE(d.final_model.has_term("coulomb_j2"));
  EXPECT_EQ(d.final.fit.theta.size(), 8);
  // Every candidate not named carries its reason.
  for (const auto& t : d.not_named) EXPECT_FALSE(t.reason.empty()) << t.effect.id();
}

TEST(DiagnoseRuns, KeepsTanhForTanhFrictionAndFindsAtanFriction) {
  const sid::RunsDiagnosis tanh = sid::diagnose_runs(runs_with("coulomb_j2", 0.1, 0.01));
  ASSERT_EQ(tanh.friction_shapes.size(), 1u);
  EXPECT_EQ(tanh.friction_shapes[0].shape, sid::CoulombShape::Tanh);
  EXPECT_FALSE(tanh.friction_shapes[0].asymmetric);
  EXPECT_LT(tanh.friction_shapes[0].atan_gain[1], 0.0);
  // atan(qd / 0.05) reaches 94 % of the level only at 0.5 rad/s: visible on these motions.
  sid::EffectSettings atan;
  atan.coulomb_shape = sid::CoulombShape::Atan;
  atan.coulomb_epsilon = 0.05;
  sid::RunsDiagnoseOptions options;
  options.effects.coulomb_epsilon = 0.05;
  const sid::RunsDiagnosis d = sid::diagnose_runs(
      runs_with("coulomb_j2", Eigen::VectorXd::Constant(1, 0.1), 0.01, atan), options);
  ASSERT_EQ(named_ids(d), std::vector<std::string>{"coulomb_j2"});
  ASSERT_EQ(d.friction_shapes.size(), 1u);
  EXPECT_EQ(d.friction_shapes[0].shape, sid::CoulombShape::Atan);
  EXPECT_GT(d.friction_shapes[0].atan_gain[1], 0.005);
  EXPECT_NEAR(d.named[0].estimate.value[0], 0.1, 0.005);
}

TEST(DiagnoseRuns, FindsFrictionThatDiffersByDirection) {
  // Forward 0.15, backward 0.05 N m. Away from reversals such a level looks like a torque
  // offset of 0.05 plus a symmetric 0.1: the two are told apart only near reversals, so the
  // offset is not a candidate here.
  sid::EffectSettings asymmetric;
  asymmetric.coulomb_asymmetric = true;
  sid::RunsDiagnoseOptions options;
  options.candidates = {"coulomb_j1", "spring_j2"};
  const sid::RunsDiagnosis d = sid::diagnose_runs(
      runs_with("coulomb_j1", Eigen::Vector2d(0.1, 0.05), 0.01, asymmetric), options);
  ASSERT_EQ(named_ids(d), std::vector<std::string>{"coulomb_j1"});
  ASSERT_EQ(d.friction_shapes.size(), 1u);
  const sid::FrictionShapeTest& s = d.friction_shapes[0];
  EXPECT_TRUE(s.asymmetric);
  EXPECT_NEAR(s.forward, 0.15, 0.01);
  EXPECT_NEAR(s.backward, 0.05, 0.01);
  EXPECT_EQ(d.final.fit.theta.size(), 9);  // the final model has the dFc column
}

TEST(DiagnoseRuns, NamesARealSpring) {
  // On joint 2: these motions keep q1 within 0.8 rad, where joint 1's spring column k q1 is
  // nearly gravity's sin q1 and is absorbed in theta4.
  const sid::RunsDiagnosis d = sid::diagnose_runs(runs_with("spring_j2", 0.5, 0.01));
  ASSERT_EQ(named_ids(d), std::vector<std::string>{"spring_j2"});
  EXPECT_NEAR(d.named[0].estimate.value[0], 0.5, 0.05);
}

TEST(DiagnoseRuns, NamesNothingOnTheNominalModel) {
  const sid::RunsDiagnosis d = sid::diagnose_runs(runs_with("coulomb_j1", 0.0, 0.01));
  EXPECT_TRUE(d.named.empty()) << d.named.front().effect.id();
  ASSERT_TRUE(d.rotor_coupling.has_value());
  EXPECT_FALSE(d.rotor_coupling->reason.empty());
  // The floor is the torque above the cutoff: about the white noise's share above it.
  for (const auto& f : d.floor)
    for (int j = 0; j < 2; ++j) {
      EXPECT_GT(f[j], 0.005);
      EXPECT_LT(f[j], 0.0101);
    }
}

TEST(DiagnoseRuns, RejectsBadOptions) {
  const auto runs = runs_with("coulomb_j1", 0.0, 0.01);
  const auto expect_error = [&](const sid::RunsDiagnoseOptions& o, const std::string& what) {
    try {
      (void)sid::diagnose_runs(runs, o);
      ADD_FAILURE() << "no error for " << what;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  sid::RunsDiagnoseOptions o;
  o.candidates = {sid::Effect{sid::EffectKind::Coulomb, 2}};
  expect_error(o, "effect joint 2 is outside 0..1");
  o = {};
  o.family_alpha = 0.0;
  expect_error(o, "family_alpha");
  o = {};
  o.min_prediction_gain = -0.1;
  expect_error(o, "min_prediction_gain");
  o = {};
  o.stribeck_velocities = {0.1, std::nan("")};
  expect_error(o, "stribeck_velocities");
  EXPECT_THROW((void)sid::diagnose_runs({}), std::invalid_argument);
}

// The measured runs of a real two-link arm (tests/data/dfki_double_pendulum): the lab fits
// Coulomb friction of 0.093 / 0.078 N m and a rotor of drive 2 on link 1 (Ir = 9.9e-5 kg m^2).
class RealRunsDiagnosis : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::vector<sid::Trajectory<double>> runs;
    for (const char* id : {"00", "01", "02", "03", "05", "12"})
      runs.push_back(sid_test::load_run(id));
    diagnosis_ = sid::diagnose_runs(runs);
  }
  static sid::RunsDiagnosis diagnosis_;
};
sid::RunsDiagnosis RealRunsDiagnosis::diagnosis_;

TEST_F(RealRunsDiagnosis, NamesCoulombFrictionOnBothJointsAndNoSpringOrAngleOffset) {
  const sid::RunsDiagnosis& d = diagnosis_;
  for (const char* joint : {"coulomb_j1", "coulomb_j2"}) {
    const auto it = std::find_if(d.named.begin(), d.named.end(), [&](const auto& e) {
      return e.effect.id() == joint || e.effect.id() == "stribeck_j" + std::string(1, joint[9]);
    });
    ASSERT_NE(it, d.named.end()) << joint << " not named";
    EXPECT_GT(it->estimate.value[0], 0.03) << joint;
    EXPECT_LT(it->estimate.value[0], 0.3) << joint;
  }
  for (const auto& e : d.named) {
    EXPECT_EQ(e.effect.id().rfind("spring", 0), std::string::npos) << e.effect.id();
    if (e.effect.id().rfind("angle_offset", 0) == 0) {
      EXPECT_LT(std::abs(e.estimate.value[0]), 0.02) << e.effect.id();
    }
  }
  // Each named Coulomb friction had its shape tested.
  EXPECT_EQ(d.friction_shapes.size(), 2u);
  // The spring on joint 1 is significant but predicts the held-out runs worse: the case the
  // held-out criterion exists for.
  const auto spring = std::find_if(d.not_named.begin(), d.not_named.end(),
                                   [](const auto& e) { return e.effect.id() == "spring_j1"; });
  ASSERT_NE(spring, d.not_named.end());
  EXPECT_LT(spring->gain, 0.0);
}

TEST_F(RealRunsDiagnosis, SaysWhetherTheRotorCouplingIsSupported) {
  const sid::RunsDiagnosis& d = diagnosis_;
  const bool named = std::any_of(d.named.begin(), d.named.end(),
                                 [](const auto& e) { return e.effect.id() == "armature_j2"; });
  ASSERT_TRUE(named || d.rotor_coupling.has_value());
  if (!named) {
    EXPECT_FALSE(d.rotor_coupling->reason.empty());
    // Ir = Ia / (gr^2 + gr) with gr = 6: the same order as the lab's 9.9e-5 kg m^2.
    const double ir = d.rotor_coupling->estimate.value[0] / 42.0;
    EXPECT_GT(ir, 2e-5);
    EXPECT_LT(ir, 3e-4);
  }
}

TEST_F(RealRunsDiagnosis, FinalModelPredictsHeldOutRunsBetterThanTheLabsModel) {
  // The lab's published model explains these runs with 0.253 / 0.177 N m (mean over the runs,
  // tests/data/dfki_double_pendulum/README.md); each run predicted by the other five's fit.
  const sid::RunsDiagnosis& d = diagnosis_;
  ASSERT_EQ(d.final.left_out_prediction_rms.size(), 6u);
  sid::Vector2<double> mean = sid::Vector2<double>::Zero();
  for (const auto& r : d.final.left_out_prediction_rms) mean += r / 6.0;
  EXPECT_LT(mean[0], 0.9 * 0.253);
  EXPECT_LT(mean[1], 0.9 * 0.177);
  // What no effect explains is reported, and it is not negative.
  EXPECT_GT(d.excess_rms[0], 0.0);
  EXPECT_GE(d.left_out_excess_rms[0], d.excess_rms[0]);
}

}  // namespace
