#pragma once
/// @file
/// @brief Stacking the regressor over a trajectory (paper eq. 10): X (2n x p) holds ALL of joint
/// 1's rows first, then joint 2's; y (2n) holds tau1 then tau2. Row i of X is joint 1 at sample i,
/// row n + i joint 2 at sample i.

#include <sid/detail/sincos.hpp>
#include <sid/model/model.hpp>
#include <sid/model/terms.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <type_traits>
#include <string>

namespace sid {

namespace detail {

template <typename Scalar>
using ConstSamplesRef = Eigen::Ref<const MatrixX2<NoDeduce<Scalar>>>;
template <typename Scalar>
using StackedMatrixRef =
    Eigen::Ref<Eigen::Matrix<NoDeduce<Scalar>, Eigen::Dynamic, Eigen::Dynamic>>;
template <typename Scalar>
using StackedVectorRef = Eigen::Ref<VectorX<NoDeduce<Scalar>>>;

template <typename Scalar>
void check_samples(const char* who, const ConstSamplesRef<Scalar>& q,
                   const ConstSamplesRef<Scalar>& qd, const ConstSamplesRef<Scalar>& qdd) {
  if (qd.rows() != q.rows())
    throw std::invalid_argument(std::string(who) + ": q has " + std::to_string(q.rows()) +
                                " rows but qd has " + std::to_string(qd.rows()));
  if (qdd.rows() != q.rows())
    throw std::invalid_argument(std::string(who) + ": q has " + std::to_string(q.rows()) +
                                " rows but qdd has " + std::to_string(qdd.rows()));
}

template <typename Scalar>
void check_stacked(const char* who, Eigen::Index n, Eigen::Index p, Eigen::Index rows,
                   Eigen::Index cols) {
  if (rows != 2 * n || cols != p)
    throw std::invalid_argument(std::string(who) + ": X is " + std::to_string(rows) + " x " +
                                std::to_string(cols) + " but must be " + std::to_string(2 * n) +
                                " x " + std::to_string(p) + " (2n x p)");
}

/// sin and cos of n angles: vectorized when all are moderate and finite, std otherwise.
inline void sincos_chunk(const double* x, double* s, double* c, long n) noexcept {
  bool moderate = true;
  for (long i = 0; i < n; ++i) moderate &= std::fabs(x[i]) <= kFastSinCosLimit;
  if (moderate) return sincos_batch(x, s, c, n);
  for (long i = 0; i < n; ++i) {
    s[i] = std::sin(x[i]);
    c[i] = std::cos(x[i]);
  }
}

/// The double fast path of stack_two_link_regressor: trigonometry for a chunk of samples in one
/// vectorized pass, then straight column-wise stores (one stream per column of X).
inline void stack_two_link_regressor_double(const ConstSamplesRef<double>& q,
                                            const ConstSamplesRef<double>& qd,
                                            const ConstSamplesRef<double>& qdd, double g,
                                            Eigen::Ref<Eigen::MatrixXd>& X) noexcept {
  constexpr long kChunk = 256;
  double s1[kChunk], c1[kChunk], s2[kChunk], c2[kChunk];
  const long n = q.rows(), ld = X.outerStride();
  double* const top = X.data();
  double* const bottom = X.data() + n;
  for (long i0 = 0; i0 < n; i0 += kChunk) {
    const long m = std::min(kChunk, n - i0);
    const double* q1 = q.col(0).data() + i0;
    const double* q2 = q.col(1).data() + i0;
    const double* qd1 = qd.col(0).data() + i0;
    const double* qd2 = qd.col(1).data() + i0;
    const double* qdd1 = qdd.col(0).data() + i0;
    const double* qdd2 = qdd.col(1).data() + i0;
    sincos_chunk(q1, s1, c1, m);
    sincos_chunk(q2, s2, c2, m);
    double* t = top + i0;
    double* b = bottom + i0;
    for (long j = 0; j < m; ++j) {
      const double gs12 = g * (s1[j] * c2[j] + c1[j] * s2[j]);
      t[j] = qdd1[j];
      b[j] = 0.0;
      t[j + ld] = qdd1[j] + qdd2[j];
      b[j + ld] = qdd1[j] + qdd2[j];
      t[j + 2 * ld] = c2[j] * (2.0 * qdd1[j] + qdd2[j]) - s2[j] * (2.0 * qd1[j] + qd2[j]) * qd2[j];
      b[j + 2 * ld] = c2[j] * qdd1[j] + s2[j] * qd1[j] * qd1[j];
      t[j + 3 * ld] = g * s1[j];
      b[j + 3 * ld] = 0.0;
      t[j + 4 * ld] = gs12;
      b[j + 4 * ld] = gs12;
      t[j + 5 * ld] = qd1[j];
      b[j + 5 * ld] = 0.0;
      t[j + 6 * ld] = 0.0;
      b[j + 6 * ld] = qd2[j];
    }
  }
}

}  // namespace detail

/// @brief A stacked regression problem y = X theta + e (paper eq. 10).
template <typename Scalar>
struct StackedRegression {
  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> X;  ///< 2n x p
  VectorX<Scalar> y;                                        ///< 2n [N m]
};

/// @brief y = (tau1(0..n-1), tau2(0..n-1)) [N m] into caller storage of size 2n.
/// @throws std::invalid_argument if y.size() != 2 * tau.rows().
template <typename Scalar>
void stack_torque(const detail::ConstSamplesRef<Scalar>& tau, detail::StackedVectorRef<Scalar> y) {
  const Eigen::Index n = tau.rows();
  if (y.size() != 2 * n)
    throw std::invalid_argument("sid::stack_torque: y has " + std::to_string(y.size()) +
                                " entries but tau has " + std::to_string(n) +
                                " rows (need 2n = " + std::to_string(2 * n) + ")");
  y.head(n) = tau.col(0);
  y.tail(n) = tau.col(1);
}

/// @brief Stacks the generic model's regressor over n samples into caller storage X (2n x p):
/// each term writes straight into rows i and n + i, so there is no per-sample allocation.
/// @param q, qd, qdd n x 2 [rad, rad/s, rad/s^2].
/// @throws std::invalid_argument on row-count mismatch or wrongly sized X.
template <typename Scalar>
void stack_regressor(const Model<Scalar>& model, const detail::ConstSamplesRef<Scalar>& q,
                     const detail::ConstSamplesRef<Scalar>& qd,
                     const detail::ConstSamplesRef<Scalar>& qdd,
                     detail::StackedMatrixRef<Scalar> X) {
  detail::check_samples<Scalar>("sid::stack_regressor", q, qd, qdd);
  const Eigen::Index n = q.rows(), p = model.num_parameters();
  detail::check_stacked<Scalar>("sid::stack_regressor", n, p, X.rows(), X.cols());
  using RowPair = Eigen::Map<Eigen::Matrix<Scalar, 2, Eigen::Dynamic>, 0,
                             Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>>;
  for (Eigen::Index i = 0; i < n; ++i) {
    RowPair rows(X.data() + i, 2, p,
                 Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>(X.outerStride(), n));
    model.regressor(q.row(i).transpose(), qd.row(i).transpose(), qdd.row(i).transpose(), rows);
  }
}

/// @brief X and y for a whole Kinematics with the generic model (allocates X and y once).
template <typename Scalar>
StackedRegression<Scalar> stack_regression(const Model<Scalar>& model,
                                           const Kinematics<Scalar>& kinematics) {
  const Eigen::Index n = kinematics.q.rows();
  if (kinematics.tau.rows() != n)
    throw std::invalid_argument("sid::stack_regression: kinematics.q has " + std::to_string(n) +
                                " rows but kinematics.tau has " +
                                std::to_string(kinematics.tau.rows()));
  StackedRegression<Scalar> r;
  r.X.resize(2 * n, model.num_parameters());
  r.y.resize(2 * n);
  stack_regressor<Scalar>(model, kinematics.q, kinematics.qd, kinematics.qdd, r.X);
  stack_torque<Scalar>(kinematics.tau, r.y);
  return r;
}

/// @brief Fast path: the closed-form arm regressor stacked into caller storage X (2n x 7).
/// No allocation; two sincos evaluations per sample dominate the cost.
/// @param g gravity [m/s^2].
/// @throws std::invalid_argument on row-count mismatch or wrongly sized X.
template <typename Scalar>
void stack_two_link_regressor(const detail::ConstSamplesRef<Scalar>& q,
                              const detail::ConstSamplesRef<Scalar>& qd,
                              const detail::ConstSamplesRef<Scalar>& qdd,
                              detail::NoDeduce<Scalar> g, detail::StackedMatrixRef<Scalar> X) {
  detail::check_samples<Scalar>("sid::stack_two_link_regressor", q, qd, qdd);
  const Eigen::Index n = q.rows();
  detail::check_stacked<Scalar>("sid::stack_two_link_regressor", n, 7, X.rows(), X.cols());
  if constexpr (std::is_same_v<Scalar, double>) {
    detail::stack_two_link_regressor_double(q, qd, qdd, g, X);
    return;
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    const TwoLinkRegressor<Scalar> z = two_link_regressor<Scalar>(
        q.row(i).transpose(), qd.row(i).transpose(), qdd.row(i).transpose(), g);
    X.row(i) = z.row(0);
    X.row(n + i) = z.row(1);
  }
}

/// @brief X and y for a whole Kinematics with the closed-form arm regressor (allocates once).
template <typename Scalar>
StackedRegression<Scalar> stack_two_link_regression(
    const Kinematics<Scalar>& kinematics, detail::NoDeduce<Scalar> g = Scalar(kPaperGravity)) {
  const Eigen::Index n = kinematics.q.rows();
  if (kinematics.tau.rows() != n)
    throw std::invalid_argument("sid::stack_two_link_regression: kinematics.q has " +
                                std::to_string(n) + " rows but kinematics.tau has " +
                                std::to_string(kinematics.tau.rows()));
  StackedRegression<Scalar> r;
  r.X.resize(2 * n, 7);
  r.y.resize(2 * n);
  stack_two_link_regressor<Scalar>(kinematics.q, kinematics.qd, kinematics.qdd, g, r.X);
  stack_torque<Scalar>(kinematics.tau, r.y);
  return r;
}

}  // namespace sid
