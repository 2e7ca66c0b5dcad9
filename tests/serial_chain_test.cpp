// Tests of sid/model/serial_chain.hpp, sid/model/chain_regressor.hpp, sid/model/link_inertia.hpp
// and sid/base_parameters.hpp on two 6R arms: a PUMA 560 in standard DH and a Staubli TX40 in
// modified DH. References are Pinocchio's regressor and RNEA (tests/data/ndof/), a pendulum's
// closed form, and the regressor's own identities.

#include <sid/base_parameters.hpp>
#include <sid/least_squares.hpp>
#include <sid/model/articulated_body.hpp>
#include <sid/model/chain_dynamics.hpp>
#include <sid/model/chain_regressor.hpp>
#include <sid/model/link_inertia.hpp>
#include <sid/model/serial_chain.hpp>

#include "chain_test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace {

constexpr double kPi = 3.14159265358979323846;
// Both sides evaluate the same recursion in double: differences are round-off, ~1e-13.
constexpr double kTorqueTol = 1e-9;       // [N m]; |tau| reaches 77 N m
constexpr double kSlideForceTol = 1e-12;  // [N]; |f| reaches 30 N
constexpr double kBaseRelTol = 1e-10;     // relative to |beta|
constexpr double kIdentRelTol = 1e-8;     // least squares on exact kinematics, relative to |beta|

struct Arm {
  std::string name;  // of its reference files
  sid::SerialChain<double> chain;
  std::string label;
};

std::ostream& operator<<(std::ostream& os, const Arm& arm) { return os << arm.label; }

// Corke's mdl_puma560 (d, a, alpha in standard DH).
Arm puma560() {
  return {"puma560",
          sid::SerialChain<double>(sid::DhConvention::Standard, {{0.0, kPi / 2, 0.0, 0.0},
                                                                 {0.4318, 0.0, 0.0, 0.0},
                                                                 {0.0203, -kPi / 2, 0.15005, 0.0},
                                                                 {0.0, kPi / 2, 0.4318, 0.0},
                                                                 {0.0, -kPi / 2, 0.0, 0.0},
                                                                 {0.0, 0.0, 0.0, 0.0}}),
          "puma560"};
}

// Gautier and Khalil's TX40 table (alpha_j, d_j, r_j in Khalil's modified DH).
Arm tx40() {
  return {"tx40",
          sid::SerialChain<double>(sid::DhConvention::Modified, {{0.0, 0.0, 0.0, 0.0},
                                                                 {0.0, -kPi / 2, 0.0, 0.0},
                                                                 {0.225, 0.0, 0.035, 0.0},
                                                                 {0.0, kPi / 2, 0.225, 0.0},
                                                                 {0.0, -kPi / 2, 0.0, 0.0},
                                                                 {0.0, kPi / 2, 0.0, 0.0}}),
          "tx40"};
}

// The TX40 as URDF writes a chain: each joint frame placed in its parent's frame, the child
// link's frame on the joint (after = identity). Khalil's Rx(alpha) Tx(d) Rz(q) Tz(r) is
// [Rx(alpha) Tx(d) Tz(r)] Rz(q), as Rz and Tz commute.
Arm tx40_as_urdf() {
  const double table[6][3] = {{0.0, 0.0, 0.0},       {-kPi / 2, 0.0, 0.0}, {0.0, 0.225, 0.035},
                              {kPi / 2, 0.0, 0.225}, {-kPi / 2, 0.0, 0.0}, {kPi / 2, 0.0, 0.0}};
  std::vector<sid::JointPlacement<double>> joints(6);
  for (int j = 0; j < 6; ++j) {
    const double alpha = table[j][0], d = table[j][1], r = table[j][2];
    joints[j].before.rotation =
        Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitX()).toRotationMatrix();
    joints[j].before.translation << d, -std::sin(alpha) * r, std::cos(alpha) * r;
  }
  return {"tx40", sid::SerialChain<double>(joints), "tx40_urdf"};
}

Eigen::MatrixXd samples_of(const sid_test::Table& table, const std::string& stem) {
  Eigen::MatrixXd m(table.data.rows(), 6);
  for (int j = 0; j < 6; ++j) m.col(j) = table.col(stem + std::to_string(j + 1));
  return m;
}

// The reference's true theta, base columns and beta.
struct BaseReference {
  Eigen::VectorXd theta;
  std::vector<Eigen::Index> independent;
  Eigen::VectorXd beta;  // in the order of `independent`
  Eigen::Index n_base = 0;
};

BaseReference base_reference(const std::string& arm) {
  const sid_test::Table table = sid_test::read_table("ndof/base_" + arm + ".csv");
  BaseReference ref;
  ref.theta = table.col("theta");
  std::vector<double> beta;
  for (Eigen::Index j = 0; j < table.data.rows(); ++j)
    if (table.data(j, table.column("independent")) == 1.0) {
      ref.independent.push_back(j);
      beta.push_back(table.data(j, table.column("beta")));
    }
  ref.beta = Eigen::Map<Eigen::VectorXd>(beta.data(), static_cast<Eigen::Index>(beta.size()));
  const std::string& comment = table.comments.at(0);
  ref.n_base = std::stol(comment.substr(comment.find("n_base=") + 7));
  return ref;
}

// W over random states, q ~ U(-pi, pi), qd ~ U(-2, 2), qdd ~ U(-5, 5), as the reference drew.
Eigen::MatrixXd random_regressor(const sid::SerialChain<double>& chain, int samples,
                                 unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> angle(-kPi, kPi), rate(-2.0, 2.0), accel(-5.0, 5.0);
  const Eigen::Index n = chain.joints();
  Eigen::MatrixXd q(samples, n), qd(samples, n), qdd(samples, n);
  for (Eigen::Index k = 0; k < samples; ++k)
    for (Eigen::Index j = 0; j < n; ++j) {
      q(k, j) = angle(rng);
      qd(k, j) = rate(rng);
      qdd(k, j) = accel(rng);
    }
  return sid::stack_chain_regression(chain, q, qd, qdd, Eigen::MatrixXd::Zero(samples, n)).X;
}

class SixJointArm : public ::testing::TestWithParam<Arm> {};

TEST_P(SixJointArm, RegressorMatchesPinocchio) {
  sid_test::expect_reference_regressor(GetParam().chain, GetParam().name);
}

TEST_P(SixJointArm, InverseDynamicsMatchesPinocchioWithFriction) {
  const Arm& arm = GetParam();
  const sid_test::Table table = sid_test::read_table("ndof/rnea_" + arm.name + ".csv");
  const Eigen::VectorXd theta = base_reference(arm.name).theta;
  for (Eigen::Index row = 0; row < table.data.rows(); ++row) {
    const Eigen::VectorXd tau = sid::chain_inverse_dynamics(
        arm.chain, theta, sid_test::joints_of(table, row, "q"),
        sid_test::joints_of(table, row, "qd"), sid_test::joints_of(table, row, "qdd"));
    EXPECT_LT((tau - sid_test::joints_of(table, row, "tau")).cwiseAbs().maxCoeff(), kTorqueTol)
        << "sample " << row;
  }
}

TEST_P(SixJointArm, LinkTorquesOfTheRecursionAreTheRegressorsProduct) {
  const Arm& arm = GetParam();
  const int n = arm.chain.joints();
  const Eigen::Index links = sid::kLinkParameters * n;
  const Eigen::VectorXd theta = base_reference(arm.name).theta.head(links);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(-kPi, kPi), rate(-2.0, 2.0), accel(-5.0, 5.0);
  Eigen::MatrixXd y(n, sid::chain_parameter_count(n));
  Eigen::VectorXd q(n), qd(n), qdd(n), tau(n);
  for (int sample = 0; sample < 20; ++sample) {
    for (int j = 0; j < n; ++j) {
      q[j] = angle(rng);
      qd[j] = rate(rng);
      qdd[j] = accel(rng);
    }
    sid::chain_regressor(arm.chain, q, qd, qdd, y);
    sid::detail::chain_link_torques_unchecked(arm.chain, theta, q, qd, qdd, tau);
    EXPECT_LT((tau - y.leftCols(links) * theta).cwiseAbs().maxCoeff(), kTorqueTol)
        << "sample " << sample;
  }
}

TEST_P(SixJointArm, ForwardDynamicsInvertsTheTorquesAsPinocchiosAbaDoes) {
  // Pinocchio's ABA maps the rigid-body torques back to qdd to 1e-13; with friction in theta
  // and in the torques, so must sid's forward dynamics, both the O(n^3) route and the O(n)
  // articulated bodies. M(q) must be symmetric and its product with qdd plus h(q, qd) the
  // torque.
  const Arm& arm = GetParam();
  const sid_test::Table table = sid_test::read_table("ndof/rnea_" + arm.name + ".csv");
  const Eigen::VectorXd theta = base_reference(arm.name).theta;
  for (Eigen::Index row = 0; row < table.data.rows(); ++row) {
    const Eigen::VectorXd q = sid_test::joints_of(table, row, "q"),
                          qd = sid_test::joints_of(table, row, "qd"),
                          qdd = sid_test::joints_of(table, row, "qdd"),
                          tau = sid_test::joints_of(table, row, "tau");
    const Eigen::VectorXd qdd_hat = sid::chain_forward_dynamics(arm.chain, theta, q, qd, tau);
    EXPECT_LT((qdd_hat - qdd).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + qdd.cwiseAbs().maxCoeff()))
        << "sample " << row;
    const Eigen::VectorXd aba = sid::chain_forward_dynamics_aba(arm.chain, theta, q, qd, tau);
    const double scale = 1.0 + qdd.cwiseAbs().maxCoeff();
    EXPECT_LT((aba - qdd).cwiseAbs().maxCoeff(), 1e-10 * scale) << "sample " << row;
    EXPECT_LT((aba - qdd_hat).cwiseAbs().maxCoeff(), 1e-10 * scale) << "sample " << row;
    const Eigen::MatrixXd m = sid::chain_mass_matrix(arm.chain, theta, q);
    EXPECT_LT((m - m.transpose()).cwiseAbs().maxCoeff(), 1e-12 * m.cwiseAbs().maxCoeff());
    EXPECT_LT(
        (m * qdd + sid::chain_bias_torque(arm.chain, theta, q, qd) - tau).cwiseAbs().maxCoeff(),
        kTorqueTol);
  }
}

TEST_P(SixJointArm, FindsTheReferenceNumberOfBaseParametersAndRegroupsExactly) {
  const Arm& arm = GetParam();
  const BaseReference ref = base_reference(arm.name);
  const Eigen::MatrixXd w = random_regressor(arm.chain, 300, 7);
  const sid::BaseParameters<double> base = sid::base_parameters(w);
  EXPECT_EQ(base.rank(), ref.n_base);
  // Whichever columns the pivoting keeps, they must reproduce every torque.
  const Eigen::VectorXd tau = w * ref.theta;
  EXPECT_LT((base.base_regressor(w) * base.beta(ref.theta) - tau).cwiseAbs().maxCoeff(),
            kBaseRelTol * tau.cwiseAbs().maxCoeff());
  // On the reference's columns, beta is the reference's.
  const sid::BaseParameters<double> given = sid::base_parameters(w, ref.independent);
  ASSERT_EQ(given.rank(), ref.n_base);
  Eigen::VectorXd expected(ref.n_base);
  std::vector<Eigen::Index> order = ref.independent;
  for (Eigen::Index k = 0; k < ref.n_base; ++k) {
    const auto at = std::find(given.independent.begin(), given.independent.end(),
                              order[static_cast<std::size_t>(k)]) -
                    given.independent.begin();
    expected[at] = ref.beta[k];
  }
  EXPECT_LT((given.beta(ref.theta) - expected).norm(), kBaseRelTol * expected.norm());
}

TEST_P(SixJointArm, LeastSquaresOnExactKinematicsRecoversBeta) {
  const Arm& arm = GetParam();
  const BaseReference ref = base_reference(arm.name);
  const sid_test::Table ident = sid_test::read_table("ndof/ident_" + arm.name + ".csv");
  const sid::StackedRegression<double> r =
      sid::stack_chain_regression(arm.chain, samples_of(ident, "q"), samples_of(ident, "qd"),
                                  samples_of(ident, "qdd"), samples_of(ident, "tau"));
  const sid::BaseParameters<double> base =
      sid::base_parameters(random_regressor(arm.chain, 300, 11), ref.independent);
  const auto fit = sid::least_squares(base.base_regressor(r.X), r.y, 6);
  ASSERT_TRUE(fit.ok()) << fit.message;
  const Eigen::VectorXd beta = base.beta(ref.theta);
  EXPECT_LT((fit.theta - beta).cwiseAbs().maxCoeff(), kIdentRelTol * beta.norm());
}

INSTANTIATE_TEST_SUITE_P(ChainRegressor, SixJointArm,
                         ::testing::Values(puma560(), tx40(), tx40_as_urdf()),
                         [](const auto& info) { return info.param.label; });

TEST(ChainRegressor, FlippedAxesMirrorTheMotion) {
  // Turning about -z by q is turning about z by -q, and the torque about -z is minus the one
  // about z: Y_flipped(q, qd, qdd) = -Y(-q, -qd, -qdd), friction columns included.
  const Arm arm = tx40();
  std::vector<sid::JointPlacement<double>> flipped = arm.chain.placements();
  for (auto& joint : flipped) joint.axis = -2.0 * joint.axis;  // any length: axes are normalised
  const sid::SerialChain<double> mirror(flipped);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  Eigen::MatrixXd y(6, 72), y_mirror(6, 72);
  for (int k = 0; k < 20; ++k) {
    Eigen::VectorXd q(6), qd(6), qdd(6);
    for (int j = 0; j < 6; ++j) {
      q[j] = u(rng);
      qd[j] = u(rng);
      qdd[j] = u(rng);
    }
    sid::chain_regressor(arm.chain, -q, -qd, -qdd, y);
    sid::chain_regressor(mirror, q, qd, qdd, y_mirror);
    EXPECT_LT((y_mirror + y).cwiseAbs().maxCoeff(), sid_test::kChainRegressorTol) << "state " << k;
  }
}

// The published mass, centre of mass and inertia about it (link-frame axes) per link:
// m, cx, cy, cz, Ixx, Iyy, Izz, Ixy, Iyz, Ixz.
using LinkTable = std::vector<std::array<double, 10>>;

const LinkTable kPuma560Links = {{0, 0, 0, 0, 0, 0.35, 0, 0, 0, 0},
                                 {17.4, -0.3638, 0.006, 0.2275, 0.13, 0.524, 0.539, 0, 0, 0},
                                 {4.8, -0.0203, -0.0141, 0.07, 0.066, 0.086, 0.0125, 0, 0, 0},
                                 {0.82, 0, 0.019, 0, 0.0018, 0.0013, 0.0018, 0, 0, 0},
                                 {0.34, 0, 0, 0, 0.0003, 0.0004, 0.0003, 0, 0, 0},
                                 {0.09, 0, 0, 0.032, 0.00015, 0.00015, 4e-05, 0, 0, 0}};
const LinkTable kTx40Links = {{10.5, 0, 0.02, -0.043, 0.055, 0.047, 0.035, 0, 0.003, 0},
                              {3.6, 0.109, -0.002, 0.134, 0.038, 0.009, 0.04, 0, -0.002, 0},
                              {4.07, 0.008, 0.006, 0.041, 0.012, 0.012, 0.004, 0, -0.001, -0.001},
                              {3.62, -0.004, 0.002, -0.107, 0.014, 0.013, 0.004, 0, 0, -0.001},
                              {1.02, -0.004, -0.003, -0.001, 0.001, 0.001, 0.001, 0, 0, 0},
                              {0.2, 0, 0, 0.042, 8e-05, 8e-05, 0.00016, 0, 0, 0}};

sid::LinkInertia<double> link_of(const std::array<double, 10>& row) {
  sid::LinkInertia<double> link;
  link.mass = row[0];
  link.com << row[1], row[2], row[3];
  link.inertia_com << row[4], row[7], row[9], row[7], row[5], row[8], row[9], row[8], row[6];
  return link;
}

TEST(LinkInertia, StandardParametersOfThePublishedLinksArePinocchios) {
  for (const auto& [arm, links] : {std::pair{std::string("puma560"), kPuma560Links},
                                   std::pair{std::string("tx40"), kTx40Links}}) {
    const Eigen::VectorXd theta = base_reference(arm).theta;
    for (int i = 0; i < 6; ++i) {
      const sid::LinkParameters<double> phi = sid::standard_parameters(link_of(links[i]));
      EXPECT_LT((phi - theta.segment<10>(10 * i)).cwiseAbs().maxCoeff(), 1e-14)
          << arm << " link " << i + 1;
    }
  }
}

TEST(LinkInertia, NamesWhyAPublishedLinkCannotBeARealBody) {
  // The PUMA's link 1 has no mass in the source and its link 3's principal moments
  // (0.0125, 0.066, 0.086) break the triangle inequality; the TX40's links are all real.
  const Eigen::VectorXd puma = base_reference("puma560").theta;
  EXPECT_EQ(sid::link_inconsistency<double>(puma.segment<10>(0)), "the mass is not positive");
  EXPECT_EQ(sid::link_inconsistency<double>(puma.segment<10>(20)),
            "the principal moments break the triangle inequality");
  for (const int i : {1, 3, 4, 5})
    EXPECT_EQ(sid::link_inconsistency<double>(puma.segment<10>(10 * i)), "") << "link " << i + 1;
  const Eigen::VectorXd tx40 = base_reference("tx40").theta;
  for (int i = 0; i < 6; ++i)
    EXPECT_EQ(sid::link_inconsistency<double>(tx40.segment<10>(10 * i)), "") << "link " << i + 1;
  // A negative principal moment about the centre of mass, seen through the parallel axes.
  sid::LinkInertia<double> bad = link_of(kTx40Links[1]);
  bad.inertia_com(2, 2) = -0.001;
  EXPECT_EQ(sid::link_inconsistency(sid::standard_parameters(bad)),
            "the inertia about the centre of mass is not positive definite");
}

TEST(ChainRegressor, PendulumHasItsClosedForm) {
  // One joint turning about z, gravity along -y: tau = (Izz_c + m l^2) qdd + m g l cos(q)
  // + Fv qd + Fc sign(qd) for a point-like link with its centre of mass at (l, 0, 0).
  const double m = 1.3, l = 0.4, izz_c = 0.02, g = 9.81, fv = 0.1, fc = 0.3;
  for (const auto convention : {sid::DhConvention::Standard, sid::DhConvention::Modified}) {
    // Standard DH puts frame 1 at the far end (a = l): there the centre of mass is at the origin.
    const bool standard = convention == sid::DhConvention::Standard;
    const sid::SerialChain<double> chain(convention, {{standard ? l : 0.0, 0.0, 0.0, 0.0}},
                                         sid::Vector3<double>(0.0, -g, 0.0));
    Eigen::VectorXd theta = Eigen::VectorXd::Zero(12);
    const double cx = standard ? 0.0 : l;
    theta[0] = m;
    theta[1] = m * cx;
    theta[9] = izz_c + m * cx * cx;
    theta[10] = fv;
    theta[11] = fc;
    for (const double q : {-2.0, -0.3, 0.0, 1.1, 2.9})
      for (const double qd : {-1.5, 0.0, 0.7}) {
        const double qdd = 0.8 - q;
        const double expected = (izz_c + m * l * l) * qdd + m * g * l * std::cos(q) + fv * qd +
                                fc * ((qd > 0) - (qd < 0));
        const Eigen::VectorXd tau = sid::chain_inverse_dynamics(
            chain, theta, Eigen::VectorXd::Constant(1, q), Eigen::VectorXd::Constant(1, qd),
            Eigen::VectorXd::Constant(1, qdd));
        EXPECT_NEAR(tau[0], expected, 1e-12) << (standard ? "standard" : "modified") << " q " << q;
      }
  }
}

TEST(ChainRegressor, PolarArmWithAPrismaticJointHasItsClosedForm) {
  // Joint 1 turns about z, joint 2 slides along link 1's x by r = q2 + offset; link 1 has Izz
  // about the axis, link 2 is a point mass m at its frame's origin; gravity along -y. Then
  // tau1 = (Izz + m r^2) qdd1 + 2 m r qd1 qd2 + m g r cos(q1) and
  // f2 = m qdd2 - m r qd1^2 + m g sin(q1) + Fv2 qd2 + Fc2 sign(qd2).
  const double izz = 0.05, m = 2.0, g = 9.81, offset = 0.3, fv = 4.0, fc = 1.5;
  std::vector<sid::JointPlacement<double>> joints(2);
  joints[1].axis = Eigen::Vector3d(-2.0, 0.0, 0.0);  // any length, either sign
  joints[1].offset = -offset;
  joints[1].type = sid::JointType::Prismatic;
  const sid::SerialChain<double> chain(joints, sid::Vector3<double>(0.0, -g, 0.0));
  EXPECT_EQ(chain.joint_type(1), sid::JointType::Prismatic);
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(24);
  theta[9] = izz;
  theta[10] = m;
  theta[21] = fv;
  theta[23] = fc;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector2d q(u(rng), u(rng)), qd(u(rng), u(rng)), qdd(u(rng), u(rng));
    const double r = -(q[1] - offset);  // the axis points along -x
    const double rd = -qd[1], rdd = -qdd[1];
    const double tau1 =
        (izz + m * r * r) * qdd[0] + 2.0 * m * r * rd * qd[0] + m * g * r * std::cos(q[0]);
    const double f_r = m * rdd - m * r * qd[0] * qd[0] + m * g * std::sin(q[0]);
    const double f2 = -f_r + fv * qd[1] + fc * ((qd[1] > 0) - (qd[1] < 0));
    const Eigen::VectorXd tau = sid::chain_inverse_dynamics(chain, theta, q, qd, qdd);
    EXPECT_LT((tau - Eigen::Vector2d(tau1, f2)).cwiseAbs().maxCoeff(), 1e-12) << "state " << k;
    const auto poses = chain.forward_kinematics(q);
    EXPECT_LT(
        (poses[1].translation - r * Eigen::Vector3d(std::cos(q[0]), std::sin(q[0]), 0.0)).norm(),
        1e-15);
    const Eigen::MatrixXd mass = sid::chain_mass_matrix(chain, theta, q);
    EXPECT_LT((mass - Eigen::Vector2d(izz + m * r * r, m).asDiagonal().toDenseMatrix())
                  .cwiseAbs()
                  .maxCoeff(),
              1e-12);
    EXPECT_LT((sid::chain_forward_dynamics(chain, theta, q, qd, tau) - qdd).cwiseAbs().maxCoeff(),
              1e-12);
  }
}

TEST(ChainRegressor, ForwardKinematicsComposesTheTable) {
  // The PUMA at q = 0, against NumPy's product of the six DH matrices: the arm reaches a2 + a3
  // along x, d3 along -y and d4 up, with the tool frame parallel to the base.
  const Arm arm = puma560();
  const auto poses = arm.chain.forward_kinematics(Eigen::VectorXd::Zero(6));
  ASSERT_EQ(poses.size(), 6u);
  EXPECT_NEAR((poses[5].translation - Eigen::Vector3d(0.4521, -0.15005, 0.4318)).norm(), 0.0,
              1e-12);
  EXPECT_NEAR((poses[5].rotation - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-12);
}

TEST(ChainRegressor, VerticalSlideCarriesItsWeight) {
  // One prismatic DH row carrying a body of mass m, gravity 9.81 along -z. In the standard
  // convention the row slides along the base's z whatever a, alpha and the constant angle:
  // f = m (qdd + g). In the modified one it slides along Rx(alpha) z: f = m (qdd + g cos(alpha)).
  // Neither depends on where the centre of mass is or on the inertia (no rotation).
  const double m = 2.5, g = 9.81, alpha = 0.6;
  const sid::LinkInertia<double> body{
      m, {0.1, -0.2, 0.3}, Eigen::Vector3d(0.02, 0.03, 0.04).asDiagonal().toDenseMatrix()};
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(12);
  theta.head<10>() = sid::standard_parameters(body);
  const auto slide = sid::JointType::Prismatic;
  const sid::SerialChain<double> standard(sid::DhConvention::Standard,
                                          {{0.3, alpha, 0.2, 0.7, slide}});
  const sid::SerialChain<double> modified(sid::DhConvention::Modified,
                                          {{0.3, alpha, 0.2, 0.7, slide}});
  ASSERT_EQ(standard.joint_type(0), sid::JointType::Prismatic);
  for (const double q : {-0.4, 0.0, 0.25})
    for (const double qd : {-1.0, 0.0, 0.5})
      for (const double qdd : {-3.0, 0.0, 2.0}) {
        const auto one = [](double v) { return Eigen::VectorXd::Constant(1, v); };
        EXPECT_NEAR(sid::chain_inverse_dynamics(standard, theta, one(q), one(qd), one(qdd))[0],
                    m * (qdd + g), kSlideForceTol);
        EXPECT_NEAR(sid::chain_inverse_dynamics(modified, theta, one(q), one(qd), one(qdd))[0],
                    m * (qdd + g * std::cos(alpha)), kSlideForceTol);
      }
}

TEST(ChainRegressor, PrismaticDhRowsComposeTheirTransforms) {
  // T = Rz(offset) Tz(q + d) Tx(a) Rx(alpha) (standard), Rx(alpha) Tx(a) Rz(offset) Tz(q + d)
  // (modified), composed here as 4 x 4 matrices.
  const auto rx = [](double t) {
    Eigen::Matrix4d h = Eigen::Matrix4d::Identity();
    h.topLeftCorner<3, 3>() = Eigen::AngleAxisd(t, Eigen::Vector3d::UnitX()).toRotationMatrix();
    return h;
  };
  const auto rz = [](double t) {
    Eigen::Matrix4d h = Eigen::Matrix4d::Identity();
    h.topLeftCorner<3, 3>() = Eigen::AngleAxisd(t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return h;
  };
  const auto shift = [](double x, double z) {
    Eigen::Matrix4d h = Eigen::Matrix4d::Identity();
    h(0, 3) = x;
    h(2, 3) = z;
    return h;
  };
  const double a = 0.3, alpha = -0.8, d = 0.15, offset = 1.1, q = 0.42;
  const sid::DhJoint<double> row{a, alpha, d, offset, sid::JointType::Prismatic};
  const Eigen::Matrix4d standard = rz(offset) * shift(0.0, q + d) * shift(a, 0.0) * rx(alpha);
  const Eigen::Matrix4d modified = rx(alpha) * shift(a, 0.0) * rz(offset) * shift(0.0, q + d);
  for (const auto& [convention, expected] : {std::pair{sid::DhConvention::Standard, standard},
                                             std::pair{sid::DhConvention::Modified, modified}}) {
    const sid::FramePose<double> pose = sid::SerialChain<double>(convention, {row}).link_pose(0, q);
    EXPECT_LT((pose.rotation - expected.topLeftCorner<3, 3>()).cwiseAbs().maxCoeff(), 1e-15);
    EXPECT_LT((pose.translation - expected.topRightCorner<3, 1>()).cwiseAbs().maxCoeff(), 1e-15);
  }
  // A revolute row (the default type) is what it was: its angle q + offset, its slide d.
  const sid::DhJoint<double> turning{a, alpha, d, offset};
  const sid::FramePose<double> turned =
      sid::SerialChain<double>(sid::DhConvention::Standard, {turning}).link_pose(0, q);
  const Eigen::Matrix4d expected = rz(q + offset) * shift(0.0, d) * shift(a, 0.0) * rx(alpha);
  EXPECT_LT((turned.rotation - expected.topLeftCorner<3, 3>()).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((turned.translation - expected.topRightCorner<3, 1>()).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(ChainRegressor, RejectsBadInput) {
  using Table = std::vector<sid::DhJoint<double>>;
  EXPECT_THROW(sid::SerialChain<double>(sid::DhConvention::Standard, Table{}),
               std::invalid_argument);
  EXPECT_THROW(
      sid::SerialChain<double>(sid::DhConvention::Standard, Table(sid::kMaxChainJoints + 1)),
      std::invalid_argument);
  Table nan_row(2);
  nan_row[1].d = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(sid::SerialChain<double>(sid::DhConvention::Modified, nan_row),
               std::invalid_argument);
  Table unknown_type(1);
  unknown_type[0].type = static_cast<sid::JointType>(7);
  EXPECT_THROW(sid::SerialChain<double>(sid::DhConvention::Standard, unknown_type),
               std::invalid_argument);
  std::vector<sid::JointPlacement<double>> zero_axis(1);
  zero_axis[0].axis.setZero();
  EXPECT_THROW(sid::SerialChain<double>{zero_axis}, std::invalid_argument);
  const Arm arm = tx40();
  EXPECT_THROW((void)arm.chain.link_pose(6, 0.0), std::invalid_argument);
  EXPECT_THROW((void)arm.chain.joint_axis(-1), std::invalid_argument);
  EXPECT_THROW((void)arm.chain.forward_kinematics(Eigen::VectorXd::Zero(7)), std::invalid_argument);
  const Eigen::VectorXd six = Eigen::VectorXd::Zero(6);
  Eigen::MatrixXd y(6, 72);
  EXPECT_THROW(sid::chain_regressor(arm.chain, Eigen::VectorXd::Zero(5), six, six, y),
               std::invalid_argument);
  Eigen::MatrixXd narrow(6, 71);
  EXPECT_THROW(sid::chain_regressor(arm.chain, six, six, six, narrow), std::invalid_argument);
  EXPECT_THROW(
      (void)sid::chain_inverse_dynamics(arm.chain, Eigen::VectorXd::Zero(60), six, six, six),
      std::invalid_argument);
  EXPECT_THROW((void)sid::chain_forward_dynamics(arm.chain, Eigen::VectorXd::Zero(72), six, six,
                                                 Eigen::VectorXd::Zero(5)),
               std::invalid_argument);
  // A massless arm cannot be accelerated.
  EXPECT_THROW(
      (void)sid::chain_forward_dynamics(arm.chain, Eigen::VectorXd::Zero(72), six, six, six),
      std::invalid_argument);
  Eigen::MatrixXd samples = Eigen::MatrixXd::Zero(4, 6);
  Eigen::MatrixXd with_nan = samples;
  with_nan(2, 3) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW((void)sid::stack_chain_regression(arm.chain, samples, samples, with_nan, samples),
               std::invalid_argument);
  EXPECT_THROW((void)sid::stack_chain_regression(arm.chain, samples, samples, samples,
                                                 Eigen::MatrixXd::Zero(4, 5)),
               std::invalid_argument);
  const Eigen::MatrixXd w = random_regressor(arm.chain, 20, 3);
  EXPECT_THROW((void)sid::base_parameters(w, 0.0), std::invalid_argument);
  EXPECT_THROW((void)sid::base_parameters(Eigen::MatrixXd::Zero(5, 3)), std::invalid_argument);
  EXPECT_THROW((void)sid::base_parameters(w, std::vector<Eigen::Index>{3, 3}),
               std::invalid_argument);
  EXPECT_THROW((void)sid::base_parameters(w, std::vector<Eigen::Index>{72}), std::invalid_argument);
  // Column 0 (m_1 of the TX40) never moves a joint: it cannot be independent.
  EXPECT_THROW((void)sid::base_parameters(w, std::vector<Eigen::Index>{0, 9}),
               std::invalid_argument);
}

}  // namespace
