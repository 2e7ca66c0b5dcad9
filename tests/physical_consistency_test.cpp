// Tests of include/sid/physical_consistency.hpp. References are independent of the header: the
// arm's closed-form mass matrix and Eigen's symmetric eigensolver for check_physical, the analytic
// condition "theta2 > 0 and theta1 theta2 > theta3^2" for positive definiteness at every q2, and,
// for nearest_physical, (i) a Euclidean projection known in closed form, (ii) the problem reduced
// to two variables on the boundary theta3 = sqrt(theta1 theta2) and solved by pattern search, and
// (iii) the first-order optimality condition grad f(theta)'(theta' - theta) >= 0 over sampled
// feasible theta'.

#include <sid/physical_consistency.hpp>

#include <sid/model/effects.hpp>
#include <sid/model/model.hpp>
#include <sid/model/two_link_arm.hpp>

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr Eigen::Index kGrid = 360;              // the default grid
constexpr double kGridStep = 2.0 * kPi / kGrid;  // [rad]
constexpr double kEigenAbsTol = 1e-13;           // [kg m^2] same D, different eigen-formulas
constexpr double kParameterAbsTol = 1e-8;        // solver vs reference [units of theta]
constexpr double kOptimalityRelTol = 1e-7;       // first-order condition, relative to the cost

using V2 = sid::Vector2<double>;

double grid_q2(Eigen::Index g) { return -kPi + kGridStep * static_cast<double>(g); }

struct EigenMinimum {
  double value = std::numeric_limits<double>::infinity();
  double q2 = 0.0;
};

/// Smallest eigenvalue of model.mass_matrix(theta, (0, q2)) over the default grid, by Eigen's
/// eigensolver (the header builds D from regressor columns and a closed-form 2 x 2 formula).
EigenMinimum reference_min_eigenvalue(const sid::Model<double>& model,
                                      const Eigen::VectorXd& theta) {
  EigenMinimum m;
  for (Eigen::Index g = 0; g < kGrid; ++g) {
    const Eigen::Matrix2d d = model.mass_matrix(theta, V2(0.0, grid_q2(g)));
    const Eigen::Matrix2d sym = 0.5 * (d + d.transpose());
    const double v =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>().computeDirect(sym).eigenvalues()(0);
    if (v < m.value) m = {v, grid_q2(g)};
  }
  return m;
}

/// Same with the arm's closed-form D (paper eq. 39), not through the model at all.
EigenMinimum closed_form_min_eigenvalue(const sid::TwoLinkParameters<double>& theta) {
  EigenMinimum m;
  for (Eigen::Index g = 0; g < kGrid; ++g) {
    const Eigen::Matrix2d d = sid::two_link_mass_matrix(theta, V2(0.0, grid_q2(g)));
    const double v =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>().computeDirect(d).eigenvalues()(0);
    if (v < m.value) m = {v, grid_q2(g)};
  }
  return m;
}

/// X (2n x p: joint 1's rows, then joint 2's) of the model at random states.
Eigen::MatrixXd random_regressor(const sid::Model<double>& model, Eigen::Index n,
                                 std::mt19937& rng) {
  std::uniform_real_distribution<double> angle(-kPi, kPi), rate(-3.0, 3.0), accel(-10.0, 10.0);
  Eigen::MatrixXd x(2 * n, model.num_parameters());
  for (Eigen::Index i = 0; i < n; ++i) {
    const V2 q(angle(rng), angle(rng)), qd(rate(rng), rate(rng)), qdd(accel(rng), accel(rng));
    const auto z = model.regressor(q, qd, qdd);
    x.row(i) = z.row(0);
    x.row(n + i) = z.row(1);
  }
  return x;
}

Eigen::VectorXd gaussian(Eigen::Index n, double sigma, std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, sigma);
  Eigen::VectorXd e(n);
  for (Eigen::Index i = 0; i < n; ++i) e(i) = noise(rng);
  return e;
}

double cost(const Eigen::MatrixXd& x, const Eigen::VectorXd& y, const Eigen::VectorXd& theta) {
  return (x * theta - y).squaredNorm();
}

Eigen::VectorXd paper_theta() { return sid::paper_arm_parameters<double>(); }

/// Index of a parameter name in the model.
Eigen::Index index_of(const sid::Model<double>& model, const std::string& name) {
  const auto names = model.parameter_names();
  return static_cast<Eigen::Index>(std::find(names.begin(), names.end(), name) - names.begin());
}

/// Minimises f over R^2 by pattern search (8 directions, step doubled on success, halved on
/// failure) from x until the step is below min_step: slow but assumption-free, and each f here
/// is O(1).
Eigen::Vector2d pattern_search(const std::function<double(const Eigen::Vector2d&)>& f,
                               Eigen::Vector2d x, double step, double min_step) {
  const Eigen::Vector2d dirs[] = {{1, 0}, {-1, 0}, {0, 1},  {0, -1},
                                  {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};
  double fx = f(x);
  while (step > min_step) {
    bool improved = false;
    for (const auto& d : dirs) {
      const Eigen::Vector2d trial = x + step * d;
      const double ft = f(trial);
      if (ft < fx) {
        x = trial;
        fx = ft;
        improved = true;
        break;
      }
    }
    step = improved ? 2.0 * step : 0.5 * step;
  }
  return x;
}

/// The least-squares fit restricted to the boundary theta3 = sqrt(theta1 theta2) (where an arm
/// with theta1 theta2 < theta3^2, theta3 > 0 is projected), with the parameters in `zero` fixed
/// at 0 and the others free. For fixed (theta1, theta2) the free parameters are a linear least
/// squares problem, so projecting them out leaves a quadratic form in w = (theta1, theta2,
/// sqrt(theta1 theta2)) minimised over two variables by pattern search.
Eigen::VectorXd reference_on_boundary(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                                      const std::vector<Eigen::Index>& zero,
                                      const Eigen::Vector2d& start) {
  const Eigen::Index p = x.cols();
  std::vector<Eigen::Index> free;
  for (Eigen::Index j = 3; j < p; ++j)
    if (std::find(zero.begin(), zero.end(), j) == zero.end()) free.push_back(j);
  Eigen::MatrixXd xf(x.rows(), static_cast<Eigen::Index>(free.size()));
  for (std::size_t j = 0; j < free.size(); ++j)
    xf.col(static_cast<Eigen::Index>(j)) = x.col(free[j]);
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr_free(xf);
  const auto project_out = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
    return v - xf * qr_free.solve(v);
  };
  Eigen::MatrixXd xt(x.rows(), 3);
  for (Eigen::Index j = 0; j < 3; ++j) xt.col(j) = project_out(x.col(j));
  const Eigen::VectorXd yt = project_out(y);
  const Eigen::Matrix3d gram = xt.transpose() * xt;
  const Eigen::Vector3d b = xt.transpose() * yt;
  const double c0 = yt.squaredNorm();
  // Relative coordinates u = theta_j / start_j keep the search well scaled.
  const auto f = [&](const Eigen::Vector2d& u) {
    const double t1 = u(0) * start(0), t2 = u(1) * start(1);
    if (t1 <= 0.0 || t2 <= 0.0) return std::numeric_limits<double>::infinity();
    const Eigen::Vector3d w(t1, t2, std::sqrt(t1 * t2));
    return w.dot(gram * w) - 2.0 * b.dot(w) + c0;
  };
  const Eigen::Vector2d u = pattern_search(f, Eigen::Vector2d(1.0, 1.0), 0.01, 1e-14);
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(p);
  theta(0) = u(0) * start(0);
  theta(1) = u(1) * start(1);
  theta(2) = std::sqrt(theta(0) * theta(1));
  const Eigen::VectorXd rest = qr_free.solve(y - x.leftCols(3) * theta.head(3));
  for (std::size_t j = 0; j < free.size(); ++j) theta(free[j]) = rest(static_cast<Eigen::Index>(j));
  return theta;
}

/// grad f(theta)'(theta' - theta) >= -tol for sampled theta' satisfying the constraints (checked
/// with reference_min_eigenvalue and the bounds directly): by convexity this is what "theta
/// minimises f over the feasible set" means. Samples are theta + alpha delta at several scales,
/// so both nearby and distant feasible points are tried; at least `min_feasible` must be.
void expect_first_order_optimal(const sid::Model<double>& model, const Eigen::MatrixXd& x,
                                const Eigen::VectorXd& y, const Eigen::VectorXd& theta,
                                const std::vector<std::string>& bounded, double margin,
                                std::mt19937& rng) {
  const Eigen::VectorXd grad = 2.0 * x.transpose() * (x * theta - y);
  const double tol = kOptimalityRelTol * cost(x, y, theta);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::VectorXd typical = theta.cwiseAbs().array() + 1e-3;
  int feasible = 0;
  for (int s = 0; s < 3000; ++s) {
    const double alpha = std::pow(10.0, -4.0 + 4.0 * (s % 5) / 4.0);  // 1e-4 .. 1
    Eigen::VectorXd delta(theta.size());
    for (Eigen::Index k = 0; k < delta.size(); ++k) delta(k) = normal(rng) * typical(k);
    const Eigen::VectorXd other = theta + alpha * delta;
    bool ok = reference_min_eigenvalue(model, other).value >= margin;
    for (const auto& name : bounded) ok = ok && other(index_of(model, name)) >= 0.0;
    if (!ok) continue;
    ++feasible;
    EXPECT_GE(grad.dot(other - theta), -tol) << "theta' = " << other.transpose();
  }
  EXPECT_GE(feasible, 100) << "too few feasible samples for the check to mean anything";
}

template <typename F>
void expect_invalid_argument(const F& f, const std::string& prefix) {
  try {
    f();
    ADD_FAILURE() << "no exception, expected std::invalid_argument starting with " << prefix;
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind(prefix, 0), 0u) << e.what();
  }
}

sid::Model<double> arm() { return sid::two_link_arm_model<double>(); }

}  // namespace

// ---------------------------------------------------------------------------------------------
// check_physical

TEST(CheckPhysical, PaperParametersArePlausible) {
  const auto model = arm();
  const sid::PhysicalCheck check = sid::check_physical(model, paper_theta());
  EXPECT_TRUE(check.plausible());
  EXPECT_TRUE(check.mass_matrix_positive_definite);
  EXPECT_TRUE(check.negative_parameters.empty());
  const EigenMinimum ref = closed_form_min_eigenvalue(sid::paper_arm_parameters<double>());
  EXPECT_GT(ref.value, 0.0);
  EXPECT_NEAR(check.min_eigenvalue, ref.value, kEigenAbsTol);
  EXPECT_DOUBLE_EQ(check.min_eigenvalue_q2, ref.q2);
}

TEST(CheckPhysical, FlagsIndefiniteMassMatrixWorstAtStretchedOrFoldedArm) {
  const auto model = arm();
  sid::TwoLinkParameters<double> theta = sid::paper_arm_parameters<double>();
  theta(2) = 1.5 * std::sqrt(theta(0) * theta(1));  // theta1 theta2 < theta3^2
  const sid::PhysicalCheck check = sid::check_physical(model, theta);
  EXPECT_FALSE(check.plausible());
  EXPECT_FALSE(check.mass_matrix_positive_definite);
  EXPECT_TRUE(check.negative_parameters.empty());
  EXPECT_LT(check.min_eigenvalue, 0.0);
  // det D = theta1 theta2 - theta3^2 cos^2 q2 is smallest at q2 = 0 or pi.
  EXPECT_LT(std::abs(std::sin(check.min_eigenvalue_q2)), 1.01 * kGridStep)
      << "q2 = " << check.min_eigenvalue_q2;
  const EigenMinimum ref = closed_form_min_eigenvalue(theta);
  EXPECT_NEAR(check.min_eigenvalue, ref.value, kEigenAbsTol);
}

TEST(CheckPhysical, AgreesWithAnalyticConditionOnRandomParameters) {
  // D(q) > 0 for every q2 iff theta2 > 0 and theta1 theta2 > theta3^2 (det D = theta1 theta2 -
  // theta3^2 cos^2 q2, and the grid holds cos^2 q2 = 1).
  const auto model = arm();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  int positive = 0, negative = 0;
  for (int s = 0; s < 2000; ++s) {
    Eigen::VectorXd theta = paper_theta();
    theta(0) = u(rng);
    theta(1) = u(rng);
    theta(2) = u(rng);
    const double det = theta(0) * theta(1) - theta(2) * theta(2);
    if (std::abs(det) < 1e-8 || std::abs(theta(1)) < 1e-6) continue;  // too close to call
    const bool expected = theta(1) > 0.0 && det > 0.0;
    (expected ? positive : negative)++;
    EXPECT_EQ(sid::check_physical(model, theta).mass_matrix_positive_definite, expected)
        << theta.head(3).transpose();
  }
  EXPECT_GT(positive, 100);
  EXPECT_GT(negative, 100);
}

TEST(CheckPhysical, NamesNegativeGravityParameter) {
  const auto model = arm();
  Eigen::VectorXd theta = paper_theta();
  theta(3) = -0.1;
  const sid::PhysicalCheck check = sid::check_physical(model, theta);
  EXPECT_FALSE(check.plausible());
  EXPECT_TRUE(check.mass_matrix_positive_definite);
  EXPECT_EQ(check.negative_parameters, std::vector<std::string>{"theta4"});
  EXPECT_EQ(check.negative_values, std::vector<double>{-0.1});
}

TEST(CheckPhysical, UsesTheGivenListIgnoringUnknownNames) {
  const auto model = arm();
  Eigen::VectorXd theta = paper_theta();
  theta(3) = -0.1;
  theta(2) = -0.001;
  sid::PhysicalConstraints c;
  c.nonnegative = std::vector<std::string>{"theta3", "no_such_parameter"};
  const sid::PhysicalCheck check = sid::check_physical(model, theta, c);
  EXPECT_EQ(check.negative_parameters, std::vector<std::string>{"theta3"});
  c.nonnegative = std::vector<std::string>{};
  EXPECT_TRUE(sid::check_physical(model, theta, c).plausible());
}

TEST(CheckPhysical, DefaultConstraintsChooseGravityFrictionCoulombAndArmatureByName) {
  auto model = arm();
  for (const char* id : {"coulomb_j1", "torque_offset_j1", "stribeck_j2", "armature_j2",
                         "spring_j1", "angle_offset_q2"})
    model.add(sid::effect_term(id));
  const sid::PhysicalConstraints c = sid::default_physical_constraints(model);
  ASSERT_TRUE(c.nonnegative.has_value());
  EXPECT_EQ(*c.nonnegative,
            (std::vector<std::string>{"theta4", "theta5", "theta6", "theta7", "coulomb_j1.Fc",
                                      "stribeck_j2.Fc", "armature_j2.Ia"}));
  EXPECT_EQ(c.grid_size, kGrid);
}

TEST(CheckPhysical, MassMatrixWithEffectTermsMatchesModelMassMatrix) {
  // armature_j2 adds Ia to D22 and angle_offset_q2 adds sin q2 terms: D then has no closed form
  // here, so the reference is the model's own mass_matrix with Eigen's eigensolver.
  auto model = arm();
  model.add(sid::effect_term("armature_j2"));
  model.add(sid::effect_term("angle_offset_q2"));
  Eigen::VectorXd theta(model.num_parameters());
  theta << paper_theta(), -0.0025, 0.004, 0.001;
  const sid::PhysicalCheck check = sid::check_physical(model, theta);
  const EigenMinimum ref = reference_min_eigenvalue(model, theta);
  EXPECT_NEAR(check.min_eigenvalue, ref.value, kEigenAbsTol);
  EXPECT_DOUBLE_EQ(check.min_eigenvalue_q2, ref.q2);
  EXPECT_EQ(check.negative_parameters, std::vector<std::string>{"armature_j2.Ia"});
}

TEST(CheckPhysical, RejectsBadInput) {
  const auto model = arm();
  expect_invalid_argument([&] { (void)sid::check_physical(model, Eigen::VectorXd::Ones(6)); },
                          "sid::check_physical: ");
  Eigen::VectorXd theta = paper_theta();
  theta(0) = std::numeric_limits<double>::quiet_NaN();
  expect_invalid_argument([&] { (void)sid::check_physical(model, theta); },
                          "sid::check_physical: ");
  sid::PhysicalConstraints c;
  c.grid_size = 0;
  expect_invalid_argument([&] { (void)sid::check_physical(model, paper_theta(), c); },
                          "sid::check_physical: ");
}

// ---------------------------------------------------------------------------------------------
// nearest_physical

TEST(NearestPhysical, ReturnsFeasibleLeastSquaresUnchanged) {
  const auto model = arm();
  std::mt19937 rng(1);
  const Eigen::MatrixXd x = random_regressor(model, 200, rng);
  const Eigen::VectorXd y = x * paper_theta() + gaussian(x.rows(), 0.01, rng);
  const Eigen::VectorXd ls = x.colPivHouseholderQr().solve(y);
  ASSERT_TRUE(sid::check_physical(model, ls).plausible());

  const sid::ConsistentEstimate r = sid::nearest_physical(model, x, y);
  EXPECT_FALSE(r.changed);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.theta, r.theta_unconstrained);
  EXPECT_LT((r.theta - ls).cwiseAbs().maxCoeff(), kParameterAbsTol);
  EXPECT_EQ(r.cost_increase, 0.0);
  EXPECT_TRUE(r.active_bounds.empty());
  EXPECT_FALSE(r.mass_matrix_active);
  EXPECT_EQ(r.iterations, 0);
}

/// An m x p design with orthonormal columns and y = X theta_hat + (part orthogonal to X): then
/// ||X theta - y||^2 = ||theta - theta_hat||^2 + const, the fit is the Euclidean projection of
/// theta_hat onto the feasible set, and theta_hat is the least-squares estimate.
struct OrthonormalDesign {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
};

OrthonormalDesign orthonormal_design(const Eigen::VectorXd& theta_hat, std::mt19937& rng) {
  const Eigen::Index m = 60, p = theta_hat.size();
  const Eigen::MatrixXd a = Eigen::MatrixXd::NullaryExpr(
      m, p, [&] { return std::normal_distribution<double>(0.0, 1.0)(rng); });
  OrthonormalDesign d;
  d.x = Eigen::HouseholderQR<Eigen::MatrixXd>(a).householderQ() * Eigen::MatrixXd::Identity(m, p);
  const Eigen::VectorXd e = gaussian(m, 0.1, rng);
  d.y = d.x * theta_hat + (e - d.x * (d.x.transpose() * e));
  return d;
}

TEST(NearestPhysical, OrthonormalDesignSetsNegativeViscousFrictionToZeroAndKeepsTheRest) {
  const auto model = arm();
  std::mt19937 rng(2);
  Eigen::VectorXd theta_hat = paper_theta();
  theta_hat(5) = -0.3;
  const OrthonormalDesign d = orthonormal_design(theta_hat, rng);

  const sid::ConsistentEstimate r = sid::nearest_physical(model, d.x, d.y);
  EXPECT_TRUE(r.changed);
  EXPECT_TRUE(r.converged);
  EXPECT_LT((r.theta_unconstrained - theta_hat).cwiseAbs().maxCoeff(), kParameterAbsTol);
  Eigen::VectorXd expected = theta_hat;
  expected(5) = 0.0;
  EXPECT_EQ(r.theta(5), 0.0);
  EXPECT_LT((r.theta - expected).cwiseAbs().maxCoeff(), kParameterAbsTol) << r.theta.transpose();
  EXPECT_NEAR(r.cost_increase, 0.09, 1e-8);
  EXPECT_NEAR(r.cost_increase, cost(d.x, d.y, r.theta) - cost(d.x, d.y, r.theta_unconstrained),
              1e-10);
  EXPECT_EQ(r.active_bounds, std::vector<std::string>{"theta6"});
  EXPECT_FALSE(r.mass_matrix_active);
  EXPECT_TRUE(sid::check_physical(model, r.theta).plausible());
}

TEST(NearestPhysical, OrthonormalDesignMatchesReducedProjectionOntoMassMatrixCone) {
  const auto model = arm();
  std::mt19937 rng(3);
  Eigen::VectorXd theta_hat = paper_theta();
  theta_hat(2) = 2.0 * std::sqrt(theta_hat(0) * theta_hat(1));
  const OrthonormalDesign d = orthonormal_design(theta_hat, rng);
  ASSERT_FALSE(sid::check_physical(model, theta_hat).mass_matrix_positive_definite);

  const sid::ConsistentEstimate r = sid::nearest_physical(model, d.x, d.y);
  const Eigen::VectorXd ref =
      reference_on_boundary(d.x, d.y, {}, Eigen::Vector2d(theta_hat(0), theta_hat(1)));
  EXPECT_TRUE(r.converged);
  EXPECT_TRUE(r.changed);
  EXPECT_LT((r.theta - ref).cwiseAbs().maxCoeff(), kParameterAbsTol)
      << "\n got " << r.theta.transpose() << "\n ref " << ref.transpose();
  // Only the inertia parameters move: the projection is Euclidean and the others are feasible.
  EXPECT_LT((r.theta.tail(4) - theta_hat.tail(4)).cwiseAbs().maxCoeff(), kParameterAbsTol);
  EXPECT_TRUE(r.mass_matrix_active);
  EXPECT_TRUE(r.active_bounds.empty());
  EXPECT_LT(std::abs(std::sin(r.min_eigenvalue_q2)), 1.01 * kGridStep);
  EXPECT_GE(r.min_eigenvalue, r.margin_absolute);
  EXPECT_TRUE(sid::check_physical(model, r.theta).plausible());
  EXPECT_NEAR(r.cost_increase, (ref - theta_hat).squaredNorm(),
              1e-6 * (ref - theta_hat).squaredNorm());
}

TEST(NearestPhysical, RealisticDesignMatchesReducedReferenceAndIsFirstOrderOptimal) {
  const auto model = arm();
  std::mt19937 rng(4);
  const Eigen::MatrixXd x = random_regressor(model, 300, rng);
  Eigen::VectorXd theta_bad = paper_theta();
  theta_bad(2) = 1.6 * std::sqrt(theta_bad(0) * theta_bad(1));
  theta_bad(6) = -0.05;
  const Eigen::VectorXd y = x * theta_bad + gaussian(x.rows(), 0.02, rng);
  const Eigen::VectorXd ls = x.colPivHouseholderQr().solve(y);
  ASSERT_FALSE(sid::check_physical(model, ls).plausible());

  const sid::ConsistentEstimate r = sid::nearest_physical(model, x, y);
  EXPECT_TRUE(r.changed);
  EXPECT_TRUE(r.converged);
  EXPECT_LT((r.theta_unconstrained - ls).cwiseAbs().maxCoeff(), kParameterAbsTol);
  EXPECT_TRUE(sid::check_physical(model, r.theta).plausible());
  EXPECT_GE(r.min_eigenvalue, r.margin_absolute);
  EXPECT_EQ(r.theta(6), 0.0);
  EXPECT_EQ(r.active_bounds, std::vector<std::string>{"theta7"});
  EXPECT_TRUE(r.mass_matrix_active);
  const double direct = cost(x, y, r.theta) - cost(x, y, ls);
  EXPECT_GT(r.cost_increase, 0.0);
  EXPECT_NEAR(r.cost_increase, direct, 1e-6 * direct);

  // Reference: theta7 = 0 and theta3 = sqrt(theta1 theta2) imposed, the rest free. It lies on
  // the boundary itself, so the solver runs without margin here (its default margin, 1e-9 of
  // D's scale, costs ~1e-8 of the cost on this data).
  const Eigen::VectorXd ref = reference_on_boundary(x, y, {6}, Eigen::Vector2d(ls(0), ls(1)));
  ASSERT_TRUE(sid::check_physical(model, ref).negative_parameters.empty());
  sid::NearestPhysicalOptions no_margin;
  no_margin.margin = 0.0;
  const sid::ConsistentEstimate r0 = sid::nearest_physical(model, x, y, {}, no_margin);
  EXPECT_TRUE(r0.converged);
  EXPECT_LT((r0.theta - ref).cwiseAbs().maxCoeff(), kParameterAbsTol)
      << "\n got " << r0.theta.transpose() << "\n ref " << ref.transpose();
  EXPECT_LT((r.theta - ref).cwiseAbs().maxCoeff(), kParameterAbsTol)
      << "\n got " << r.theta.transpose() << "\n ref " << ref.transpose();
  const double ref_increase = cost(x, y, ref) - cost(x, y, ls);
  EXPECT_NEAR(r0.cost_increase, ref_increase, 1e-9 * ref_increase);

  expect_first_order_optimal(model, x, y, r.theta, {"theta4", "theta5", "theta6", "theta7"},
                             r.margin_absolute, rng);
}

TEST(NearestPhysical, BoundsCoulombAndArmatureButNotTorqueOffset) {
  auto model = arm();
  model.add(sid::effect_term("coulomb_j1"));
  model.add(sid::effect_term("armature_j2"));
  model.add(sid::effect_term("torque_offset_j1"));
  const Eigen::Index fc = index_of(model, "coulomb_j1.Fc"), ia = index_of(model, "armature_j2.Ia"),
                     b = index_of(model, "torque_offset_j1.b");
  std::mt19937 rng(5);
  const Eigen::MatrixXd x = random_regressor(model, 300, rng);
  Eigen::VectorXd theta_true(model.num_parameters());
  theta_true << paper_theta(), -0.2, -0.001, -0.1;  // Fc < 0 and Ia < 0 unphysical, b free
  const Eigen::VectorXd y = x * theta_true + gaussian(x.rows(), 0.01, rng);

  const sid::ConsistentEstimate r = sid::nearest_physical(model, x, y);
  EXPECT_LT(r.theta_unconstrained(fc), 0.0);
  EXPECT_LT(r.theta_unconstrained(ia), 0.0);
  EXPECT_TRUE(r.converged);
  EXPECT_GE(r.theta(fc), 0.0);
  EXPECT_GE(r.theta(ia), 0.0);
  EXPECT_EQ(r.theta(fc), 0.0);
  EXPECT_EQ(r.active_bounds, (std::vector<std::string>{"coulomb_j1.Fc", "armature_j2.Ia"}));
  EXPECT_LT(r.theta(b), -0.05) << "the torque offset is not bounded";
  EXPECT_TRUE(sid::check_physical(model, r.theta).plausible());
  expect_first_order_optimal(model, x, y, r.theta,
                             *sid::default_physical_constraints(model).nonnegative,
                             r.margin_absolute, rng);
}

TEST(NearestPhysical, ThrowsWhenNoStrictlyFeasiblePointExists) {
  std::mt19937 rng(6);
  // D = diag(0, Ia): singular for every parameter value.
  sid::Model<double> singular;
  singular.add(sid::viscous_friction_term<double>());
  singular.add(sid::effect_term("armature_j2"));
  const Eigen::MatrixXd xs = random_regressor(singular, 50, rng);
  const Eigen::VectorXd ys = gaussian(xs.rows(), 1.0, rng);
  try {
    (void)sid::nearest_physical(singular, xs, ys);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("strictly feasible"), std::string::npos) << e.what();
  }
  // No inertia at all.
  sid::Model<double> friction_only;
  friction_only.add(sid::viscous_friction_term<double>());
  const Eigen::MatrixXd xf = random_regressor(friction_only, 50, rng);
  expect_invalid_argument([&] { (void)sid::nearest_physical(friction_only, xf, ys); },
                          "sid::nearest_physical: ");
}

TEST(NearestPhysical, RejectsBadInput) {
  const auto model = arm();
  std::mt19937 rng(7);
  const Eigen::MatrixXd x = random_regressor(model, 50, rng);
  const Eigen::VectorXd y = x * paper_theta();
  const std::string prefix = "sid::nearest_physical: ";
  expect_invalid_argument([&] { (void)sid::nearest_physical(model, x.leftCols(6), y); }, prefix);
  expect_invalid_argument([&] { (void)sid::nearest_physical(model, x, y.head(99)); }, prefix);
  expect_invalid_argument([&] { (void)sid::nearest_physical(model, x.topRows(7), y.head(7)); },
                          prefix);
  Eigen::VectorXd y_nan = y;
  y_nan(3) = std::numeric_limits<double>::quiet_NaN();
  expect_invalid_argument([&] { (void)sid::nearest_physical(model, x, y_nan); }, prefix);
  Eigen::MatrixXd x_inf = x;
  x_inf(5, 2) = std::numeric_limits<double>::infinity();
  expect_invalid_argument([&] { (void)sid::nearest_physical(model, x_inf, y); }, prefix);
  Eigen::MatrixXd x_rank = x;
  x_rank.col(6) = 2.0 * x.col(5);
  expect_invalid_argument([&] { (void)sid::nearest_physical(model, x_rank, y); }, prefix);
  sid::PhysicalConstraints c;
  c.grid_size = 0;
  expect_invalid_argument([&] { (void)sid::nearest_physical(model, x, y, c); }, prefix);
  sid::NearestPhysicalOptions options;
  options.tolerance = 0.0;
  expect_invalid_argument([&] { (void)sid::nearest_physical(model, x, y, {}, options); }, prefix);
  options = {};
  options.margin = -1.0;
  expect_invalid_argument([&] { (void)sid::nearest_physical(model, x, y, {}, options); }, prefix);
}
