// Tests of payload identification (sid/payload.hpp and sid_identify --payload-of): the load's
// parameters from a log that carries it with the arm held at its own identification, in the
// frame of the --tip link (tool0) or of --payload-frame, the refusal of a motion that cannot show
// it, of the fit of another robot and of a frame not fixed to the last moving link, and the URDF
// with the load read back.

#include <sid/logged_sensors.hpp>
#include <sid/payload.hpp>

#include <nlohmann/json.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/link_inertia.hpp>
#include <sid/model/urdf.hpp>

#include "app_test_support.hpp"
#include "csv.hpp"
#include "robot_description.hpp"
#include "ur5_tool0.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

namespace {

constexpr double kMassTolerance = 0.02;   // relative
constexpr double kComTolerance = 5e-3;    // [m]
constexpr double kExactTolerance = 1e-6;  // relative, noise-free data with the true arm
constexpr double kTorqueNoise = 0.01;     // of each joint's RMS
constexpr double kAngleNoise = 1e-5;      // [rad]
constexpr double kRate = 500.0;           // [Hz]
/// Relative: one body identified in two frames (the columns differ by a change of frame only).
constexpr double kSameBodyTolerance = 1e-6;
constexpr double kUrdfTolerance = 1e-9;  // relative, a URDF written at 17 digits read back

std::string ur5_path() { return SID_TEST_DATA_DIR "/urdf/real/ur5_robot.urdf"; }

/// The UR5 to tool0 with the drive terms sid_identify fits by default (viscous, Coulomb, offset,
/// armature), and a true arm a little off its description (a CAD model is never exact).
struct Ur5 {
  sid::RobotDescription robot = sid::app::read_robot_description(ur5_path(), "", "tool0");
  sid::Transmission transmission{6};
  sid::ChainModel model{robot.chain, robot.joint_names,
                        sid::drive_terms({sid::DriveTermKind::Viscous, sid::DriveTermKind::Coulomb,
                                          sid::DriveTermKind::Offset, sid::DriveTermKind::Armature},
                                         transmission),
                        transmission, 0.01};
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.parameters());

  Ur5() {
    for (int i = 0; i < 6; ++i) {
      sid::LinkInertia<double> body =
          sid::link_inertia(sid::LinkParameters<double>(robot.link_parameters.segment<10>(10 * i)));
      body.mass *= i % 2 ? 1.06 : 0.95;
      body.com += Eigen::Vector3d(0.004, -0.003, 0.002);
      body.inertia_com *= 1.1;
      theta.segment<10>(10 * i) = sid::standard_parameters(body);
    }
    Eigen::Index c = model.rigid_body_parameters();
    for (const sid::DriveTerm& t : model.terms()) {
      const double big = t.index < 3 ? 1.0 : 0.3;
      switch (t.kind) {
        case sid::DriveTermKind::Viscous:
          theta[c] = 2.0 * big;
          break;
        case sid::DriveTermKind::Coulomb:
          theta[c] = 1.5 * big;
          break;
        case sid::DriveTermKind::Offset:
          theta[c] = 0.2 * big;
          break;
        case sid::DriveTermKind::Armature:
          theta[c] = 0.4 * big;
          break;
        default:
          break;
      }
      ++c;
    }
  }
};

using sid_test::in_wrist_3;
using sid_test::tool0_in_wrist_3;

/// 2.5 kg off every axis, given in tool0's frame as a vendor gives it: its centre of mass at
/// (0.03, -0.02, 0.08) m of tool0 and its principal axes turned away from tool0's.
sid::LinkInertia<double> the_load() {
  sid::LinkInertia<double> load;
  load.mass = 2.5;
  load.com = Eigen::Vector3d(0.03, -0.02, 0.08);
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(0.8, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(-0.5, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  load.inertia_com = r * Eigen::Vector3d(0.012, 0.009, 0.005).asDiagonal() * r.transpose();
  return load;
}

/// A log of model at theta by exact inverse dynamics, kRate Hz: each joint a random Fourier
/// series (base 0.1 Hz, 6 harmonics) about q0 scaled to |q - q0| <= 1 rad and |qd| <= 1.5 rad/s;
/// joints with moving[j] false stay at q0. Angle noise kAngleNoise, torque noise kTorqueNoise.
sid::ChainTrajectory<double> inverse_dynamics_log(const sid::ChainModel& model,
                                                  const Eigen::VectorXd& theta, double duration,
                                                  unsigned seed, const std::vector<bool>& moving,
                                                  bool noise = true) {
  const int n = model.joints(), harmonics = 6;
  const double w0 = 2.0 * M_PI * 0.1;
  std::mt19937 g(seed);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd a(n, harmonics), b(n, harmonics);
  for (int j = 0; j < n; ++j)
    for (int h = 0; h < harmonics; ++h) {
      a(j, h) = normal(g) / (h + 1);
      b(j, h) = normal(g) / (h + 1);
    }
  const Eigen::Index samples = static_cast<Eigen::Index>(duration * kRate) + 1;
  sid::ChainTrajectory<double> run;
  run.t = Eigen::VectorXd::LinSpaced(samples, 0.0, static_cast<double>(samples - 1) / kRate);
  Eigen::MatrixXd q(samples, n), qd(samples, n), qdd(samples, n);
  for (Eigen::Index k = 0; k < samples; ++k)
    for (int j = 0; j < n; ++j) {
      double x = 0.0, v = 0.0, acc = 0.0;
      for (int h = 0; h < harmonics; ++h) {
        const double w = w0 * (h + 1), s = std::sin(w * run.t[k]), c = std::cos(w * run.t[k]);
        x += a(j, h) * s + b(j, h) * c;
        v += w * (a(j, h) * c - b(j, h) * s);
        acc -= w * w * (a(j, h) * s + b(j, h) * c);
      }
      q(k, j) = x;
      qd(k, j) = v;
      qdd(k, j) = acc;
    }
  const Eigen::VectorXd q0 = (Eigen::VectorXd(6) << 0.3, -1.4, 1.2, -1.3, -1.5, 0.4).finished();
  for (int j = 0; j < n; ++j) {
    const double scale =
        moving[static_cast<std::size_t>(j)]
            ? std::min(1.0 / q.col(j).cwiseAbs().maxCoeff(), 1.5 / qd.col(j).cwiseAbs().maxCoeff())
            : 0.0;
    q.col(j) = (q.col(j) * scale).array() + q0[j];
    qd.col(j) *= scale;
    qdd.col(j) *= scale;
  }
  run.q = q;
  run.tau.resize(samples, n);
  Eigen::MatrixXd y(n, model.parameters());
  for (Eigen::Index k = 0; k < samples; ++k) {
    const Eigen::VectorXd qk = q.row(k).transpose(), qdk = qd.row(k).transpose(),
                          qddk = qdd.row(k).transpose();
    model.regressor(qk, qdk, qddk, y);
    run.tau.row(k) = (y * theta).transpose();
  }
  if (!noise) return run;
  for (int j = 0; j < n; ++j) {
    const double rms = std::sqrt(run.tau.col(j).squaredNorm() / static_cast<double>(samples));
    for (Eigen::Index k = 0; k < samples; ++k) {
      run.tau(k, j) += kTorqueNoise * rms * normal(g);
      run.q(k, j) += kAngleNoise * normal(g);
    }
  }
  return run;
}

void write_log(const std::string& path, const sid::ChainTrajectory<double>& run) {
  std::vector<std::string> names = {"t"};
  std::vector<Eigen::VectorXd> columns = {run.t};
  for (int j = 0; j < run.joints(); ++j) {
    names.push_back("q" + std::to_string(j + 1));
    columns.push_back(run.q.col(j));
  }
  for (int j = 0; j < run.joints(); ++j) {
    names.push_back("tau" + std::to_string(j + 1));
    columns.push_back(run.tau.col(j));
  }
  sid::app::write_csv(path, names, columns);
}

/// The arm's parameters with `load` (in tool0's frame) on wrist_3_link, the last moving link.
Eigen::VectorXd with_load(const Ur5& arm, const sid::LinkInertia<double>& load) {
  Eigen::VectorXd theta = arm.theta;
  theta.segment<10>(50) += sid::standard_parameters(in_wrist_3(load));
  return theta;
}

/// A payload's ten parameters, mass, centre of mass and their std from sid_identify's JSON.
struct ReportedLoad {
  std::string frame;
  sid::LinkParameters<double> phi;
  double mass = 0.0, mass_std = 0.0;
  Eigen::Vector3d com, com_std;
};

ReportedLoad reported_load(const nlohmann::json& j) {
  const nlohmann::json& p = j["payload"];
  ReportedLoad r;
  r.frame = p["frame"].get<std::string>();
  for (int k = 0; k < 10; ++k)
    r.phi[k] = p["standard_parameters"][static_cast<std::size_t>(k)].get<double>();
  r.mass = p["mass"].get<double>();
  r.mass_std = p["mass_std"].get<double>();
  for (int a = 0; a < 3; ++a) {
    r.com[a] = p["com"][static_cast<std::size_t>(a)].get<double>();
    r.com_std[a] = p["com_std"][static_cast<std::size_t>(a)].get<double>();
  }
  return r;
}

const std::vector<bool> kAllMove(6, true);

// ---------------------------------------------------------------------------------------------
// The library part.

TEST(PayloadBody, JacobianMatchesCentralDifferences) {
  const sid::LinkParameters<double> phi = sid::standard_parameters(the_load());
  const auto body = [](const sid::LinkParameters<double>& p) {
    const sid::LinkInertia<double> b = sid::link_inertia(p);
    Eigen::Matrix<double, 10, 1> v;
    v << b.mass, b.com, sid::detail::inertia_six(b.inertia_com);
    return v;
  };
  const Eigen::Matrix<double, 10, 10> analytic = sid::detail::body_jacobian(phi);
  constexpr double kStep = 1e-6, kTol = 1e-6;
  for (int c = 0; c < 10; ++c) {
    sid::LinkParameters<double> up = phi, down = phi;
    up[c] += kStep;
    down[c] -= kStep;
    const Eigen::Matrix<double, 10, 1> numeric = (body(up) - body(down)) / (2.0 * kStep);
    EXPECT_TRUE(numeric.isApprox(analytic.col(c), kTol) ||
                (numeric - analytic.col(c)).norm() < kTol)
        << "column " << c << "\n"
        << numeric.transpose() << "\n"
        << analytic.col(c).transpose();
  }
}

TEST(PayloadBody, NearestRealBodyOfAnImpossibleEstimateIsRealAndNoFartherThanTheTruth) {
  const sid::LinkParameters<double> truth = sid::standard_parameters(the_load());
  // A flat load seen through noise: the inertia about the centre of mass breaks the triangle
  // inequality, and the estimate is no body.
  sid::LinkInertia<double> flat = the_load();
  flat.inertia_com = Eigen::Vector3d(0.012, 0.0005, 0.0125).asDiagonal();
  const sid::LinkParameters<double> flat_phi = sid::standard_parameters(flat);
  sid::LinkParameters<double> estimate = flat_phi;
  estimate[9] += 0.004;
  ASSERT_FALSE(sid::link_inconsistency(estimate).empty());
  std::mt19937 g(3);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd a(40, 10);
  for (Eigen::Index k = 0; k < a.size(); ++k) a(k) = normal(g);
  int iterations = 0;
  bool converged = false;
  const sid::LinkParameters<double> nearest =
      sid::nearest_real_body(estimate, a, 1.0, 1e-10, 200, iterations, converged);
  EXPECT_TRUE(converged) << iterations;
  EXPECT_EQ(sid::link_inconsistency(nearest), "");
  const auto cost = [&](const sid::LinkParameters<double>& p) {
    return (a * (p - estimate)).squaredNorm();
  };
  EXPECT_LE(cost(nearest), cost(flat_phi) + 1e-9);
  EXPECT_LE(cost(nearest), cost(truth) + 1e-9);
  EXPECT_GT(cost(nearest), 0.0);
}

TEST(PayloadLibrary, NoiseFreeLogWithTheTrueArmGivesTheLoadExactly) {
  const Ur5 arm;
  const sid::ChainTrajectory<double> run =
      inverse_dynamics_log(arm.model, with_load(arm, the_load()), 4.0, 7, kAllMove, false);
  sid::PayloadOptions options;
  const sid::PayloadIdentification id = sid::identify_payload(
      arm.model, arm.theta, {run}, Eigen::VectorXd::Constant(6, 40.0), options);
  const sid::LinkParameters<double> truth = sid::standard_parameters(in_wrist_3(the_load()));
  EXPECT_LT((id.phi - truth).cwiseAbs().maxCoeff(), kExactTolerance * 10.0 + 1e-5)
      << id.phi.transpose() << "\n"
      << truth.transpose();
  EXPECT_FALSE(id.projected);
  EXPECT_LT(id.relative_residual_after, 1e-3);
  EXPECT_GT(id.relative_residual_before, 0.01);
  EXPECT_THROW((void)sid::identify_payload(arm.model, arm.theta.head(10), {run},
                                           Eigen::VectorXd::Constant(6, 40.0)),
               std::invalid_argument);
}

TEST(PayloadLibrary, AFrameFixedToTheTipLinkGivesTheSameBodyExpressedInIt) {
  const Ur5 arm;
  const sid::ChainTrajectory<double> run =
      inverse_dynamics_log(arm.model, with_load(arm, the_load()), 8.0, 9, kAllMove);
  const Eigen::VectorXd cutoff = Eigen::VectorXd::Constant(6, 8.0);
  const sid::PayloadIdentification link =
      sid::identify_payload(arm.model, arm.theta, {run}, cutoff);
  sid::PayloadOptions options;
  options.frame = tool0_in_wrist_3();
  const sid::PayloadIdentification tool =
      sid::identify_payload(arm.model, arm.theta, {run}, cutoff, options);
  ASSERT_FALSE(link.projected);
  ASSERT_FALSE(tool.projected);
  const sid::LinkInertia<double> moved = in_wrist_3(tool.body);
  std::printf(
      "[ frames ] mass %.9g and %.9g kg, com in wrist_3_link (%.6f, %.6f, %.6f) and "
      "(%.6f, %.6f, %.6f) m; error against the truth %.2f mm\n",
      link.body.mass, tool.body.mass, link.body.com[0], link.body.com[1], link.body.com[2],
      moved.com[0], moved.com[1], moved.com[2], 1e3 * (tool.body.com - the_load().com).norm());
  EXPECT_TRUE(sid::standard_parameters(moved).isApprox(link.phi, kSameBodyTolerance))
      << sid::standard_parameters(moved).transpose() << "\n"
      << link.phi.transpose();
  // The std of the centre of mass turns with it (tool0's axes are wrist_3_link's signed and
  // permuted), the mass's and the fit's figures stay.
  const Eigen::Matrix3d turn = tool0_in_wrist_3().rotation.cwiseAbs();
  EXPECT_TRUE((turn * tool.com_std).isApprox(link.com_std, kSameBodyTolerance))
      << (turn * tool.com_std).transpose() << "\n"
      << link.com_std.transpose();
  EXPECT_NEAR(tool.mass_std, link.mass_std, kSameBodyTolerance * link.mass_std);
  EXPECT_EQ(tool.equations, link.equations);
  EXPECT_NEAR(tool.relative_residual_after, link.relative_residual_after, kSameBodyTolerance);
  EXPECT_NEAR(tool.body.mass, the_load().mass, kMassTolerance * the_load().mass);
  EXPECT_LT((tool.body.com - the_load().com).norm(), kComTolerance);

  options.frame.rotation(0, 1) = 0.5;
  EXPECT_THROW((void)sid::identify_payload(arm.model, arm.theta, {run}, cutoff, options),
               std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// The tool, as a user runs it: the arm identified by sid_identify from an unloaded log, then the
// load from a loaded one. Made once for the suite.

class Payload : public sid_test::AppTest {
 protected:
  static std::filesystem::path shared_;
  static double arm_seconds_;

  static std::string shared(const std::string& name) { return (shared_ / name).string(); }

  static void SetUpTestSuite() {
    shared_ =
        std::filesystem::temp_directory_path() / ("Payload_shared_" + std::to_string(::getpid()));
    std::filesystem::remove_all(shared_);
    std::filesystem::create_directories(shared_);
    const Ur5 arm;
    write_log(shared("unloaded.csv"),
              inverse_dynamics_log(arm.model, arm.theta, 20.0, 1, kAllMove));
    write_log(shared("loaded.csv"),
              inverse_dynamics_log(arm.model, with_load(arm, the_load()), 20.0, 2, kAllMove));
    const auto start = std::chrono::steady_clock::now();
    const std::string command = "'" SID_APP_DIR "/sid_identify' --robot '" + ur5_path() +
                                "' --tip tool0 --json '" + shared("arm.json") + "' '" +
                                shared("unloaded.csv") + "' >'" + shared("arm.txt") + "' 2>&1";
    ASSERT_EQ(std::system(command.c_str()), 0) << read(shared("arm.txt"));
    arm_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    std::filesystem::remove_all(shared_, ec);
  }

  static std::string ur5() {
    return app("sid_identify") + " --robot '" + ur5_path() + "' --tip tool0";
  }
};

std::filesystem::path Payload::shared_;
double Payload::arm_seconds_ = 0.0;

TEST_F(Payload, RecoversAnOffAxisLoadWithTheArmOfItsOwnIdentification) {
  const auto start = std::chrono::steady_clock::now();
  const sid_test::AppRun r =
      shell(ur5() + " --payload-of '" + shared("arm.json") +
            "' --json payload.json --write-urdf loaded.urdf '" + shared("loaded.csv") + "'");
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::printf("[ timing ] unloaded arm identification %.2f s, payload identification %.2f s\n",
              arm_seconds_, seconds);
  std::printf("%s", r.out.c_str());
  // In the --tip link's frame (tool0, turned and moved from wrist_3_link by a fixed joint), where
  // the load was given.
  EXPECT_NE(r.out.find("payload on tool0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("in the frame of tool0"), std::string::npos) << r.out;
  const nlohmann::json j = nlohmann::json::parse(read(file("payload.json")));
  const nlohmann::json& p = j["payload"];
  EXPECT_EQ(p["frame"], "tool0");
  const sid::LinkInertia<double> truth = the_load();
  const double mass = p["mass"].get<double>();
  const Eigen::Vector3d com(p["com"][0].get<double>(), p["com"][1].get<double>(),
                            p["com"][2].get<double>());
  Eigen::Matrix<double, 6, 1> inertia;
  for (int k = 0; k < 6; ++k) inertia[k] = p["inertia"][static_cast<std::size_t>(k)].get<double>();
  const Eigen::Matrix<double, 6, 1> true_inertia = sid::detail::inertia_six(truth.inertia_com);
  std::printf("[ errors ] mass %+.3f %%, com %.2f mm, inertia max |error| %.2e kg m^2 (of %.2e)\n",
              100.0 * (mass - truth.mass) / truth.mass, 1e3 * (com - truth.com).norm(),
              (inertia - true_inertia).cwiseAbs().maxCoeff(), true_inertia.cwiseAbs().maxCoeff());
  EXPECT_NEAR(mass, truth.mass, kMassTolerance * truth.mass);
  EXPECT_LT((com - truth.com).norm(), kComTolerance) << com.transpose();
  // Every figure has an honest, finite standard deviation.
  EXPECT_GT(p["mass_std"].get<double>(), 0.0);
  for (const char* key : {"com_std", "inertia_std"})
    for (const auto& s : p[key]) EXPECT_GT(s.get<double>(), 0.0) << key;
  EXPECT_LT(p["relative_residual_after"].get<double>(),
            p["relative_residual_before"].get<double>());
  // A real body.
  sid::LinkParameters<double> phi;
  for (int k = 0; k < 10; ++k)
    phi[k] = p["standard_parameters"][static_cast<std::size_t>(k)].get<double>();
  EXPECT_EQ(sid::link_inconsistency(phi), "");

  // The URDF read back: the last moving link carries what it did plus the load.
  const std::string written = read(file("loaded.urdf"));
  EXPECT_NE(written.find("<joint name=\"payload_joint\" type=\"fixed\">"), std::string::npos);
  const sid::UrdfChain before = sid::chain_from_urdf(read(ur5_path()), "base_link", "tool0");
  const sid::UrdfChain after = sid::chain_from_urdf(written, "base_link", "tool0");
  EXPECT_TRUE(
      (after.theta.segment<10>(50) - before.theta.segment<10>(50))
          .isApprox(sid::standard_parameters(in_wrist_3(sid::link_inertia(phi))), kUrdfTolerance));
  EXPECT_EQ(after.theta.head(50), before.theta.head(50));
  // And it is not overwritten without --force.
  const sid_test::AppRun again = shell(ur5() + " --payload-of '" + shared("arm.json") +
                                       "' --write-urdf loaded.urdf '" + shared("loaded.csv") + "'");
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.err.find("refusing to overwrite"), std::string::npos) << again.err;
}

// Both logs with the torque 10 ms behind the angles, the arm identified with that delay: the
// payload is fitted with each torque paired as the arm was, and the load comes out as without
// a delay. The same arm with its delay left out pairs the torque with the wrong motion.
TEST_F(Payload, PairsEachTorqueWithTheAnglesAtTheArmsDelay) {
  const Ur5 arm;
  const auto delayed = [](sid::ChainTrajectory<double> run) {
    run.tau = sid::delayed_channel(run.t, run.tau, 0.01);
    return run;
  };
  write_log(file("unloaded.csv"),
            delayed(inverse_dynamics_log(arm.model, arm.theta, 20.0, 1, kAllMove)));
  write_log(file("loaded.csv"), delayed(inverse_dynamics_log(arm.model, with_load(arm, the_load()),
                                                             20.0, 2, kAllMove)));
  const sid_test::AppRun fit = shell(ur5() + " --torque-delay 0.01 --json arm.json unloaded.csv");
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  nlohmann::json without = nlohmann::json::parse(read(file("arm.json")));
  without.erase("torque_delay");
  write("arm0.json", without.dump());
  const auto mass_error = [&](const std::string& model) {
    const sid_test::AppRun r =
        shell(ur5() + " --payload-of " + model + " --json p.json --force loaded.csv");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(read(file("p.json")));
    if (model == "arm.json") {
      EXPECT_EQ(j["torque_delay"].get<double>(), 0.01);
      EXPECT_NE(r.out.find("each torque paired with the angles 10 ms earlier"), std::string::npos)
          << r.out;
    }
    return std::abs(j["payload"]["mass"].get<double>() - the_load().mass) / the_load().mass;
  };
  const double paired = mass_error("arm.json"), unpaired = mass_error("arm0.json");
  std::printf("[ errors ] mass %.3f %% paired at the delay, %.3f %% at none\n", 100.0 * paired,
              100.0 * unpaired);
  EXPECT_LT(paired, kMassTolerance);
  EXPECT_LT(paired, unpaired);
}

TEST_F(Payload, ReportsTheSameBodyInTheFrameOfAnyLinkFixedToTheLastMovingLink) {
  const std::string run =
      " --payload-of '" + shared("arm.json") + "' '" + shared("loaded.csv") + "'";
  const sid_test::AppRun tool = shell(ur5() + " --json tool0.json --write-urdf tool0.urdf" + run);
  ASSERT_EQ(tool.exit_code, 0) << tool.err;
  const sid_test::AppRun link = shell(ur5() +
                                      " --payload-frame wrist_3_link --json wrist_3.json "
                                      "--write-urdf wrist_3.urdf" +
                                      run);
  ASSERT_EQ(link.exit_code, 0) << link.err;
  EXPECT_NE(link.out.find("payload on wrist_3_link"), std::string::npos) << link.out;
  const ReportedLoad in_tool0 = reported_load(nlohmann::json::parse(read(file("tool0.json"))));
  const ReportedLoad in_link = reported_load(nlohmann::json::parse(read(file("wrist_3.json"))));
  EXPECT_EQ(in_tool0.frame, "tool0");
  EXPECT_EQ(in_link.frame, "wrist_3_link");
  const sid::LinkInertia<double> truth = in_wrist_3(the_load());
  std::printf("[ errors ] in wrist_3_link: mass %+.3f %%, com %.2f mm\n",
              100.0 * (in_link.mass - truth.mass) / truth.mass,
              1e3 * (in_link.com - truth.com).norm());
  EXPECT_NEAR(in_link.mass, truth.mass, kMassTolerance * truth.mass);
  EXPECT_LT((in_link.com - truth.com).norm(), kComTolerance) << in_link.com.transpose();
  // The same body: tool0's figures moved by hand into wrist_3_link, the std of the centre of
  // mass turned with it.
  const sid::LinkParameters<double> moved =
      sid::standard_parameters(in_wrist_3(sid::link_inertia(in_tool0.phi)));
  EXPECT_TRUE(moved.isApprox(in_link.phi, kSameBodyTolerance)) << moved.transpose() << "\n"
                                                               << in_link.phi.transpose();
  EXPECT_TRUE((tool0_in_wrist_3().rotation.cwiseAbs() * in_tool0.com_std)
                  .isApprox(in_link.com_std, kSameBodyTolerance))
      << in_tool0.com_std.transpose() << "\n"
      << in_link.com_std.transpose();
  EXPECT_NEAR(in_link.mass_std, in_tool0.mass_std, kSameBodyTolerance * in_tool0.mass_std);
  // And the same URDF, the load hung from tool0 either way.
  const sid::UrdfChain from_tool0 =
      sid::chain_from_urdf(read(file("tool0.urdf")), "base_link", "tool0");
  const sid::UrdfChain from_link =
      sid::chain_from_urdf(read(file("wrist_3.urdf")), "base_link", "tool0");
  EXPECT_TRUE(from_link.theta.isApprox(from_tool0.theta, kSameBodyTolerance));
  // ee_link, fixed to wrist_3_link beside tool0, is a frame as well.
  const sid_test::AppRun ee = shell(ur5() + " --payload-frame ee_link" + run);
  EXPECT_EQ(ee.exit_code, 0) << ee.err;
  EXPECT_NE(ee.out.find("payload on ee_link"), std::string::npos) << ee.out;
}

TEST_F(Payload, RefusesAPayloadFrameThatIsNotFixedToTheLastMovingLink) {
  const auto refused = [&](const std::string& args, const std::string& says) {
    const sid_test::AppRun r = shell(app("sid_identify") + " " + args + " --json out.json");
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(says), std::string::npos) << args << "\n" << r.err;
    EXPECT_FALSE(std::filesystem::exists(file("out.json"))) << args;
  };
  const std::string robot = "--robot '" + ur5_path() + "'";
  const std::string run =
      " --payload-of '" + shared("arm.json") + "' '" + shared("loaded.csv") + "'";
  refused(robot + " --tip tool0 --payload-frame flange" + run,
          "--payload-frame: the URDF has no link 'flange'; the frame must be fixed to "
          "wrist_3_link, the chain's last moving link (e.g. tool0 or wrist_3_link itself)");
  refused(robot + " --tip tool0 --payload-frame forearm_link" + run,
          "--payload-frame: link 'forearm_link' is not below wrist_3_link");
  // With the chain ending at wrist_2_link, tool0 is past the moving wrist_3_joint.
  refused(robot + " --tip wrist_2_link --payload-frame tool0" + run,
          "link 'tool0' is not rigidly attached to wrist_2_link: joint 'wrist_3_joint' between "
          "them is revolute");
  write("arm.dh",
        "convention standard\nj1 0 1.5708 0.1 0\nj2 0.4 0 0 0\nj3 0.4 0 0 0\n"
        "j4 0 1.5708 0.1 0\nj5 0 -1.5708 0.1 0\nj6 0 0 0.08 0\n");
  refused("--robot arm.dh --payload-frame tool0" + run, "--payload-frame needs a URDF as --robot");
  refused(robot + " --tip tool0 --payload-frame tool0 '" + shared("unloaded.csv") + "'",
          "--payload-frame goes with --known-payload or --payload-of");
  refused("--payload-frame tool0 '" + shared("unloaded.csv") + "'",
          "--payload-frame needs --robot");
}

TEST_F(Payload, RefusesAMotionThatDoesNotShowTheLoadNamingWhatItLacks) {
  const Ur5 arm;
  // Only the base joint turns: the load's tip never tips over.
  std::vector<bool> moving(6, false);
  moving[0] = true;
  write_log(file("turn.csv"),
            inverse_dynamics_log(arm.model, with_load(arm, the_load()), 4.0, 5, moving));
  const sid_test::AppRun r =
      shell(ur5() + " --payload-of '" + shared("arm.json") + "' --json out.json turn.csv");
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.err.find("does not determine the load's"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("Izz"), std::string::npos) << r.err;
  // The load is reported in tool0's frame, the motion judged in wrist_3_link's.
  EXPECT_NE(r.err.find("(the parameters named in the frame of the chain's last moving link"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("sid_excite --robot"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(file("out.json")));
}

TEST_F(Payload, RefusesTheFitOfAnotherRobotAndFilesThatAreNoFit) {
  const auto refused = [&](const std::string& args, const std::string& says) {
    const sid_test::AppRun r = shell(app("sid_identify") + " " + args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(says), std::string::npos) << args << "\n" << r.err;
  };
  // The TX40 has six joints and the same drive terms: only its joints' names differ.
  refused("--robot '" SID_TEST_DATA_DIR "/ndof/tx40.urdf' --tip tool0 --payload-of '" +
              shared("arm.json") + "' '" + shared("loaded.csv") + "'",
          "is the fit of another robot");
  write("not.json", "{ nope");
  refused("--robot '" + ur5_path() + "' --tip tool0 --payload-of not.json '" +
              shared("loaded.csv") + "'",
          "is not JSON");
  write("other.json", "{\"theta\": [1, 2]}");
  refused("--robot '" + ur5_path() + "' --tip tool0 --payload-of other.json '" +
              shared("loaded.csv") + "'",
          "is it sid_identify --robot's --json output?");
  refused("--payload-of '" + shared("arm.json") + "' '" + shared("loaded.csv") + "'",
          "--payload-of needs --robot");
  refused("--robot '" + ur5_path() + "' --tip tool0 --cutoff 5 --payload-of '" +
              shared("arm.json") + "' '" + shared("loaded.csv") + "'",
          "the drive terms, the smoothing and the torque's delay are the arm's");
  refused("--robot '" + ur5_path() + "' --tip tool0 --torque-delay 0.002 --payload-of '" +
              shared("arm.json") + "' '" + shared("loaded.csv") + "'",
          "--torque-delay and --estimate-torque-delay do not apply");
}

}  // namespace
