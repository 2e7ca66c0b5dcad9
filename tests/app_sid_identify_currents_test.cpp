// Tests of sid_identify --robot --currents as a user runs it: a UR5 whose logs hold motor
// currents, one run with a known payload on the tip link (given in tool0's frame, or in another
// link's with --payload-frame) and one without, gives its drive gains and an arm in N m; bad
// options are refused with a message naming them.

#include <sid/drive_gains.hpp>
#include <sid/cvode/identify_robot_currents.hpp>

#include <nlohmann/json.hpp>

#include "app_test_support.hpp"
#include "chain_identify_app.hpp"
#include "csv.hpp"
#include "ur5_tool0.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

namespace {

constexpr double kGainTolerance = 0.02;        // relative, the acceptance bound
constexpr double kPredictionTolerance = 0.02;  // relative torque error of the identified arm
constexpr double kRate = 250.0;                // [Hz]
constexpr double kDuration = 14.0;             // [s]
constexpr double kAngleNoise = 5e-5;           // [rad]
constexpr double kCurrentNoise = 0.01;         // of each joint's current RMS
/// Relative: the gains from one load given in two frames (the same torques either way).
constexpr double kSameGainTolerance = 1e-6;

const double kTrueGain[6] = {9.2, 10.5, 7.4, 3.6, 4.1, 5.3};  // [N m/A]

/// The UR5 to tool0 as sid_identify --robot models it: the URDF's links, and per joint viscous
/// and Coulomb friction, an offset and an armature.
struct Ur5 {
  sid::app::LoadedChain chain;
  Eigen::VectorXd theta;

  static std::string urdf() { return SID_TEST_DATA_DIR "/urdf/real/ur5_robot.urdf"; }

  Ur5() : chain(load()) {
    theta = Eigen::VectorXd::Zero(chain.model.parameters());
    theta.head(chain.robot.link_parameters.size()) = chain.robot.link_parameters;
    const double fv[6] = {2.0, 2.5, 1.2, 0.3, 0.3, 0.2}, fc[6] = {3.0, 3.5, 2.0, 0.6, 0.5, 0.4};
    const double offset[6] = {0.5, -0.8, 0.3, 0.1, -0.05, 0.04};
    const double ia[6] = {0.6, 0.6, 0.35, 0.06, 0.06, 0.05};
    Eigen::Index c = chain.model.rigid_body_parameters();
    for (const sid::DriveTerm& t : chain.model.terms()) {
      const auto j = static_cast<std::size_t>(t.index);
      switch (t.kind) {
        case sid::DriveTermKind::Viscous:
          theta[c] = fv[j];
          break;
        case sid::DriveTermKind::Coulomb:
          theta[c] = fc[j];
          break;
        case sid::DriveTermKind::Offset:
          theta[c] = offset[j];
          break;
        case sid::DriveTermKind::Armature:
          theta[c] = ia[j];
          break;
        default:
          ADD_FAILURE() << "unexpected drive term";
      }
      ++c;
    }
  }

  static sid::app::LoadedChain load() {
    sid::app::ChainIdentifyAppOptions o;
    o.robot = urdf();
    o.tip = "tool0";
    return sid::app::load_identify_chain(o);
  }

  /// A Fourier excitation about a pose away from the singularities, at kRate: exact angles and
  /// their derivatives.
  sid::ChainKinematics<double> motion(unsigned seed) const {
    std::mt19937 g(seed);
    std::uniform_real_distribution<double> amplitude(0.1, 0.35), phase(0.0, 2.0 * M_PI);
    const double q0[6] = {0.0, -1.3, 1.4, -1.2, 1.3, 0.0}, f0 = 0.2;
    const auto n = static_cast<Eigen::Index>(kDuration * kRate);
    sid::ChainKinematics<double> k;
    k.t = Eigen::VectorXd::LinSpaced(n, 0.0, static_cast<double>(n - 1) / kRate);
    k.q = k.qd = k.qdd = k.tau = Eigen::MatrixXd::Zero(n, 6);
    for (int j = 0; j < 6; ++j) {
      k.q.col(j).setConstant(q0[j]);
      for (int h = 1; h <= 4; ++h) {
        const double a = amplitude(g) / h, w = 2.0 * M_PI * f0 * h, p = phase(g);
        for (Eigen::Index i = 0; i < n; ++i) {
          k.q(i, j) += a * std::sin(w * k.t[i] + p);
          k.qd(i, j) += a * w * std::cos(w * k.t[i] + p);
          k.qdd(i, j) -= a * w * w * std::sin(w * k.t[i] + p);
        }
      }
    }
    return k;
  }

  /// The torques Y theta along k, with `payload` on the tip link.
  Eigen::MatrixXd torques(const sid::ChainKinematics<double>& k,
                          const sid::LinkParameters<double>& payload) const {
    Eigen::VectorXd th = theta;
    th.segment<10>(chain.model.rigid_body_parameters() - 10) += payload;
    Eigen::MatrixXd tau(k.q.rows(), 6), y(6, chain.model.parameters());
    for (Eigen::Index i = 0; i < k.q.rows(); ++i) {
      const Eigen::VectorXd q = k.q.row(i).transpose(), qd = k.qd.row(i).transpose(),
                            qdd = k.qdd.row(i).transpose();
      chain.model.regressor(q, qd, qdd, y);
      tau.row(i) = (y * th).transpose();
    }
    return tau;
  }
};

const Ur5& ur5() {
  static const Ur5 arm;
  return arm;
}

/// 3 kg off the axes, given in tool0's frame (the --tip link's) as a vendor gives it.
sid::LinkInertia<double> payload() {
  sid::LinkInertia<double> p;
  p.mass = 3.0;
  p.com = Eigen::Vector3d(0.04, 0.07, -0.03);
  p.inertia_com << 0.012, 0.001, 0.0, 0.001, 0.010, 0.0, 0.0, 0.0, 0.008;
  return p;
}

class IdentifyCurrents : public sid_test::AppTest {
 protected:
  /// A log of the UR5 along motion(motion) with currents i = tau / K plus noise, angles with noise.
  std::string write_log(const std::string& name, unsigned motion, unsigned noise,
                        const sid::LinkParameters<double>& load) const {
    const sid::ChainKinematics<double> k = ur5().motion(motion);
    const Eigen::MatrixXd tau = ur5().torques(k, load);
    std::mt19937 g(noise);
    std::normal_distribution<double> normal;
    std::vector<Eigen::VectorXd> columns = {k.t};
    for (int j = 0; j < 6; ++j) {
      Eigen::VectorXd q = k.q.col(j);
      for (Eigen::Index i = 0; i < q.size(); ++i) q[i] += kAngleNoise * normal(g);
      columns.push_back(q);
    }
    for (int j = 0; j < 6; ++j) {
      Eigen::VectorXd current = tau.col(j) / kTrueGain[j];
      const double rms = std::sqrt(current.squaredNorm() / static_cast<double>(current.size()));
      for (Eigen::Index i = 0; i < current.size(); ++i)
        current[i] += kCurrentNoise * rms * normal(g);
      columns.push_back(current);
    }
    sid::app::write_csv(
        file(name),
        {"t", "q1", "q2", "q3", "q4", "q5", "q6", "tau1", "tau2", "tau3", "tau4", "tau5", "tau6"},
        columns);
    return name;
  }

  static std::string tool() {
    return app("sid_identify") + " --robot '" + Ur5::urdf() + "' --tip tool0 --currents";
  }
  /// payload() as the option writes it.
  static std::string payload_option() {
    return " --known-payload 3,0.04,0.07,-0.03,0.012,0.010,0.008,0.001,0,0";
  }
  /// A load as --known-payload m,cx,cy,cz,ixx,iyy,izz,ixy,ixz,iyz takes it, at full precision.
  static std::string known_payload(const sid::LinkInertia<double>& p) {
    const double v[10] = {p.mass,
                          p.com[0],
                          p.com[1],
                          p.com[2],
                          p.inertia_com(0, 0),
                          p.inertia_com(1, 1),
                          p.inertia_com(2, 2),
                          p.inertia_com(0, 1),
                          p.inertia_com(0, 2),
                          p.inertia_com(1, 2)};
    std::string out = " --known-payload ";
    for (int k = 0; k < 10; ++k) {
      char number[32];
      std::snprintf(number, sizeof number, "%s%.17g", k ? "," : "", v[k]);
      out += number;
    }
    return out;
  }
  /// The gains of sid_identify --json's drive_gains.
  static Eigen::VectorXd gains_of(const nlohmann::json& fit) {
    Eigen::VectorXd k(6);
    for (int j = 0; j < 6; ++j)
      k[j] = fit["drive_gains"][static_cast<std::size_t>(j)]["gain"].get<double>();
    return k;
  }
};

TEST_F(IdentifyCurrents, FindsTheDriveGainsWithinTwoPercentAndTheArmInNewtonMetres) {
  // The load rides on wrist_3_link, the last moving link; the user gives it in tool0's frame,
  // turned and moved from that link's by a fixed joint.
  write_log("loaded.csv", 1, 11, sid::standard_parameters(sid_test::in_wrist_3(payload())));
  write_log("unloaded.csv", 1, 12, sid::LinkParameters<double>::Zero());
  const sid_test::AppRun r =
      shell(tool() + payload_option() + " --payload-run loaded.csv --json fit.json unloaded.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("drive gains (current to torque)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("gain [N m/A]"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("m in the frame of tool0"), std::string::npos) << r.out;
  const nlohmann::json fit = nlohmann::json::parse(read(file("fit.json")));
  EXPECT_EQ(fit["drive_gain_fit"]["payload"]["frame"], "tool0");
  const auto& gains = fit["drive_gains"];
  ASSERT_EQ(gains.size(), 6u);
  for (int j = 0; j < 6; ++j) {
    const auto& g = gains[static_cast<std::size_t>(j)];
    EXPECT_EQ(g["joint"], ur5().chain.model.joint_names()[static_cast<std::size_t>(j)]);
    const double k = g["gain"].get<double>(), s = g["std"].get<double>();
    EXPECT_NEAR(k, kTrueGain[j], kGainTolerance * kTrueGain[j]) << g;
    EXPECT_GT(s, 0.0) << g;
    EXPECT_LT(s, kGainTolerance * kTrueGain[j]) << g;
    std::printf("gain %d: %.5f (true %.2f, error %+.3f %%, std %.3f %%)\n", j + 1, k, kTrueGain[j],
                100.0 * (k / kTrueGain[j] - 1.0), 100.0 * s / k);
  }

  // The identified arm predicts the true torques [N m] of the motion (noise-free, unloaded): the
  // converted currents were torques. Were the gains ignored (currents taken as torques), it
  // would be off by their factors of 3.6 to 10.5.
  const sid::ChainModel& model = ur5().chain.model;
  std::vector<Eigen::Index> kept;
  for (const auto& combination : fit["parameter_combinations"]) {
    const std::string first =
        combination.get<std::string>().substr(0, combination.get<std::string>().find(' '));
    const auto& names = model.parameter_names();
    const auto at = std::find(names.begin(), names.end(), first);
    ASSERT_NE(at, names.end()) << first;
    kept.push_back(at - names.begin());
  }
  Eigen::VectorXd beta(static_cast<Eigen::Index>(kept.size()));
  for (Eigen::Index a = 0; a < beta.size(); ++a)
    beta[a] = fit["theta"][static_cast<std::size_t>(a)].get<double>();
  const sid::ChainKinematics<double> k = ur5().motion(1);
  const Eigen::MatrixXd truth = ur5().torques(k, sid::LinkParameters<double>::Zero());
  Eigen::MatrixXd y(6, model.parameters());
  double error = 0.0;
  for (Eigen::Index i = 0; i < k.q.rows(); ++i) {
    const Eigen::VectorXd q = k.q.row(i).transpose(), qd = k.qd.row(i).transpose(),
                          qdd = k.qdd.row(i).transpose();
    model.regressor(q, qd, qdd, y);
    error += (y(Eigen::all, kept) * beta - truth.row(i).transpose()).squaredNorm();
  }
  const double relative = std::sqrt(error) / truth.norm();
  EXPECT_LT(relative, kPredictionTolerance);
  EXPECT_LT(fit["relative_residual"].get<double>(), kPredictionTolerance);
  std::printf("relative error of the identified arm's torque: %.4f %%\n", 100.0 * relative);
}

TEST_F(IdentifyCurrents, TheKnownPayloadMayBeGivenInAnyLinkFixedToTheLastMovingLink) {
  write_log("loaded.csv", 1, 11, sid::standard_parameters(sid_test::in_wrist_3(payload())));
  write_log("unloaded.csv", 1, 12, sid::LinkParameters<double>::Zero());
  const std::string runs = " --payload-run loaded.csv --cutoff 8 unloaded.csv";
  const sid_test::AppRun in_tool0 = shell(tool() + payload_option() + " --json tool0.json" + runs);
  ASSERT_EQ(in_tool0.exit_code, 0) << in_tool0.err;
  // The same body in wrist_3_link's frame, moved there by hand.
  const sid_test::AppRun in_link = shell(tool() + known_payload(sid_test::in_wrist_3(payload())) +
                                         " --payload-frame wrist_3_link --json link.json" + runs);
  ASSERT_EQ(in_link.exit_code, 0) << in_link.err;
  EXPECT_NE(in_link.out.find("m in the frame of wrist_3_link"), std::string::npos) << in_link.out;
  const nlohmann::json link = nlohmann::json::parse(read(file("link.json")));
  EXPECT_EQ(link["drive_gain_fit"]["payload"]["frame"], "wrist_3_link");
  const Eigen::VectorXd tool0_gains = gains_of(nlohmann::json::parse(read(file("tool0.json"))));
  const Eigen::VectorXd link_gains = gains_of(link);
  EXPECT_TRUE(link_gains.isApprox(tool0_gains, kSameGainTolerance))
      << link_gains.transpose() << "\n"
      << tool0_gains.transpose();
  for (int j = 0; j < 6; ++j) {
    EXPECT_NEAR(link_gains[j], kTrueGain[j], kGainTolerance * kTrueGain[j]) << j;
    std::printf("gain %d in wrist_3_link's frame: %.5f (error %+.3f %%; tool0's %+.3f %%)\n", j + 1,
                link_gains[j], 100.0 * (link_gains[j] / kTrueGain[j] - 1.0),
                100.0 * (tool0_gains[j] / kTrueGain[j] - 1.0));
  }
  // One library call gives the tool's numbers.
  const sid::app::LoadedChain& chain = ur5().chain;
  const auto run = [&](const char* name) {
    return sid::NamedChainRun{
        name, sid::app::chain_trajectory_from_table(sid::app::read_csv(file(name)), 6,
                                                    sid::app::chain_columns("", 6, "--columns"))};
  };
  sid::RobotCurrentsOptions options;
  options.identify.fit = chain.options;
  options.identify.fit.cutoff_hz = {8.0};
  const sid::RobotCurrentsIdentification library =
      sid::identify_robot_currents(chain.model, run("loaded.csv"), {run("unloaded.csv")},
                                   sid_test::in_wrist_3(payload()), {}, options);
  for (int j = 0; j < 6; ++j) EXPECT_EQ(library.gains.gain[j], link_gains[j]) << j;
  ASSERT_EQ(link["theta"].size(), std::size_t(library.arm.identification.fit.theta.size()));
  for (Eigen::Index i = 0; i < library.arm.identification.fit.theta.size(); ++i)
    EXPECT_EQ(link["theta"][std::size_t(i)].get<double>(), library.arm.identification.fit.theta[i])
        << i;
  EXPECT_TRUE(std::isnan(library.first_cutoff_hz));
  // The tool0 figures read in wrist_3_link's frame are another load: the gains follow it.
  const sid_test::AppRun misread =
      shell(tool() + payload_option() + " --payload-frame wrist_3_link --json misread.json" + runs);
  ASSERT_EQ(misread.exit_code, 0) << misread.err;
  const Eigen::VectorXd wrong = gains_of(nlohmann::json::parse(read(file("misread.json"))));
  double worst = 0.0;
  for (int j = 0; j < 6; ++j) {
    worst = std::max(worst, std::abs(wrong[j] / kTrueGain[j] - 1.0));
    std::printf("gain %d from tool0's load read in wrist_3_link's frame: %.4g (true %.2f)\n", j + 1,
                wrong[j], kTrueGain[j]);
  }
  EXPECT_GT(worst, 10.0 * kGainTolerance);
}

TEST_F(IdentifyCurrents, NamesTheGainThePayloadCannotReach) {
  // A point mass on tool0's z axis, which is wrist_3_joint's (y in wrist_3_link's frame), puts
  // no torque on it.
  sid::LinkInertia<double> on_axis;
  on_axis.mass = 2.0;
  on_axis.com = Eigen::Vector3d(0.0, 0.0, 0.1);
  write_log("loaded.csv", 1, 11, sid::standard_parameters(sid_test::in_wrist_3(on_axis)));
  write_log("unloaded.csv", 1, 12, sid::LinkParameters<double>::Zero());
  const sid_test::AppRun r = shell(tool() +
                                   " --known-payload 2,0,0,0.1 --payload-run loaded.csv "
                                   "--cutoff 8 unloaded.csv");
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.err.find("does not reach wrist_3_joint"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("shoulder"), std::string::npos) << r.err;
}

TEST_F(IdentifyCurrents, RefusesOptionsThatCannotFixTheGainsScale) {
  write("loaded.csv", "t,q1\n");
  const auto refused = [&](const std::string& options, const std::string& message) {
    const sid_test::AppRun r = shell(options);
    EXPECT_EQ(r.exit_code, 2) << options << "\n" << r.out;
    EXPECT_NE(r.err.find(message), std::string::npos) << options << "\n" << r.err;
  };
  refused(tool() + " --payload-run loaded.csv run.csv", "--currents needs --known-payload");
  refused(tool() + " --known-payload 3,0,0,0.1 run.csv", "--currents needs --payload-run");
  refused(tool() + " --known-payload 3,0,0.1 --payload-run loaded.csv run.csv",
          "--known-payload takes 4 numbers (m,cx,cy,cz) or 10");
  refused(tool() + " --known-payload 3,0,0,0.1,1,1,1 --payload-run loaded.csv run.csv", "got 7");
  refused(tool() + " --known-payload -3,0,0,0.1 --payload-run loaded.csv run.csv",
          "--known-payload is not a real body: the mass must be finite and > 0 kg");
  refused(tool() +
              " --known-payload 3,0,0,0.1,0.1,0.01,0.01,0,0,0 --payload-run loaded.csv "
              "run.csv",
          "triangle inequality");
  refused(app("sid_identify") + " --robot '" + Ur5::urdf() +
              "' --known-payload 3,0,0,0.1 --payload-run loaded.csv run.csv",
          "--known-payload and --payload-run go with --currents");
  refused(app("sid_identify") +
              " --currents --known-payload 3,0,0,0.1 --payload-run loaded.csv "
              "run.csv",
          "need --robot");
  refused(tool() + " --payload-frame tool0 --payload-run loaded.csv run.csv",
          "--payload-frame goes with --known-payload or --payload-of");
  refused(tool() +
              " --known-payload 3,0,0,0.1 --payload-frame upper_arm_link --payload-run "
              "loaded.csv run.csv",
          "--payload-frame: link 'upper_arm_link' is not below wrist_3_link");
  refused(tool() +
              " --known-payload 3,0,0,0.1 --payload-frame tool1 --payload-run "
              "loaded.csv run.csv",
          "--payload-frame: the URDF has no link 'tool1'");
}

TEST(DriveGains, APointMassIsARealPayloadAndAFlatDiscBeyondTheTriangleIsNot) {
  sid::LinkInertia<double> p;
  p.mass = 1.0;
  EXPECT_EQ(sid::payload_inconsistency(p), "");
  p.inertia_com = Eigen::Vector3d(0.5, 0.25, 0.25).asDiagonal();  // a thin disc: equality
  EXPECT_EQ(sid::payload_inconsistency(p), "");
  p.inertia_com(0, 0) = 0.6;
  EXPECT_NE(sid::payload_inconsistency(p).find("triangle"), std::string::npos);
  p.inertia_com = -p.inertia_com;
  EXPECT_NE(sid::payload_inconsistency(p).find("semidefinite"), std::string::npos);
}

}  // namespace
