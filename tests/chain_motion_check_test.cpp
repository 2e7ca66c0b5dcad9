// The chain diagnosis and its motion check on three arms they were never tuned on (a Kinova Jaco
// 2, a Baxter's left arm, a Unitree G1's left arm), logged as real arms log them: 1 kHz, angles
// from an encoder (quantised, no other angle noise), σ_τ 2 % of each joint's RMS. A log whose
// named set is right must not be flagged by the free simulation: an effect-free control, a
// hidden spring and a hidden encoder offset on each arm. And where a coarse encoder fools GCV
// (12 bits), the diagnosis smooths as for a measured log and names nothing on a control.

#include <sid/cvode/chain_motion_check.hpp>
#include <sid/cvode/diagnose_robot.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "chain_hidden_terms.hpp"

namespace {

/// What sid_diagnose --robot runs on a log: the diagnosis and the motion check, with the
/// description's links as the prior.
sid::RobotDiagnosis whole_check(const sid_test::SuiteArm& a,
                                const sid::ChainTrajectory<double>& run) {
  sid::DescriptionDynamics description;
  description.link_parameters = a.arm.theta.head(10 * a.joints());
  return sid::diagnose_robot(sid_test::suite_nominal(a), {run}, {}, description);
}

std::string named(const sid::ChainDiagnosis& d) {
  std::string ids;
  for (const auto& e : d.named) ids += (ids.empty() ? "" : ",") + e.id;
  return ids;
}

/// Per joint, the final error over its threshold: where a joint is flagged.
std::string ratios(const sid::ChainMotionCheck& m) {
  std::string out;
  for (Eigen::Index j = 0; j < m.final_error.size(); ++j)
    out += " " + std::to_string(m.final_error[j] / m.threshold[j]);
  return out;
}

/// The value of a spring whose torque is a tenth of joint j's torque RMS on the effect-free run.
double spring_of(const sid_test::SuiteArm& a, int j) {
  const sid::ChainKinematics<double> truth = sid_test::suite_experiment(a, {}, 1).run.truth;
  const auto rms = [&](const Eigen::VectorXd& x) {
    return std::sqrt(x.squaredNorm() / static_cast<double>(x.size()));
  };
  const Eigen::VectorXd swing = truth.q.col(j).array() - truth.q.col(j).mean();
  return 0.1 * rms(truth.tau.col(j)) / rms(swing);
}

struct Case {
  const char* name;
  sid_test::SuiteArm (*arm)();
  int spring_joint, offset_joint;  ///< 0-based joints where each is separable
};

class RealLoggedArm : public ::testing::TestWithParam<Case> {};

TEST_P(RealLoggedArm, FlagsNoLogWhoseNamedSetIsRight) {
#ifdef SID_SANITIZED_TESTS
  GTEST_SKIP() << "numbers only; the paths run in the diagnosis's own tests";
#endif
  const Case& c = GetParam();
  sid_test::SuiteArm a = c.arm();
  a.duration = 10.0;
  const sid::DriveTerm spring{sid::DriveTermKind::Spring, c.spring_joint, false};
  const sid::DriveTerm offset{sid::DriveTermKind::Offset, c.offset_joint, false};
  const std::string offset_id = "angle_offset_q" + std::to_string(c.offset_joint + 1);
  const struct {
    std::vector<sid_test::HiddenTerm> hidden;
    std::string expected;
  } logs[] = {{{}, ""},
              {{{spring, spring_of(a, c.spring_joint)}}, sid::drive_term_id(spring)},
              {{{offset, 0.05, true}}, offset_id}};
  for (const auto& log : logs) {
    const sid::RobotDiagnosis w = whole_check(a, sid_test::suite_run(a, log.hidden, 1));
    const std::string what = std::string(c.name) +
                             ", hidden: " + (log.expected.empty() ? "none" : log.expected) +
                             ", smoothing " + w.diagnosis.smoothing;
    EXPECT_EQ(named(w.diagnosis), log.expected) << what;
    ASSERT_TRUE(w.motion.threshold.allFinite()) << what << ": " << w.motion.failure;
    EXPECT_TRUE(w.motion.beyond.empty())
        << what << "; final error / threshold:" << ratios(w.motion);
  }
}

INSTANTIATE_TEST_SUITE_P(
    ThreeArms, RealLoggedArm,
    ::testing::Values(Case{"Kinova Jaco 2", sid_test::kinova_suite_arm, 3, 3},
                      Case{"Baxter left arm", sid_test::baxter_suite_arm, 3, 1},
                      Case{"G1 left arm", sid_test::g1_arm_suite_arm, 3, 1}),
    [](const ::testing::TestParamInfo<Case>& info) {
      return std::string(info.param.name).substr(0, std::string(info.param.name).find(' '));
    });

// A 12-bit encoder (a step of 1.5e-3 rad): GCV of the angles chose 56 Hz on joint 4 of this
// log (sid::ChainSmoothingChoice::AngleGcv), took the steps for motion and named a torque
// offset of 0.2 N m on joint 6, every joint's free simulation beyond its threshold. Smoothed as
// sid_identify --robot smooths a measured log, nothing is named and nothing flagged.
TEST(RealLoggedArm, SmoothsACoarseEncodersLogAsAMeasuredOne) {
#ifdef SID_SANITIZED_TESTS
  GTEST_SKIP() << "numbers only";
#endif
  sid_test::SuiteArm a = sid_test::baxter_suite_arm();
  a.angle_step = 2.0 * 3.14159265358979323846 / 4096.0;
  const sid::ChainTrajectory<double> run = sid_test::suite_run(a, {}, 2);
  const sid::RobotDiagnosis w = whole_check(a, run);
  EXPECT_NE(w.diagnosis.smoothing.find("held-out torque prediction"), std::string::npos)
      << w.diagnosis.smoothing;
  EXPECT_NE(w.diagnosis.smoothing.find("staircase"), std::string::npos) << w.diagnosis.smoothing;
  EXPECT_EQ(named(w.diagnosis), "");
  EXPECT_TRUE(w.motion.beyond.empty()) << "final error / threshold:" << ratios(w.motion);
  // The cutoffs are those sid_identify --robot chooses for the nominal model with Coulomb
  // friction and torque offsets.
  std::vector<sid::DriveTerm> terms = sid_test::suite_nominal(a).terms();
  for (int j = 0; j < a.joints(); ++j) {
    terms.push_back({sid::DriveTermKind::Coulomb, j, false});
    terms.push_back({sid::DriveTermKind::Offset, j, false});
  }
  const sid::ChainModel identified(a.arm.chain, a.arm.joint_names, terms, sid::Transmission(7),
                                   0.05);
  sid::ChainIdentifyOptions options;
  options.statistics = false;
  const sid::ChainIdentification id = sid::identify_chain(identified, {run}, options);
  EXPECT_EQ(w.diagnosis.cutoff_hz, id.cutoff_hz);
}

}  // namespace
