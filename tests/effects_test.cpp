// Tests of include/sid/model/effects.hpp: every effect term against its closed form written out
// here independently, the exactness of the angle-offset columns against the closed-form inverse
// dynamics at shifted angles, the effectful arm's mass matrix, recovering each effect's physical
// values by least squares, and the parsing of effect specs.

#include <sid/model/effects.hpp>

#include <sid/least_squares.hpp>
#include <sid/model/model.hpp>
#include <sid/model/regressor.hpp>
#include <sid/model/two_link_arm.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Core>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace {

constexpr double kRoundoffTol = 1e-12;    // N m, regressor entries of order 1..100
constexpr double kRecoveryRelTol = 1e-8;  // exact data: only rounding separates fit and truth
constexpr double kPi = 3.14159265358979323846;
constexpr double kG = sid::kPaperGravity;

using V2 = sid::Vector2<double>;

struct State {
  V2 q, qd, qdd;
};

// Angles over a full turn, velocities that cross zero often (so tanh(qd / 0.01) is neither
// saturated everywhere nor linear everywhere), accelerations of the paper's order.
State random_state(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> angle(-kPi, kPi), velocity(-1.5, 1.5), accel(-20, 20);
  State s;
  s.q = V2(angle(rng), angle(rng));
  s.qd = V2(velocity(rng), velocity(rng));
  // A quarter of the samples near zero speed, inside the tanh and Stribeck region.
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  if (unit(rng) < 0.25) s.qd *= 0.02;
  s.qdd = V2(accel(rng), accel(rng));
  return s;
}

Eigen::MatrixXd columns(const sid::Term<double>& term, const State& s) {
  Eigen::Matrix<double, 2, Eigen::Dynamic> out(2, term.size());
  out.setConstant(std::numeric_limits<double>::quiet_NaN());  // every entry must be written
  term.columns(s.q, s.qd, s.qdd, out);
  return out;
}

// The columns of each effect written out from the effect table (docs/discrepancy-workflow.md),
// independently of the header.
Eigen::MatrixXd expected_columns(const std::string& id, const State& s, double eps, double vs) {
  const int j = id.back() == '1' ? 0 : 1;
  const double v = s.qd[j];
  const double sign = std::tanh(v / eps);
  Eigen::MatrixXd z = Eigen::MatrixXd::Zero(2, 1);
  if (id.rfind("coulomb", 0) == 0) {
    z(j, 0) = sign;
  } else if (id.rfind("stribeck", 0) == 0) {
    z = Eigen::MatrixXd::Zero(2, 2);
    z(j, 0) = sign;
    z(j, 1) = std::exp(-(v / vs) * (v / vs)) * sign;
  } else if (id.rfind("torque_offset", 0) == 0) {
    z(j, 0) = 1.0;
  } else if (id == "angle_offset_q1") {
    z = Eigen::MatrixXd::Zero(2, 2);
    z(0, 0) = kG * std::cos(s.q[0]);
    z(0, 1) = z(1, 1) = kG * std::cos(s.q[0] + s.q[1]);
  } else if (id == "angle_offset_q2") {
    // d/dq2 of theta3's column [c2 (2 qdd1 + qdd2) - s2 (2 qd1 + qd2) qd2; c2 qdd1 + s2 qd1^2].
    const double s2 = std::sin(s.q[1]), c2 = std::cos(s.q[1]);
    z = Eigen::MatrixXd::Zero(2, 2);
    z(0, 0) = -s2 * (2 * s.qdd[0] + s.qdd[1]) - c2 * (2 * s.qd[0] + s.qd[1]) * s.qd[1];
    z(1, 0) = -s2 * s.qdd[0] + c2 * s.qd[0] * s.qd[0];
    z(0, 1) = z(1, 1) = kG * std::cos(s.q[0] + s.q[1]);
  } else if (id.rfind("armature", 0) == 0) {
    z(j, 0) = s.qdd[j];
  } else if (id.rfind("spring", 0) == 0) {
    z(j, 0) = s.q[j];
  } else {
    ADD_FAILURE() << "no reference for " << id;
  }
  return z;
}

// Tests address effects by their documented text ids; the library takes them parsed.
sid::Effect parsed(const std::string& id) { return sid::Effect(id); }

const std::vector<std::string>& all_ids() {
  static const std::vector<std::string> ids{
      "coulomb_j1",       "coulomb_j2",       "stribeck_j1",     "stribeck_j2",
      "torque_offset_j1", "torque_offset_j2", "angle_offset_q1", "angle_offset_q2",
      "armature_j1",      "armature_j2",      "spring_j1",       "spring_j2"};
  return ids;
}

// A spec with values of a plausible size for each id.
sid::EffectSpec example_spec(const std::string& id) {
  if (id.rfind("coulomb", 0) == 0) return {parsed(id), {0.15}};
  if (id.rfind("stribeck", 0) == 0) return {parsed(id), {0.1, 0.35, 0.2}};
  if (id.rfind("torque_offset", 0) == 0) return {parsed(id), {-0.07}};
  if (id.rfind("angle_offset", 0) == 0) return {parsed(id), {0.05}};
  if (id.rfind("armature", 0) == 0) return {parsed(id), {0.008}};
  return {parsed(id), {0.3}};  // spring
}

}  // namespace

TEST(Effects, IdsAreInTheDocumentedOrder) {
  std::vector<std::string> ids;
  for (const sid::Effect e : sid::all_effects()) ids.push_back(e.id());
  EXPECT_EQ(ids, all_ids());
  for (const auto& id : all_ids()) EXPECT_EQ(parsed(id).id(), id);
  for (const char* id : {"", "coulomb", "coulomb_j3", "coulomb_j0", "angle_offset_j1", "Coulomb_j1",
                         "coulomb_j1 ", "spring_j12"})
    sid_test::expect_invalid_argument([&] { (void)sid::Effect(std::string(id)); }, "sid::Effect",
                                      "unknown effect id '" + std::string(id) + "'");
}

TEST(Effects, EffectsAreValuesOfKindAndJoint) {
  const sid::Effect coulomb2{sid::EffectKind::Coulomb, 1};
  EXPECT_EQ(coulomb2, sid::Effect("coulomb_j2"));
  EXPECT_NE(coulomb2, sid::Effect("coulomb_j1"));
  EXPECT_NE(coulomb2, sid::Effect("stribeck_j2"));
  EXPECT_EQ(sid::Effect("angle_offset_q1"), (sid::Effect{sid::EffectKind::AngleOffset, 0}));
  EXPECT_EQ(sid::contained_effect("stribeck_j2"), std::optional<sid::Effect>(coulomb2));
  EXPECT_FALSE(sid::contained_effect("coulomb_j2").has_value());
  EXPECT_TRUE(sid::is_dynamic_effect("spring_j1"));
  EXPECT_FALSE(sid::is_dynamic_effect("torque_offset_j2"));
}

TEST(Effects, TermColumnsMatchTheClosedFormsAtRandomStates) {
  std::mt19937_64 rng(11);
  for (const double eps : {0.01, 0.05}) {
    for (const double vs : {0.2, 0.07}) {
      sid::EffectSettings settings;
      settings.coulomb_epsilon = eps;
      settings.stribeck_velocity = vs;
      for (const auto& id : all_ids()) {
        const sid::Term<double> term = sid::effect_term(parsed(id), settings);
        EXPECT_EQ(term.name, id);
        for (int trial = 0; trial < 50; ++trial) {
          const State s = random_state(rng);
          const Eigen::MatrixXd got = columns(term, s);
          const Eigen::MatrixXd want = expected_columns(id, s, eps, vs);
          ASSERT_EQ(got.cols(), want.cols()) << id;
          EXPECT_LT((got - want).cwiseAbs().maxCoeff(), kRoundoffTol)
              << id << " eps=" << eps << " vs=" << vs << "\n"
              << got << "\nwant\n"
              << want;
        }
      }
    }
  }
}

TEST(Effects, StribeckColumnIsFiniteAtExtremeVelocities) {
  const sid::Term<double> term = sid::effect_term("stribeck_j2");
  for (const double v : {1e300, -1e300, std::numeric_limits<double>::infinity(), 0.0, -1e-300}) {
    const State s{V2::Zero(), V2(0.0, v), V2::Zero()};
    const Eigen::MatrixXd z = columns(term, s);
    EXPECT_TRUE(z.allFinite()) << v << "\n" << z;
    if (std::abs(v) > 1e3) {
      EXPECT_EQ(z(1, 0), v > 0 ? 1.0 : -1.0) << v;
      EXPECT_EQ(z(1, 1), 0.0) << v;
    }
  }
}

TEST(Effects, ParameterAndValueNames) {
  using Names = std::vector<std::string>;
  const std::vector<std::pair<std::string, std::pair<Names, Names>>> cases{
      {"coulomb_j1", {{"coulomb_j1.Fc"}, {"Fc"}}},
      {"stribeck_j2", {{"stribeck_j2.Fc", "stribeck_j2.Fs_minus_Fc"}, {"Fc", "Fs", "vs"}}},
      {"torque_offset_j2", {{"torque_offset_j2.b"}, {"b"}}},
      {"angle_offset_q1",
       {{"angle_offset_q1.theta4_sin", "angle_offset_q1.theta5_sin"}, {"delta"}}},
      {"angle_offset_q2",
       {{"angle_offset_q2.theta3_sin", "angle_offset_q2.theta5_sin"}, {"delta"}}},
      {"armature_j2", {{"armature_j2.Ia"}, {"Ia"}}},
      {"spring_j1", {{"spring_j1.k"}, {"k"}}},
  };
  for (const auto& [id, names] : cases) {
    EXPECT_EQ(sid::effect_term(parsed(id)).parameter_names, names.first) << id;
    EXPECT_EQ(sid::effect_value_names(parsed(id)), names.second) << id;
    EXPECT_EQ(sid::effect_value_units(parsed(id)).size(), names.second.size()) << id;
  }
  EXPECT_EQ(sid::effect_name("coulomb_j2"), "Coulomb friction on joint 2");
  EXPECT_NE(sid::effect_name("torque_offset_j1").find("constant load"), std::string::npos);
  EXPECT_NE(sid::effect_name("angle_offset_q1").find("tilt"), std::string::npos);
  EXPECT_NE(sid::effect_name("armature_j1").find("theta1"), std::string::npos);
  for (const auto& id : all_ids()) EXPECT_FALSE(sid::effect_name(parsed(id)).empty()) << id;
}

TEST(Effects, UnknownIdIsRefusedWithTheListOfValidIds) {
  for (const auto& call : std::vector<std::pair<std::string, std::function<void()>>>{
           {"sid::Effect", [] { (void)sid::Effect("coulomb_j3"); }},
           {"sid::parse_effect", [] { (void)sid::parse_effect("coulomb_j3:0.1"); }}}) {
    sid_test::expect_invalid_argument(call.second, call.first, "unknown effect id 'coulomb_j3'");
    for (const auto& id : all_ids()) sid_test::expect_invalid_argument(call.second, call.first, id);
  }
  // An effect built from its parts can still name a joint the library does not serve.
  const sid::Effect third{sid::EffectKind::Coulomb, 2};
  sid_test::expect_invalid_argument([&] { (void)sid::effect_term(third); }, "sid::effect_term",
                                    "effect joint 2 is outside 0..1");
  sid_test::expect_invalid_argument(
      [&] {
        sid::validate_effect({third, {0.1}});
      },
      "sid::validate_effect", "effect joint 2 is outside 0..1");
}

TEST(Effects, BadSettingsAreRefused) {
  sid::EffectSettings s;
  s.coulomb_epsilon = 0.0;
  sid_test::expect_invalid_argument([&] { (void)sid::effect_term("coulomb_j1", s); },
                                    "sid::effect_term", "coulomb_epsilon");
  s = {};
  s.stribeck_velocity = -0.2;
  sid_test::expect_invalid_argument([&] { (void)sid::effect_term("stribeck_j1", s); },
                                    "sid::effect_term", "stribeck_velocity");
  s = {};
  s.gravity = std::numeric_limits<double>::quiet_NaN();
  sid_test::expect_invalid_argument([&] { (void)sid::effect_term("angle_offset_q1", s); },
                                    "sid::effect_term", "gravity");
}

// The claim that makes an angle-offset fit exact rather than linearised: with the old columns'
// coefficients scaled by cos(delta) and the new ones carrying theta sin(delta), the model at the
// measured angle equals the arm at the true angle q_m + delta e_j.
TEST(Effects, AngleOffsetColumnsAreExact) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> offset(-1.4, 1.4);
  const sid::TwoLinkParameters<double> theta = sid::paper_arm_parameters();
  for (const int j : {0, 1}) {
    const std::string id = j == 0 ? "angle_offset_q1" : "angle_offset_q2";
    sid::Model<double> model = sid::two_link_arm_model<double>(kG);
    model.add(sid::effect_term(parsed(id)));
    for (int trial = 0; trial < 200; ++trial) {
      const double delta = offset(rng);
      const State s = random_state(rng);
      Eigen::VectorXd aug(9);
      aug.head<7>() = theta;
      const double c = std::cos(delta), sn = std::sin(delta);
      if (j == 0) {
        aug[3] *= c;
        aug[4] *= c;
        aug[7] = theta[3] * sn;
        aug[8] = theta[4] * sn;
      } else {
        aug[2] *= c;
        aug[4] *= c;
        aug[7] = theta[2] * sn;
        aug[8] = theta[4] * sn;
      }
      V2 q_true = s.q;
      q_true[j] += delta;
      const V2 want = sid::two_link_inverse_dynamics(theta, q_true, s.qd, s.qdd, kG);
      const V2 got = model.inverse_dynamics(aug, s.q, s.qd, s.qdd);
      EXPECT_LT((got - want).cwiseAbs().maxCoeff(), kRoundoffTol)
          << id << " delta=" << delta << " got " << got.transpose() << " want " << want.transpose();
    }
  }
}

TEST(Effects, ArmatureAddsToTheMassMatrixDiagonal) {
  std::mt19937_64 rng(8);
  const sid::TwoLinkParameters<double> theta = sid::paper_arm_parameters();
  const double ia = 0.0061;
  const sid::EffectfulArm a2 = sid::effectful_arm(theta, {{"armature_j2", {ia}}});
  const sid::EffectfulArm a1 = sid::effectful_arm(theta, {{"armature_j1", {ia}}});
  const sid::Term<double> rigid = sid::two_link_rigid_body_term<double>(kG);
  const sid::Term<double> arm1 = sid::effect_term("armature_j1");
  for (int trial = 0; trial < 50; ++trial) {
    const State s = random_state(rng);
    const sid::Matrix2<double> d = sid::two_link_mass_matrix(theta, s.q);
    sid::Matrix2<double> d2 = d, d1 = d;
    d2(1, 1) += ia;
    d1(0, 0) += ia;
    EXPECT_LT((a2.model.mass_matrix(a2.theta, s.q) - d2).cwiseAbs().maxCoeff(), kRoundoffTol);
    EXPECT_LT((a1.model.mass_matrix(a1.theta, s.q) - d1).cwiseAbs().maxCoeff(), kRoundoffTol);
    // armature_j1's column is theta1's column: the two cannot be told apart.
    EXPECT_EQ(columns(arm1, s).col(0), columns(rigid, s).col(0));
  }
}

TEST(Effects, EffectfulArmAddsTheDynamicEffectsAndReturnsTheOffsets) {
  const sid::TwoLinkParameters<double> theta = sid::paper_arm_parameters();
  const std::vector<sid::EffectSpec> specs{
      {"coulomb_j1", {0.2}},       {"stribeck_j2", {0.1, 0.4, 0.3}},
      {"spring_j1", {0.5}},        {"torque_offset_j2", {-0.08}},
      {"angle_offset_q1", {0.03}}, {"angle_offset_q2", {-0.02}}};
  sid::EffectSettings settings;
  settings.coulomb_epsilon = 0.02;
  const sid::EffectfulArm arm = sid::effectful_arm(theta, specs, settings);
  EXPECT_TRUE(arm.model.has_term("coulomb_j1"));
  EXPECT_TRUE(arm.model.has_term("stribeck_j2"));
  EXPECT_TRUE(arm.model.has_term("spring_j1"));
  EXPECT_FALSE(arm.model.has_term("torque_offset_j2"));
  EXPECT_FALSE(arm.model.has_term("angle_offset_q1"));
  EXPECT_EQ(arm.theta.size(), 7 + 1 + 2 + 1);
  EXPECT_EQ(arm.torque_offset, V2(0.0, -0.08));
  EXPECT_EQ(arm.angle_offset, V2(0.03, -0.02));
  std::mt19937_64 rng(3);
  for (int trial = 0; trial < 100; ++trial) {
    const State s = random_state(rng);
    V2 want = sid::two_link_inverse_dynamics(theta, s.q, s.qd, s.qdd, kG);
    want[0] += 0.2 * std::tanh(s.qd[0] / 0.02) + 0.5 * s.q[0];
    const double v = s.qd[1] / 0.3;
    want[1] += (0.1 + (0.4 - 0.1) * std::exp(-v * v)) * std::tanh(s.qd[1] / 0.02);
    const V2 got = arm.model.inverse_dynamics(arm.theta, s.q, s.qd, s.qdd);
    EXPECT_LT((got - want).cwiseAbs().maxCoeff(), kRoundoffTol) << got.transpose();
  }
}

TEST(Effects, EffectfulArmRefusesDuplicatesAndBadSpecs) {
  const sid::TwoLinkParameters<double> theta = sid::paper_arm_parameters();
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::effectful_arm(theta, {{"coulomb_j1", {0.1}}, {"coulomb_j1", {0.2}}});
      },
      "sid::effectful_arm", "'coulomb_j1' is given more than once");
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::effectful_arm(theta, {{"coulomb_j1", {-0.1}}});
      },
      "sid::effectful_arm", "Fc must be > 0");
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::effectful_arm(theta, {{"spring_j2", {1.0, 2.0}}});
      },
      "sid::effectful_arm", "needs 1 value");
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::effectful_arm(theta, {{sid::Effect{sid::EffectKind::Spring, 5}, {1.0}}});
      },
      "sid::effectful_arm", "effect joint 5 is outside");
  const sid::EffectfulArm none = sid::effectful_arm(theta, {});
  EXPECT_EQ(none.theta, Eigen::VectorXd(theta));
  EXPECT_EQ(none.model.num_parameters(), 7);
}

namespace {

// Exact measured torques of the arm with one hidden effect, in measured coordinates.
V2 measured_torque(const sid::EffectSpec& spec, const State& s) {
  const sid::TwoLinkParameters<double> theta = sid::paper_arm_parameters();
  const sid::EffectfulArm arm = sid::effectful_arm(theta, {spec});
  V2 q_true = s.q + arm.angle_offset;
  return arm.model.inverse_dynamics(arm.theta, q_true, s.qd, s.qdd) + arm.torque_offset;
}

struct Fit {
  sid::Model<double> model;
  sid::LeastSquaresResult<double> ls;
};

Fit fit_with_effect(const std::string& id, const std::vector<State>& states,
                    const std::vector<V2>& tau, const sid::EffectSettings& settings) {
  sid::Model<double> model = sid::two_link_arm_model<double>(kG);
  model.add(sid::effect_term(parsed(id), settings));
  sid::Kinematics<double> k;
  const auto n = static_cast<Eigen::Index>(states.size());
  k.t = Eigen::VectorXd::LinSpaced(n, 0.0, 1.0);
  k.q.resize(n, 2);
  k.qd.resize(n, 2);
  k.qdd.resize(n, 2);
  k.tau.resize(n, 2);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& s = states[static_cast<std::size_t>(i)];
    k.q.row(i) = s.q.transpose();
    k.qd.row(i) = s.qd.transpose();
    k.qdd.row(i) = s.qdd.transpose();
    k.tau.row(i) = tau[static_cast<std::size_t>(i)].transpose();
  }
  const sid::StackedRegression<double> r = sid::stack_regression(model, k);
  return {model, sid::least_squares(r.X, r.y, 2)};
}

}  // namespace

TEST(Effects, EstimateRecoversEveryEffectFromExactTorques) {
  std::mt19937_64 rng(21);
  std::vector<State> states;
  for (int i = 0; i < 400; ++i) states.push_back(random_state(rng));
  for (const auto& id : all_ids()) {
    if (id == "armature_j1") continue;  // theta1's column: not identifiable
    for (const double scale : {1.0, -1.0}) {
      sid::EffectSpec spec = example_spec(id);
      // Offsets and angles take either sign; the other effects must stay admissible.
      if (id.find("offset") != std::string::npos)
        spec.values[0] *= scale;
      else if (scale < 0)
        continue;
      sid::EffectSettings settings;
      if (id.rfind("stribeck", 0) == 0) settings.stribeck_velocity = spec.values[2];
      std::vector<V2> tau;
      for (const auto& s : states) tau.push_back(measured_torque(spec, s));
      const Fit fit = fit_with_effect(id, states, tau, settings);
      ASSERT_TRUE(fit.ls.ok()) << id << ": " << fit.ls.message;
      const sid::EffectEstimate e =
          sid::effect_estimate(parsed(id), fit.ls.theta, fit.ls.covariance, fit.model, settings);
      EXPECT_EQ(e.effect.id(), id);
      ASSERT_EQ(e.value.size(), static_cast<Eigen::Index>(spec.values.size())) << id;
      ASSERT_EQ(e.std.size(), e.value.size()) << id;
      for (std::size_t i = 0; i < spec.values.size(); ++i)
        EXPECT_NEAR(e.value[static_cast<Eigen::Index>(i)], spec.values[i],
                    kRecoveryRelTol * std::abs(spec.values[i]))
            << id << " value " << i;
    }
  }
}

TEST(Effects, EstimateStandardDeviationsAreFiniteAndConsistentWithNoisyTorques) {
  std::mt19937_64 rng(4);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<State> states;
  for (int i = 0; i < 400; ++i) states.push_back(random_state(rng));
  for (const auto& id : all_ids()) {
    if (id == "armature_j1") continue;
    const sid::EffectSpec spec = example_spec(id);
    sid::EffectSettings settings;
    if (id.rfind("stribeck", 0) == 0) settings.stribeck_velocity = spec.values[2];
    std::vector<V2> tau;
    for (const auto& s : states)
      tau.push_back(measured_torque(spec, s) + V2(noise(rng), noise(rng)));
    const Fit fit = fit_with_effect(id, states, tau, settings);
    ASSERT_TRUE(fit.ls.ok()) << id;
    const sid::EffectEstimate e =
        sid::effect_estimate(parsed(id), fit.ls.theta, fit.ls.covariance, fit.model, settings);
    for (Eigen::Index i = 0; i < e.value.size(); ++i) {
      if (id.rfind("stribeck", 0) == 0 && i == 2) {
        EXPECT_EQ(e.std[i], 0.0) << "vs is fixed, not estimated";
        continue;
      }
      EXPECT_TRUE(std::isfinite(e.std[i])) << id;
      EXPECT_GT(e.std[i], 0.0) << id;
      // 5 sigma: a wrong delta-method gradient would miss by far more, or inflate std far more.
      EXPECT_LT(std::abs(e.value[i] - spec.values[static_cast<std::size_t>(i)]), 5.0 * e.std[i])
          << id << " value " << i << " std " << e.std[i];
      EXPECT_LT(e.std[i], 0.5 * std::abs(spec.values[static_cast<std::size_t>(i)])) << id;
    }
  }
}

// The delta-method standard deviation of an angle offset against the spread of estimates over
// independent noise draws (an independent, sampling-based reference).
TEST(Effects, AngleOffsetStandardDeviationMatchesTheSpreadOverNoiseDraws) {
  std::mt19937_64 rng(9);
  std::vector<State> states;
  for (int i = 0; i < 300; ++i) states.push_back(random_state(rng));
  const sid::EffectSpec spec{"angle_offset_q2", {0.06}};
  std::vector<V2> exact;
  for (const auto& s : states) exact.push_back(measured_torque(spec, s));
  std::normal_distribution<double> noise(0.0, 0.05);
  constexpr int kRuns = 200;
  double sum = 0.0, sum2 = 0.0, reported = 0.0;
  for (int run = 0; run < kRuns; ++run) {
    std::vector<V2> tau = exact;
    for (auto& t : tau) t += V2(noise(rng), noise(rng));
    const Fit fit = fit_with_effect(spec.effect.id(), states, tau, {});
    const sid::EffectEstimate e =
        sid::effect_estimate(spec.effect, fit.ls.theta, fit.ls.covariance, fit.model);
    sum += e.value[0];
    sum2 += e.value[0] * e.value[0];
    reported += e.std[0] / kRuns;
  }
  const double mean = sum / kRuns;
  const double spread = std::sqrt((sum2 - kRuns * mean * mean) / (kRuns - 1));
  // The sample standard deviation of 200 draws has a relative standard error of 5 %.
  EXPECT_NEAR(reported / spread, 1.0, 0.2) << "reported " << reported << " spread " << spread;
}

TEST(Effects, EstimateRefusesAModelWithoutTheTermOrWrongSizes) {
  const sid::Model<double> model = sid::two_link_arm_model<double>(kG);
  const Eigen::VectorXd theta = Eigen::VectorXd::Ones(7);
  const Eigen::MatrixXd cov = Eigen::MatrixXd::Identity(7, 7);
  sid_test::expect_invalid_argument(
      [&] { (void)sid::effect_estimate("coulomb_j1", theta, cov, model); }, "sid::effect_estimate",
      "no term 'coulomb_j1'");
  sid_test::expect_invalid_argument(
      [&] { (void)sid::effect_estimate("coulomb_j1", Eigen::VectorXd::Ones(6), cov, model); },
      "sid::effect_estimate", "theta_full has 6 entries");
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::effect_estimate("coulomb_j1", theta, Eigen::MatrixXd::Identity(6, 6), model);
      },
      "sid::effect_estimate", "covariance_full is 6 x 6");
  sid::Model<double> no_rigid;
  no_rigid.add(sid::effect_term("angle_offset_q1"));
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::effect_estimate("angle_offset_q1", Eigen::VectorXd::Ones(2),
                                   Eigen::MatrixXd::Identity(2, 2), no_rigid);
      },
      "sid::effect_estimate", "rigid_body");
}

TEST(Effects, ParseEffectReadsGoodSpecs) {
  const std::vector<std::pair<std::string, sid::EffectSpec>> cases{
      {"coulomb_j2:0.1", {"coulomb_j2", {0.1}}},
      {"stribeck_j1:0.1,0.3,0.2", {"stribeck_j1", {0.1, 0.3, 0.2}}},
      {"stribeck_j2:0.1, 0.3 ,2e-1", {"stribeck_j2", {0.1, 0.3, 0.2}}},
      {"angle_offset_q1:0.05", {"angle_offset_q1", {0.05}}},
      {"angle_offset_q2:-1.5", {"angle_offset_q2", {-1.5}}},
      {"torque_offset_j1:-0.07", {"torque_offset_j1", {-0.07}}},
      {"torque_offset_j2:0", {"torque_offset_j2", {0.0}}},
      {"armature_j1:0.004", {"armature_j1", {0.004}}},
      {"armature_j2:6e-3", {"armature_j2", {0.006}}},
      {"spring_j1:0.5", {"spring_j1", {0.5}}},
  };
  for (const auto& [text, want] : cases) {
    const sid::EffectSpec got = sid::parse_effect(text);
    EXPECT_EQ(got.effect.id(), want.effect.id()) << text;
    EXPECT_EQ(got.values, want.values) << text;
  }
}

TEST(Effects, ParseEffectRefusesBadSpecsNamingTheProblem) {
  const std::vector<std::pair<std::string, std::string>> cases{
      {"friction_j1:0.1", "unknown effect id 'friction_j1'"},
      {"coulomb_j1", "has no ':'"},
      {"coulomb_j1=0.1", "has no ':'"},
      {"coulomb_j1:", "value 1 '' is not a number"},
      {"coulomb_j1:abc", "value 1 'abc' is not a number"},
      {"coulomb_j1:0.1,", "value 2 '' is not a number"},
      {"coulomb_j1:0.1x", "value 1 '0.1x' is not a number"},
      {"coulomb_j1:0.1,0.2", "needs 1 value (Fc), got 2"},
      {"stribeck_j1:0.1,0.3", "needs 3 values (Fc,Fs,vs), got 2"},
      {"coulomb_j1:nan", "Fc must be finite"},
      {"torque_offset_j1:inf", "b must be finite"},
      {"coulomb_j1:0", "Fc must be > 0"},
      {"coulomb_j2:-0.1", "Fc must be > 0"},
      {"stribeck_j1:0.3,0.3,0.2", "Fs must be > Fc"},
      {"stribeck_j1:0.3,0.1,0.2", "Fs must be > Fc"},
      {"stribeck_j1:0.1,0.3,0", "vs must be > 0"},
      {"stribeck_j2:0.1,0.3,-0.2", "vs must be > 0"},
      {"stribeck_j2:-0.1,0.3,0.2", "Fc must be > 0"},
      {"armature_j2:0", "Ia must be > 0"},
      {"armature_j1:-0.001", "Ia must be > 0"},
      {"spring_j1:0", "k must be > 0"},
      {"spring_j2:-3", "k must be > 0"},
      {"angle_offset_q1:1.5708", "|delta| must be < pi/2"},
      {"angle_offset_q2:-2", "|delta| must be < pi/2"},
  };
  for (const auto& [text, what] : cases)
    sid_test::expect_invalid_argument([&] { (void)sid::parse_effect(text); }, "sid::parse_effect",
                                      what);
}
