// Tests of sid/identify_chain.hpp and the chain model under it (sid/model/chain_model.hpp,
// sid/model/transmission.hpp, base_parameters_in_order): the transmission keeps the drives'
// power, the drive terms are the columns they claim, the TX40's base parameters are the
// combinations FIGAROH published, and a simulated arm on a jittered grid is identified back.

#include <sid/identify_chain.hpp>
#include <sid/chain_consistency.hpp>
#include <sid/model/urdf.hpp>

#include "chain_simulation.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

/// The TX40's transmission as FIGAROH states it: N = [32, 32, 45, -48, 45, 32], the sixth motor
/// also turning with joint 5, and the modified-DH zero of joints 2 and 3.
sid::Transmission tx40_transmission() {
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(6, 6);
  const double n[6] = {32, 32, 45, -48, 45, 32};
  for (int i = 0; i < 6; ++i) g(i, i) = n[i];
  g(5, 4) = n[5];
  Eigen::VectorXd zero = Eigen::VectorXd::Zero(6);
  zero[1] = -M_PI / 2;
  zero[2] = M_PI / 2;
  return sid::Transmission(g, zero);
}

sid::ChainModel tx40_model(const std::vector<sid::DriveTermKind>& kinds,
                           double coulomb_epsilon = 0.01) {
  const sid::UrdfChain arm = sid::chain_from_urdf(
      sid_test::read_text("staubli_tx40/tx40_mdh_modified.urdf"), "base_link", "tool0");
  const sid::Transmission t = tx40_transmission();
  return sid::ChainModel(arm.chain, arm.joint_names, sid::drive_terms(kinds, t), t,
                         coulomb_epsilon);
}

TEST(Transmission, MotorLogBecomesJointSideAndKeepsTheDrivesPower) {
  const sid::Transmission t = tx40_transmission();
  std::mt19937 g(3);
  std::normal_distribution<double> normal;
  sid::ChainTrajectory<double> motor;
  motor.t = Eigen::VectorXd::LinSpaced(5, 0.0, 0.4);
  motor.q = Eigen::MatrixXd::NullaryExpr(5, 6, [&] { return normal(g); });
  motor.tau = Eigen::MatrixXd::NullaryExpr(5, 6, [&] { return normal(g); });
  const sid::ChainTrajectory<double> joint = t.joint_side(motor);
  for (int k = 0; k < 5; ++k) {
    // q_motor = G (q - zero), and the power of any joint rate is the same on both sides.
    const Eigen::VectorXd back = t.ratio() * (joint.q.row(k).transpose() - t.zero());
    EXPECT_LT((back - motor.q.row(k).transpose()).norm(), 1e-12);
    const Eigen::VectorXd qd = Eigen::VectorXd::NullaryExpr(6, [&] { return normal(g); });
    EXPECT_NEAR(joint.tau.row(k).dot(qd), motor.tau.row(k).dot(t.ratio() * qd), 1e-10);
  }
  // Joint 5 sees its own motor and the sixth: tau5 = 45 tau_m5 + 32 tau_m6.
  EXPECT_NEAR(joint.tau(2, 4), 45.0 * motor.tau(2, 4) + 32.0 * motor.tau(2, 5), 1e-12);
  EXPECT_EQ(t.coupled_motors(), std::vector<int>{5});
}

TEST(Transmission, RefusesWhatCannotBeAGear) {
  EXPECT_THROW(sid::Transmission(Eigen::MatrixXd::Ones(2, 3), Eigen::VectorXd::Zero(2)),
               std::invalid_argument);
  EXPECT_THROW(sid::Transmission(Eigen::MatrixXd::Ones(2, 2), Eigen::VectorXd::Zero(2)),
               std::invalid_argument);  // singular
  EXPECT_THROW(sid::Transmission(Eigen::Matrix2d(Eigen::Vector2d(0.0, 1.0).asDiagonal()),
                                 Eigen::VectorXd::Zero(2)),
               std::invalid_argument);  // a motor with no ratio to its joint
  EXPECT_THROW(sid::Transmission(Eigen::MatrixXd::Identity(2, 2), Eigen::VectorXd::Zero(3)),
               std::invalid_argument);
}

TEST(ChainModel, ColumnsAreTheLinksRegressorAndTheDriveTerms) {
  const sid::ChainModel model =
      tx40_model({sid::DriveTermKind::Viscous, sid::DriveTermKind::Coulomb,
                  sid::DriveTermKind::CoulombAsymmetry, sid::DriveTermKind::Offset,
                  sid::DriveTermKind::Armature},
                 0.05);
  ASSERT_EQ(model.parameters(), 60 + 6 * 5 + 4);  // coupled motor 6: four terms, no offset
  Eigen::VectorXd q(6), qd(6), qdd(6);
  q << 0.1, -0.4, 0.9, 1.3, -0.7, 2.0;
  qd << 0.3, -1.1, 0.02, 0.8, -0.5, 0.9;
  qdd << -2.0, 1.5, 0.3, -0.8, 2.2, -1.0;
  Eigen::MatrixXd y(6, model.parameters()), links(6, sid::chain_parameter_count(6));
  model.regressor(q, qd, qdd, y);
  sid::chain_regressor(model.chain(), q, qd, qdd, links);
  EXPECT_EQ(y.leftCols(60), links.leftCols(60));
  const auto column = [&](const std::string& name) {
    const auto& names = model.parameter_names();
    const auto at = std::find(names.begin(), names.end(), name);
    EXPECT_NE(at, names.end()) << name;
    return y.col(at - names.begin());
  };
  Eigen::VectorXd expected = Eigen::VectorXd::Zero(6);
  expected[2] = 0.02;
  EXPECT_EQ(column("fv_3"), expected);
  expected[2] = std::tanh(0.02 / 0.05);
  EXPECT_NEAR((column("fc_3") - expected).norm(), 0.0, 1e-15);
  expected[2] = std::abs(std::tanh(0.02 / 0.05));
  EXPECT_NEAR((column("fa_3") - expected).norm(), 0.0, 1e-15);
  expected[2] = 1.0;
  EXPECT_EQ(column("off_3"), expected);
  expected[2] = 0.3;
  EXPECT_EQ(column("Ia_3"), expected);
  // The sixth motor turns with qd5 + qd6, and its torque reaches joints 5 and 6 alike.
  expected.setZero();
  expected.tail(2).setConstant(2.2 - 1.0);
  EXPECT_NEAR((column("Ia_m6") - expected).norm(), 0.0, 1e-15);
  expected.tail(2).setConstant(std::tanh((-0.5 + 0.9) / 0.05));
  EXPECT_NEAR((column("fc_m6") - expected).norm(), 0.0, 1e-15);
}

TEST(ChainModel, RefusesTermsOffTheChainAndTermsGivenTwice) {
  const sid::ChainModel ok = tx40_model({});
  const sid::Transmission direct(6);
  EXPECT_THROW(sid::ChainModel(ok.chain(), {}, {{sid::DriveTermKind::Viscous, 6, false}}, direct),
               std::invalid_argument);
  EXPECT_THROW(
      sid::ChainModel(
          ok.chain(), {},
          {{sid::DriveTermKind::Offset, 1, false}, {sid::DriveTermKind::Offset, 1, false}}, direct),
      std::invalid_argument);
  EXPECT_THROW(sid::ChainModel(ok.chain(), {"a", "b"}, {}, direct), std::invalid_argument);
  EXPECT_THROW((void)sid::parse_drive_term_kinds("viscous,stiction"), std::invalid_argument);
  EXPECT_THROW((void)sid::parse_drive_term_kinds("offset,offset"), std::invalid_argument);
  EXPECT_TRUE(sid::parse_drive_term_kinds("none").empty());
}

/// FIGAROH's published base parameters of this TX40 (tests/data/staubli_tx40/TX40_bp_5.csv),
/// each a combination "lead + c*name + ...", in sid's names: Izz1 -> Izz_1, fs -> fc (Coulomb),
/// Iam6 -> Ia_m6 and so on.
std::vector<std::map<std::string, double>> figaroh_combinations() {
  std::ifstream in(sid_test::data_path("staubli_tx40/TX40_bp_5.csv"));
  std::vector<std::map<std::string, double>> rows;
  std::string line;
  const auto sid_name = [](std::string name) {
    std::string stem = name.substr(0, name.size() - 1), joint = name.substr(name.size() - 1);
    if (stem.size() > 1 && stem.back() == 'm' && stem != "m") {  // Iam6, fvm6, fsm6
      stem.pop_back();
      joint = "m" + joint;
    }
    if (stem == "fs") stem = "fc";
    if (stem == "Ia" && joint[0] == 'm') stem = "Ia";
    return stem + "_" + joint;
  };
  while (std::getline(in, line)) {
    std::istringstream cells(line.substr(0, line.find(',')));
    std::map<std::string, double> row;
    std::string token;
    double sign = 1.0;
    while (cells >> token) {
      if (token == "+" || token == "-") {
        sign = token == "+" ? 1.0 : -1.0;
        continue;
      }
      const auto star = token.find('*');
      const double c = star == std::string::npos ? 1.0 : std::stod(token.substr(0, star));
      row[sid_name(star == std::string::npos ? token : token.substr(star + 1))] = sign * c;
      sign = 1.0;
    }
    rows.push_back(row);
  }
  return rows;
}

TEST(ChainBaseParameters, Tx40GroupsAsFigarohPublished) {
  const sid::ChainModel model = tx40_model(sid::default_drive_term_kinds(), 0.0);
  const sid::BaseParameters<double> base = sid::chain_base_parameters(model);
  EXPECT_GT(base.rank_gap, 1e6);
  const auto& names = model.parameter_names();
  std::map<std::string, std::map<std::string, double>> ours;
  for (Eigen::Index a = 0; a < base.rank(); ++a) {
    std::map<std::string, double>& row =
        ours[names[static_cast<std::size_t>(base.independent[static_cast<std::size_t>(a)])]];
    for (Eigen::Index b = 0; b < base.K.cols(); ++b)
      if (std::abs(base.K(a, b)) > 1e-9)
        row[names[static_cast<std::size_t>(base.dependent[static_cast<std::size_t>(b)])]] =
            base.K(a, b);
  }
  const auto figaroh = figaroh_combinations();
  ASSERT_EQ(figaroh.size(), 60u);
  int compared = 0;
  for (const auto& row : figaroh) {
    // FIGAROH writes the kept parameter first with coefficient 1; it is the one sid keeps too.
    std::string lead;
    for (const auto& [name, c] : row)
      if (ours.count(name)) lead = name;
    ASSERT_FALSE(lead.empty()) << "no base parameter of sid among " << row.begin()->first;
    for (const auto& [name, c] : row) {
      if (name == lead) continue;
      ASSERT_TRUE(ours[lead].count(name)) << lead << " lacks " << name;
      EXPECT_NEAR(ours[lead][name], c, 1e-9) << lead << ": " << name;
    }
    EXPECT_EQ(ours[lead].size() + 1, row.size()) << lead;
    ++compared;
  }
  EXPECT_EQ(compared, 60);
  // One more than FIGAROH's 60: the sixth joint's own rotor (its column is q̈6, the coupled
  // motor's q̈5 + q̈6), which FIGAROH leaves out of its model.
  EXPECT_EQ(base.rank(), 61);
  EXPECT_TRUE(ours.count("Ia_6"));
}

TEST(ChainBaseParameters, RegroupingHoldsOnStatesItWasNotFoundOn) {
  const sid::ChainModel model = tx40_model(sid::default_drive_term_kinds());
  const sid::BaseParameters<double> base = sid::chain_base_parameters(model);
  std::mt19937 g(11);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  Eigen::MatrixXd y(6, model.parameters());
  for (int s = 0; s < 20; ++s) {
    const Eigen::VectorXd q = Eigen::VectorXd::NullaryExpr(6, [&] { return u(g); });
    const Eigen::VectorXd qd = Eigen::VectorXd::NullaryExpr(6, [&] { return u(g); });
    const Eigen::VectorXd qdd = Eigen::VectorXd::NullaryExpr(6, [&] { return 3.0 * u(g); });
    model.regressor(q, qd, qdd, y);
    const Eigen::MatrixXd dependent = y(Eigen::all, base.dependent);
    const Eigen::MatrixXd regrouped = y(Eigen::all, base.independent) * base.K;
    EXPECT_LT((dependent - regrouped).cwiseAbs().maxCoeff(), 1e-9 * y.cwiseAbs().maxCoeff());
  }
}

TEST(BaseParameterNames, WriteEachCombinationShortAndInFull) {
  // Columns a, b = 2a, c, d = a - 0.5 c, e = 0.
  Eigen::MatrixXd w(4, 5);
  w << 1, 2, 0, 1, 0,    //
      0, 0, 1, -0.5, 0,  //
      2, 4, 1, 1.5, 0,   //
      1, 2, 3, -0.5, 0;
  const sid::BaseParameters<double> base = sid::base_parameters_in_order(w);
  EXPECT_EQ(base.independent, (std::vector<Eigen::Index>{0, 2}));
  const std::vector<std::string> names = {"a", "b", "c", "d", "e"};
  EXPECT_EQ(sid::base_parameter_names(base, names, 0),
            (std::vector<std::string>{"a + 2*b + d", "c - 0.5*d"}));
  EXPECT_EQ(sid::base_parameter_names(base, names, 2),
            (std::vector<std::string>{"a + 2*b + ...", "c - 0.5*d"}));
  EXPECT_THROW((void)sid::base_parameter_names(base, {"a"}), std::invalid_argument);
}

TEST(IdentifyChain, RecoversASimulatedArmOnAJitteredGrid) {
  const sid_test::SimulatedArm arm;
  sid::ChainIdentifyOptions options;
  options.cutoff_hz = {16.0};
  options.filter_torque = false;  // exact torques: nothing to filter, nothing to smear
  const sid::ChainIdentification id =
      sid::identify_chain(arm.model, {arm.run(12.0, 1, 0.0)}, options);
  ASSERT_TRUE(id.fit.ok()) << id.fit.message;
  EXPECT_EQ(id.base.rank(), id.structural_rank);
  const Eigen::VectorXd beta = id.base.beta(arm.theta);
  // Exact torques: what is left is the smoothing's bias on q̈, far below a part in a thousand.
  EXPECT_LT(id.fitted.relative_residual, 1e-3);
  for (Eigen::Index i = 0; i < beta.size(); ++i)
    EXPECT_NEAR(id.fit.theta[i], beta[i], 2e-3 * std::max(1.0, std::abs(beta[i])))
        << id.parameter_names[static_cast<std::size_t>(i)];
  // Another run is predicted as well as the fitted one.
  const sid::ChainTrajectory<double> run = arm.run(6.0, 2, 0.0);
  const sid::ChainPrediction other = sid::predict_chain(arm.model, id, run, options);
  EXPECT_LT(other.relative_residual, 2e-3);
  // The model's torque at every sample, away from the spline's ends, is the run's.
  const Eigen::MatrixXd tau = sid::chain_torque(arm.model, id, run, options);
  ASSERT_EQ(tau.rows(), run.size());
  ASSERT_EQ(tau.cols(), run.joints());
  const Eigen::Index edge = run.size() / 20, inside = run.size() - 2 * edge;
  const Eigen::MatrixXd error = tau.middleRows(edge, inside) - run.tau.middleRows(edge, inside);
  EXPECT_LT(error.norm(), 2e-3 * run.tau.middleRows(edge, inside).norm());
  sid::ChainIdentification other_model = id;
  other_model.cutoff_hz.resize(1);
  EXPECT_THROW((void)sid::chain_torque(arm.model, other_model, run, options),
               std::invalid_argument);
}

// A torque channel 20 ms behind the angles (exactly: the arm's torque 20 ms earlier). Paired with
// the angles' spline 20 ms earlier, the fit is as good as on a log without the lag, and so is
// the prediction of another such run; paired as logged, it is not. A lead works alike.
TEST(IdentifyChain, PairsALaggingTorqueWithTheAnglesWhenItWasApplied) {
  const sid_test::SimulatedArm arm;
  sid::ChainIdentifyOptions options;
  options.cutoff_hz = {16.0};
  options.filter_torque = false;
  options.torque_delay = 0.02;
  const sid::ChainIdentification id =
      sid::identify_chain(arm.model, {arm.run(12.0, 1, 0.0, 0.02)}, options);
  ASSERT_TRUE(id.fit.ok()) << id.fit.message;
  EXPECT_LT(id.fitted.relative_residual, 1e-3);
  const Eigen::VectorXd beta = id.base.beta(arm.theta);
  for (Eigen::Index i = 0; i < beta.size(); ++i)
    EXPECT_NEAR(id.fit.theta[i], beta[i], 2e-3 * std::max(1.0, std::abs(beta[i])))
        << id.parameter_names[static_cast<std::size_t>(i)];
  EXPECT_LT(
      sid::predict_chain(arm.model, id, arm.run(6.0, 2, 0.0, 0.02), options).relative_residual,
      2e-3);

  sid::ChainIdentifyOptions as_logged = options;
  as_logged.torque_delay = 0.0;
  EXPECT_GT(sid::identify_chain(arm.model, {arm.run(12.0, 1, 0.0, 0.02)}, as_logged)
                .fitted.relative_residual,
            10.0 * id.fitted.relative_residual);
  options.torque_delay = -0.02;
  EXPECT_LT(sid::identify_chain(arm.model, {arm.run(12.0, 1, 0.0, -0.02)}, options)
                .fitted.relative_residual,
            1e-3);
  options.torque_delay = 0.2;  // beyond the skips: the spline would be asked outside the log
  EXPECT_THROW((void)sid::identify_chain(arm.model, {arm.run(2.0, 1, 0.0)}, options),
               std::invalid_argument);
}

// Angles from 12-bit encoders move by about one step per sample: a staircase, whose error a
// joint's own cutoff can follow unseen by the held-out torque. Every joint keeps the one shared
// cutoff (the light arm of torque_delay_test shows what that is worth).
TEST(IdentifyChain, KeepsOneCutoffForAnglesThatMoveAsAStaircase) {
  const sid_test::SimulatedArm arm;
  const auto quantised = [&](int bits) {
    sid::ChainTrajectory<double> run = arm.run(4.0, 6, 0.2);
    const double step = 2.0 * M_PI / std::pow(2.0, bits);
    run.q = (run.q / step).array().round().matrix() * step;
    return run;
  };
  const sid::ChainIdentification coarse = sid::identify_chain(arm.model, {quantised(12)});
  ASSERT_TRUE(coarse.fit.ok()) << coarse.fit.message;
  EXPECT_EQ(coarse.cutoff_hz.minCoeff(), coarse.cutoff_hz.maxCoeff());
}

TEST(IdentifyChain, ChoosesCutoffsAndItsStdDevsCoverTheErrorWithNoisyTorques) {
  const sid_test::SimulatedArm arm;
  const std::vector<sid::ChainTrajectory<double>> runs = {
      arm.run(8.0, 3, 0.2), arm.run(8.0, 4, 0.2), arm.run(8.0, 5, 0.2)};
  const sid::ChainIdentification id = sid::identify_chain(arm.model, runs);
  ASSERT_TRUE(id.fit.ok()) << id.fit.message;
  EXPECT_TRUE(id.cutoff_chosen);
  for (int j = 0; j < 3; ++j) {
    EXPECT_GE(id.cutoff_hz[j], 1.0);
    EXPECT_LE(id.cutoff_hz[j], 64.0 * (1.0 + 1e-9));
  }
  ASSERT_EQ(id.jackknife_std_dev.size(), id.fit.theta.size());
  // Against the log as recorded, what is left is the torque noise the runs were given.
  for (int j = 0; j < 3; ++j) EXPECT_NEAR(id.fitted.measured_residual_rms[j], 0.2, 0.01);
  const Eigen::VectorXd beta = id.base.beta(arm.theta);
  for (Eigen::Index i = 0; i < beta.size(); ++i) {
    ASSERT_TRUE(std::isfinite(id.std_dev[i]));
    EXPECT_LT(std::abs(id.fit.theta[i] - beta[i]), 5.0 * id.std_dev[i] + 1e-3)
        << id.parameter_names[static_cast<std::size_t>(i)];
  }
}

// Each fold holds out a span of every run's equations: together the blocks are every equation
// once, and a fold's fit with its block gives back the whole fit's residual sum of squares
// (RSS(θ) = RSS_train(θ_f) + ‖R (θ − θ_f)‖² + ‖y − X θ‖² over the block, exact for least
// squares), which a row lost or counted twice would break.
TEST(IdentifyChain, FoldsHoldOutEachEquationOnceAndRebuildTheWholeFit) {
  const sid_test::SimulatedArm arm;
  const std::vector<sid::ChainTrajectory<double>> runs = {arm.run(3.0, 1, 0.05),
                                                          arm.run(2.0, 2, 0.05)};
  sid::ChainIdentifyOptions options;
  options.cutoff_hz = {8.0};
  const sid::ChainIdentification id = sid::identify_chain(arm.model, runs, options);
  ASSERT_TRUE(id.fit.ok()) << id.fit.message;
  const std::vector<sid::ChainFold> folds = sid::chain_folds(arm.model, id, runs, options, 4);
  ASSERT_EQ(folds.size(), 4u);
  const Eigen::Index equations = id.fitted.equations.sum();
  const double rss = id.fit.residual.squaredNorm();
  Eigen::Index held = 0;
  for (const sid::ChainFold& fold : folds) {
    ASSERT_TRUE(fold.fit.fit.ok()) << fold.fit.fit.message;
    EXPECT_GT(fold.x.rows(), equations / 8);
    EXPECT_EQ(fold.fit.fit.residual.size() + fold.x.rows(), equations);
    held += fold.x.rows();
    const Eigen::MatrixXd r = fold.fit.fit.r * fold.fit.fit.column_scale.asDiagonal();
    const double rebuilt = fold.fit.fit.residual.squaredNorm() +
                           (r * (id.fit.theta - fold.fit.fit.theta)).squaredNorm() +
                           fold.residual_sum_of_squares(id.fit.theta);
    EXPECT_NEAR(rebuilt, rss, 1e-8 * rss);
    // The block was not fitted: the fold's estimate predicts it worse than the whole fit.
    EXPECT_GT(fold.residual_sum_of_squares(fold.fit.fit.theta),
              fold.residual_sum_of_squares(id.fit.theta));
  }
  EXPECT_EQ(held, equations);
  EXPECT_THROW((void)sid::chain_folds(arm.model, id, runs, options, 1), std::invalid_argument);
  EXPECT_THROW((void)sid::chain_folds(arm.model, id, {arm.run(0.02, 3, 0.05)}, options, 5),
               std::invalid_argument);
}

TEST(IdentifyChain, RegroupsWhatTheRunsDoNotTellApart) {
  // Equations at rest are left out, so |tanh(qd / eps)| is 1 in every equation used: the
  // asymmetric Coulomb level cannot be told from the torque offset in these data.
  const sid_test::SimulatedArm arm;
  const sid::Transmission t(3);
  const sid::ChainModel model(
      arm.model.chain(), {},
      sid::drive_terms({sid::DriveTermKind::Viscous, sid::DriveTermKind::Coulomb,
                        sid::DriveTermKind::Offset, sid::DriveTermKind::CoulombAsymmetry},
                       t),
      t, 0.001);
  sid::ChainIdentifyOptions options;
  options.cutoff_hz = {8.0};
  const sid::ChainIdentification id = sid::identify_chain(model, {arm.run(6.0, 6, 0.1)}, options);
  ASSERT_TRUE(id.fit.ok()) << id.fit.message;
  EXPECT_EQ(id.structural_rank - id.base.rank(), 3);
  for (int j = 1; j <= 3; ++j) {
    const std::string off = "off_" + std::to_string(j), fa = "fa_" + std::to_string(j);
    EXPECT_NE(std::find(id.parameter_names.begin(), id.parameter_names.end(), off + " + " + fa),
              id.parameter_names.end())
        << off;
  }
}

TEST(IdentifyChain, RefusesBadInput) {
  const sid_test::SimulatedArm arm;
  sid::ChainTrajectory<double> run = arm.run(2.0, 7, 0.0);
  sid::ChainIdentifyOptions options;
  options.cutoff_hz = {1.0, 2.0};  // neither one nor one per joint
  EXPECT_THROW((void)sid::identify_chain(arm.model, {run}, options), std::invalid_argument);
  EXPECT_THROW((void)sid::identify_chain(arm.model, {}), std::invalid_argument);
  options = {};
  options.rest_fraction = 1.0;
  EXPECT_THROW((void)sid::identify_chain(arm.model, {run}, options), std::invalid_argument);
  sid::ChainTrajectory<double> two_joints{run.t, run.q.leftCols(2), run.tau.leftCols(2)};
  EXPECT_THROW((void)sid::identify_chain(arm.model, {two_joints}), std::invalid_argument);
  run.t[5] = run.t[4];
  EXPECT_THROW((void)sid::identify_chain(arm.model, {run}), std::invalid_argument);
  run = arm.run(2.0, 7, 0.0);
  run.tau(3, 1) = std::nan("");
  EXPECT_THROW((void)sid::identify_chain(arm.model, {run}), std::invalid_argument);
  EXPECT_THROW((void)sid::split_run(arm.run(1.0, 7, 0.0), 1.0), std::invalid_argument);
}

TEST(IdentifyChain, SplitRunKeepsEverySampleOnce) {
  const sid_test::SimulatedArm arm;
  const sid::ChainTrajectory<double> run = arm.run(1.0, 8, 0.0);
  const auto [first, last] = sid::split_run(run, 0.7);
  EXPECT_EQ(first.size() + last.size(), run.size());
  EXPECT_LT(first.t[first.size() - 1], run.t[0] + 0.7 * (run.t[run.size() - 1] - run.t[0]));
  EXPECT_GE(last.t[0], run.t[0] + 0.7 * (run.t[run.size() - 1] - run.t[0]));
  EXPECT_EQ(last.q.row(0), run.q.row(first.size()));
}

TEST(ChainConsistency, LogCholeskyNumbersAreRealBodiesAndRoundTrip) {
  sid::LinkInertia<double> body;
  body.mass = 2.5;
  body.com = sid::Vector3<double>(0.1, -0.05, 0.2);
  body.inertia_com << 0.03, 0.002, -0.001, 0.002, 0.05, 0.004, -0.001, 0.004, 0.06;
  const sid::LinkParameters<double> phi = sid::standard_parameters(body);
  const sid::LinkParameters<double> back =
      sid::link_parameters_from_log_cholesky(sid::log_cholesky_from_link_parameters(phi));
  EXPECT_LT((back - phi).cwiseAbs().maxCoeff(), 1e-12);
  std::mt19937 g(5);
  std::normal_distribution<double> normal;
  for (int k = 0; k < 50; ++k) {
    const Eigen::Matrix<double, 10, 1> xi =
        Eigen::Matrix<double, 10, 1>::NullaryExpr([&] { return normal(g); });
    EXPECT_EQ(sid::link_inconsistency(sid::link_parameters_from_log_cholesky(xi), 1e-9), "");
  }
}

TEST(ChainConsistency, ARealArmFitsAsWellAsLeastSquaresAndStaysARealBody) {
  const sid_test::SimulatedArm arm;
  sid::ChainIdentifyOptions options;
  options.cutoff_hz = {16.0};
  options.filter_torque = false;
  const sid::ChainIdentification id =
      sid::identify_chain(arm.model, {arm.run(8.0, 9, 0.0)}, options);
  ASSERT_TRUE(id.fit.ok());
  // The truth is a real body, so the consistent fit loses almost nothing; started from a prior
  // far from it (every link 1 kg at its origin), it must find the data's base parameters.
  const sid::ChainConsistentFit fit = sid::consistent_chain_parameters(arm.model, id);
  EXPECT_TRUE(fit.converged) << fit.iterations << " steps";
  EXPECT_LT(fit.relative_residual, id.fitted.relative_residual + 1e-4);
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(
        sid::link_inconsistency(sid::LinkParameters<double>(fit.theta.segment<10>(10 * i)), 1e-9),
        "")
        << "link " << i + 1;
  const Eigen::VectorXd beta = id.base.beta(arm.theta);
  EXPECT_LT((fit.beta - beta).cwiseAbs().maxCoeff(), 1e-2 * beta.cwiseAbs().maxCoeff());
  EXPECT_THROW((void)sid::consistent_chain_parameters(arm.model, id, Eigen::VectorXd::Zero(3)),
               std::invalid_argument);
  // Link 1 turns about the vertical: no torque ever depends on its mass, so the prior's stays.
  Eigen::VectorXd prior = arm.theta;
  prior[0] = 7.0;
  const sid::ChainConsistentFit near = sid::consistent_chain_parameters(arm.model, id, prior);
  EXPECT_TRUE(near.converged);
  // The interior point stops within 1e-7 RSS of the optimum in cost; in a direction only the
  // prior (1e-4 RSS per unit relative change) sees, that bounds the error by sqrt(1e-3) of the
  // value, and it is far below in practice. The earlier solver left it 55 % off on the TX40.
  EXPECT_NEAR(near.theta[0], 7.0, 7.0 * 1e-3);
  EXPECT_LT(near.relative_residual, id.fitted.relative_residual + 1e-6);
}

}  // namespace

namespace {

constexpr double kRelative = 1e-12;  // the same arithmetic, differently grouped

/// The simulated arm identified from noisy torques, smoothed: residuals correlated in time.
sid::ChainIdentification smoothed_arm_fit(const sid_test::SimulatedArm& arm) {
  sid::ChainIdentifyOptions options;
  options.cutoff_hz = {8.0};
  return sid::identify_chain(arm.model, {arm.run(6.0, 5, 0.05)}, options);
}

TEST(ChainConsistency, PriorWeightIsTheEstimatesVarianceOverThePriors) {
  const sid_test::SimulatedArm arm;
  const sid::ChainIdentification id = smoothed_arm_fit(arm);
  ASSERT_TRUE(id.fit.ok());
  const sid::ChainConsistentFit fit = sid::consistent_chain_parameters(arm.model, id, arm.theta);
  EXPECT_TRUE(fit.converged) << fit.iterations << " steps";
  EXPECT_TRUE(fit.fits_estimate) << fit.misfit;
  // κ: the HAC variances over the uncorrelated ones; smoothing correlates the residuals.
  const double kappa = (id.std_dev.array() / id.fit.std_dev.array()).square().mean();
  EXPECT_GT(kappa, 2.0);
  EXPECT_NEAR(fit.correlation_inflation, kappa, kRelative * kappa);
  const auto dof = static_cast<double>(id.fit.residual.size() - id.base.rank());
  EXPECT_NEAR(fit.prior_weight, kappa / dof, kRelative * kappa / dof);
  // Half the prior's standard deviation, four times its weight; a weight given is used as is.
  sid::ChainConsistencyOptions options;
  options.prior_std = 0.5;
  EXPECT_NEAR(sid::consistent_chain_parameters(arm.model, id, arm.theta, options).prior_weight,
              4.0 * fit.prior_weight, kRelative * fit.prior_weight);
  options.prior_weight = 1e-4;
  EXPECT_EQ(sid::consistent_chain_parameters(arm.model, id, arm.theta, options).prior_weight, 1e-4);
  for (const auto& bad : {std::pair<double, double>{0.0, 0.0}, {1.0, -1e-4}, {NAN, 0.0}}) {
    sid::ChainConsistencyOptions o;
    o.prior_std = bad.first;
    o.prior_weight = bad.second;
    EXPECT_THROW((void)sid::consistent_chain_parameters(arm.model, id, arm.theta, o),
                 std::invalid_argument)
        << bad.first << ", " << bad.second;
  }
}

TEST(ChainConsistency, SaysWhenNoRealArmReproducesTheEstimate) {
  const sid_test::SimulatedArm arm;
  sid::ChainIdentification id = smoothed_arm_fit(arm);
  ASSERT_TRUE(id.fit.ok());
  // An estimate no arm gives: every mass and friction level negated (gravity pulls up).
  id.fit.theta = id.base.beta(-arm.theta);
  const sid::ChainConsistentFit fit = sid::consistent_chain_parameters(arm.model, id, arm.theta);
  EXPECT_TRUE(fit.converged);
  const auto r = static_cast<double>(id.base.rank());
  EXPECT_GT(fit.misfit, r + 3.0 * std::sqrt(2.0 * r));
  EXPECT_FALSE(fit.fits_estimate);
}

// A link the description gives no mass (a URDF link without <inertial>) is unknown, not
// massless: the prior must not pin it at zero against the data.
TEST(ChainConsistency, ALinkThePriorGivesNoMassFollowsTheData) {
  const sid_test::SimulatedArm arm;
  const sid::ChainIdentification id = smoothed_arm_fit(arm);
  ASSERT_TRUE(id.fit.ok());
  Eigen::VectorXd prior = arm.theta;
  prior.segment<10>(10).setZero();
  const sid::ChainConsistentFit fit = sid::consistent_chain_parameters(arm.model, id, prior);
  EXPECT_TRUE(fit.converged);
  EXPECT_TRUE(fit.fits_estimate) << fit.misfit;
  EXPECT_NEAR(fit.theta[10], arm.theta[10], 0.2 * arm.theta[10]);
  EXPECT_LT(fit.relative_residual, 1.05 * id.fitted.relative_residual);
}

}  // namespace
