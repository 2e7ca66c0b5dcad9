// Tests of include/sid/butterworth.hpp against SciPy (tests/data/butter_reference.csv and
// filtfilt_reference.csv, made by gen_signal_reference.py).

#include <sid/butterworth.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <limits>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace {

// SciPy and sid run the same algorithm in the same floating-point order, so the coefficients
// differ by a few roundings only.
constexpr double kCoefficientRelTol = 1e-12;
// filtfilt/lfilter: max error relative to the largest reference value of the column.
constexpr double kSignalRelTol = 1e-12;
// A coefficient rounded to double moves sum(a) by up to eps |a_i|; sum(a) is small (the poles
// crowd z = 1), so the DC gain of the stored coefficients is 1 only to about
// eps * sum|a| / |sum a| (1.6e7 eps for butter(4, 0.01), in SciPy's coefficients as in ours).
constexpr double kDcGainRoundings = 4.0;
// An LU solve (SciPy's lfilter_zi) is backward stable: forward error <~ n eps cond.
constexpr double kLuRoundings = 10.0;
constexpr double kEps = std::numeric_limits<double>::epsilon();

struct PaperFilter {
  std::string name;
  int order;
  double cutoff;
};

const std::vector<PaperFilter>& paper_filters() {
  static const std::vector<PaperFilter> filters = {
      {"q", 3, 0.05}, {"qd", 3, 0.015}, {"qdd", 4, 0.01}};
  return filters;
}

// Rows of butter_reference.csv for one filter: columns b, a, zi (zi has order entries).
struct Reference {
  Eigen::VectorXd b, a, zi, zi_scipy;
};

Reference scipy_reference(const PaperFilter& f) {
  const auto table = sid_test::read_table("butter_reference.csv");
  Reference ref;
  std::vector<double> b, a, zi, zi_scipy;
  for (Eigen::Index i = 0; i < table.data.rows(); ++i) {
    if (table.data(i, table.column("order")) != f.order ||
        table.data(i, table.column("wn")) != f.cutoff)
      continue;
    b.push_back(table.data(i, table.column("b")));
    a.push_back(table.data(i, table.column("a")));
    if (static_cast<int>(zi.size()) < f.order) {
      zi.push_back(table.data(i, table.column("zi")));
      zi_scipy.push_back(table.data(i, table.column("zi_scipy")));
    }
  }
  ref.b = Eigen::Map<Eigen::VectorXd>(b.data(), static_cast<Eigen::Index>(b.size()));
  ref.a = Eigen::Map<Eigen::VectorXd>(a.data(), static_cast<Eigen::Index>(a.size()));
  ref.zi = Eigen::Map<Eigen::VectorXd>(zi.data(), static_cast<Eigen::Index>(zi.size()));
  ref.zi_scipy =
      Eigen::Map<Eigen::VectorXd>(zi_scipy.data(), static_cast<Eigen::Index>(zi_scipy.size()));
  return ref;
}

double max_rel_error(const Eigen::VectorXd& actual, const Eigen::VectorXd& expected) {
  return (actual - expected).cwiseAbs().maxCoeff() / expected.cwiseAbs().maxCoeff();
}

// I - companion(a)^T, the matrix of lfilter_zi's system.
Eigen::MatrixXd zi_system(const Eigen::VectorXd& a) {
  const Eigen::Index n = a.size() - 1;
  Eigen::MatrixXd m = Eigen::MatrixXd::Identity(n, n);
  m.col(0) += a.tail(n);
  m.topRightCorner(n - 1, n - 1).diagonal().array() -= 1.0;
  return m;
}

double condition_number(const Eigen::MatrixXd& m) {
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(m);
  return svd.singularValues()(0) / svd.singularValues()(m.cols() - 1);
}

Eigen::MatrixXd signal_pair(const sid_test::Table& table) {
  Eigen::MatrixXd x(table.data.rows(), 2);
  x << table.col("x1"), table.col("x2");
  return x;
}

}  // namespace

TEST(Butterworth, CoefficientsMatchScipyButter) {
  for (const auto& f : paper_filters()) {
    const auto ref = scipy_reference(f);
    ASSERT_EQ(ref.b.size(), f.order + 1);
    const auto tf = sid::butterworth_lowpass(f.order, f.cutoff);
    ASSERT_EQ(tf.b.size(), f.order + 1);
    ASSERT_EQ(tf.a.size(), f.order + 1);
    EXPECT_EQ(tf.a(0), 1.0);
    for (Eigen::Index i = 0; i <= f.order; ++i) {
      EXPECT_NEAR(tf.b(i), ref.b(i), kCoefficientRelTol * std::abs(ref.b(i)))
          << f.name << " b[" << i << "]";
      EXPECT_NEAR(tf.a(i), ref.a(i), kCoefficientRelTol * std::abs(ref.a(i)))
          << f.name << " a[" << i << "]";
    }
  }
}

TEST(Butterworth, DcGainIsOneUpToCoefficientRounding) {
  for (const auto& f : paper_filters()) {
    const auto tf = sid::butterworth_lowpass(f.order, f.cutoff);
    // Sums of these few doubles are exact in long double (their bits span < 64 binary digits),
    // so this is the DC gain of the stored coefficients, not of a rounded sum.
    long double sum_b = 0, sum_a = 0;
    for (Eigen::Index i = 0; i <= f.order; ++i) {
      sum_b += tf.b(i);
      sum_a += tf.a(i);
    }
    const double gain = static_cast<double>(sum_b / sum_a);
    const double tol =
        kDcGainRoundings * kEps * tf.a.cwiseAbs().sum() / std::abs(static_cast<double>(sum_a));
    EXPECT_NEAR(gain, 1.0, tol) << f.name;
  }
}

TEST(Butterworth, GainAtCutoffIsHalfPower) {
  // |H(exp(i pi Wn))|^2 = 1/2 defines the Butterworth cutoff; checks the prewarping.
  constexpr double kHalfPowerTol = 1e-9;
  for (const auto& f : paper_filters()) {
    const auto tf = sid::butterworth_lowpass(f.order, f.cutoff);
    const std::complex<double> z_inv = std::exp(std::complex<double>(0.0, -EIGEN_PI * f.cutoff));
    std::complex<double> num(0), den(0), power(1);
    for (Eigen::Index i = 0; i < tf.b.size(); ++i, power *= z_inv) {
      num += tf.b(i) * power;
      den += tf.a(i) * power;
    }
    EXPECT_NEAR(std::norm(num / den), 0.5, kHalfPowerTol) << f.name;
  }
}

TEST(Butterworth, PolesLieInsideUnitCircle) {
  for (const auto& f : paper_filters()) {
    const auto tf = sid::butterworth_lowpass(f.order, f.cutoff);
    // Poles are the eigenvalues of the companion matrix of a.
    Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(f.order, f.order);
    companion.row(0) = -tf.a.tail(f.order).transpose();
    companion.bottomLeftCorner(f.order - 1, f.order - 1).setIdentity();
    const Eigen::VectorXcd poles = companion.eigenvalues();
    for (Eigen::Index k = 0; k < poles.size(); ++k) EXPECT_LT(std::abs(poles(k)), 1.0) << f.name;
  }
}

TEST(Butterworth, LfilterZiMatchesExactSolution) {
  for (const auto& f : paper_filters()) {
    const auto ref = scipy_reference(f);
    const Eigen::VectorXd zi = sid::lfilter_zi(ref.b, ref.a);
    ASSERT_EQ(zi.size(), f.order);
    EXPECT_LT(max_rel_error(zi, ref.zi), kSignalRelTol) << f.name;
  }
}

TEST(Butterworth, LfilterZiAgreesWithScipyWithinItsConditioning) {
  for (const auto& f : paper_filters()) {
    const auto ref = scipy_reference(f);
    const Eigen::VectorXd zi = sid::lfilter_zi(ref.b, ref.a);
    const double tol = kLuRoundings * kEps * condition_number(zi_system(ref.a));
    EXPECT_LT(max_rel_error(zi, ref.zi_scipy), tol) << f.name;
  }
}

TEST(Butterworth, LfilterZiAcceptsUnnormalizedAndShorterNumerator) {
  // b of length 2, a scaled by 2: same zi as b padded with zeros and a normalised (SciPy rule).
  const Eigen::Vector2d b(0.5, 0.25);
  const Eigen::Vector3d a(2.0, -1.0, 0.3);
  const Eigen::VectorXd zi = sid::lfilter_zi(b, a);
  // (I - A^T) zi = b[1:] - a[1:] b[0] with b = (0.25, 0.125, 0), a = (1, -0.5, 0.15).
  Eigen::Matrix2d m;
  m << 1.0 - 0.5, -1.0, 0.15, 1.0;
  const Eigen::Vector2d rhs(0.125 + 0.5 * 0.25, -0.15 * 0.25);
  EXPECT_LT((zi - m.fullPivLu().solve(rhs)).cwiseAbs().maxCoeff(), kSignalRelTol);
}

TEST(Butterworth, LfilterZiIsSteadyStateOfUnitStep) {
  // Property, independent of SciPy: starting from zi, a constant input 1 gives the constant
  // output b.sum()/a.sum() and leaves the state unchanged.
  constexpr double kSteadyTol = 1e-12;
  const auto tf = sid::butterworth_lowpass(3, 0.05);
  const Eigen::VectorXd zi = sid::lfilter_zi(tf.b, tf.a);
  const auto out = sid::lfilter(tf.b, tf.a, Eigen::VectorXd::Ones(50), zi);
  const double gain = tf.b.sum() / tf.a.sum();
  EXPECT_LT((out.y.array() - gain).abs().maxCoeff(), kSteadyTol);
  EXPECT_LT((out.zf - zi).cwiseAbs().maxCoeff(), kSteadyTol);
}

TEST(Butterworth, LfilterMatchesScipyColumnwise) {
  const auto table = sid_test::read_table("filtfilt_reference.csv");
  const Eigen::MatrixXd x = signal_pair(table);
  for (const auto& f : paper_filters()) {
    const auto ref = scipy_reference(f);
    const Eigen::MatrixXd y = sid::lfilter(ref.b, ref.a, x);
    ASSERT_EQ(y.rows(), x.rows());
    ASSERT_EQ(y.cols(), 2);
    EXPECT_LT(max_rel_error(y.col(0), table.col("lfilter_" + f.name + "1")), kSignalRelTol)
        << f.name;
    EXPECT_LT(max_rel_error(y.col(1), table.col("lfilter_" + f.name + "2")), kSignalRelTol)
        << f.name;
  }
}

TEST(Butterworth, LfilterWithStateContinuesWhereItStopped) {
  // Filtering in two pieces, passing zf on as zi, equals filtering in one piece.
  constexpr double kSplitTol = 1e-14;
  const auto table = sid_test::read_table("filtfilt_reference.csv");
  const Eigen::MatrixXd x = signal_pair(table);
  const auto tf = sid::butterworth_lowpass(4, 0.01);
  const Eigen::MatrixXd whole = sid::lfilter(tf.b, tf.a, x);
  const auto head = sid::lfilter(tf.b, tf.a, x.topRows(80), Eigen::MatrixXd::Zero(4, 2));
  const auto tail = sid::lfilter(tf.b, tf.a, x.bottomRows(120), head.zf);
  EXPECT_LT((head.y - whole.topRows(80)).cwiseAbs().maxCoeff(), kSplitTol);
  EXPECT_LT((tail.y - whole.bottomRows(120)).cwiseAbs().maxCoeff(), kSplitTol);
}

TEST(Butterworth, FiltfiltMatchesScipyAlgorithmColumnwise) {
  // Reference: SciPy's filtfilt steps run by SciPy's lfilter from the exact zi (the generator
  // checks that the same steps with SciPy's zi give scipy.signal.filtfilt bit for bit).
  // Filters with SciPy's coefficients: the output of butter(4, 0.01) moves by ~1e-10 when its
  // coefficients move by one ulp (its DC gain is 1 only to eps sum|a| / |sum a| = 1.6e7 eps),
  // so the design is tested separately (CoefficientsMatchScipyButter: 1-2 ulps).
  const auto table = sid_test::read_table("filtfilt_reference.csv");
  const Eigen::MatrixXd x = signal_pair(table);
  for (const auto& f : paper_filters()) {
    const auto ref = scipy_reference(f);
    const Eigen::MatrixXd y = sid::filtfilt(ref.b, ref.a, x);
    ASSERT_EQ(y.rows(), x.rows());
    ASSERT_EQ(y.cols(), 2);
    EXPECT_LT(max_rel_error(y.col(0), table.col("filtfilt_exactzi_" + f.name + "1")), kSignalRelTol)
        << f.name;
    EXPECT_LT(max_rel_error(y.col(1), table.col("filtfilt_exactzi_" + f.name + "2")), kSignalRelTol)
        << f.name;
  }
}

TEST(Butterworth, FiltfiltMatchesScipyFiltfiltWhereScipyZiIsAccurate) {
  // For butter(3, 0.05) SciPy's own zi is exact to 2e-15, so scipy.signal.filtfilt itself is a
  // 1e-12 reference; for the other two its zi error (7e-13, 3.5e-10) dominates the comparison.
  const auto table = sid_test::read_table("filtfilt_reference.csv");
  const Eigen::MatrixXd x = signal_pair(table);
  const auto ref = scipy_reference(paper_filters()[0]);
  const Eigen::MatrixXd y = sid::filtfilt(ref.b, ref.a, x);
  EXPECT_LT(max_rel_error(y.col(0), table.col("filtfilt_q1")), kSignalRelTol);
  EXPECT_LT(max_rel_error(y.col(1), table.col("filtfilt_q2")), kSignalRelTol);
}

TEST(Butterworth, FiltfiltKeepsConstantsWithoutEdgeTransient) {
  // Odd extension of a constant is the constant, and the steady-state starts make both passes
  // stay on it; a zero-state start would ramp up over ~1/Wn samples. The recursion's own
  // rounding reaches the output through 1/A(z), whose DC gain sum|a| / |sum a| bounds it.
  const Eigen::VectorXd x = Eigen::VectorXd::Constant(100, 2.5);
  for (const auto& f : paper_filters()) {
    const auto tf = sid::butterworth_lowpass(f.order, f.cutoff);
    // DC gain of the stored coefficients (long double sums are exact here, see above).
    long double sum_b = 0, sum_a = 0;
    for (Eigen::Index i = 0; i <= f.order; ++i) {
      sum_b += tf.b(i);
      sum_a += tf.a(i);
    }
    const double gain2 = std::pow(static_cast<double>(sum_b / sum_a), 2);
    const Eigen::MatrixXd y = sid::filtfilt(tf.b, tf.a, x);
    const double tol =
        kDcGainRoundings * kEps * tf.a.cwiseAbs().sum() / std::abs(static_cast<double>(sum_a));
    EXPECT_LT((y.col(0).array() - 2.5 * gain2).abs().maxCoeff(), tol * 2.5) << f.name;
  }
}

TEST(Butterworth, FiltfiltAcceptsFixedTwoColumnMatrices) {
  const auto table = sid_test::read_table("filtfilt_reference.csv");
  const Eigen::Matrix<double, Eigen::Dynamic, 2> x = signal_pair(table);
  const auto ref = scipy_reference(paper_filters()[1]);
  const sid::TransferFunction<double> tf{ref.b, ref.a};
  const Eigen::MatrixXd y = sid::filtfilt(tf, x);
  EXPECT_LT(max_rel_error(y.col(1), table.col("filtfilt_exactzi_qd2")), kSignalRelTol);
}

TEST(Butterworth, WorksInFloat) {
  constexpr double kFloatTol = 1e-5;
  const auto tf = sid::butterworth_lowpass(3, 0.05f);
  const auto tf_double = sid::butterworth_lowpass(3, 0.05);
  EXPECT_LT((tf.a.cast<double>() - tf_double.a).cwiseAbs().maxCoeff(), kFloatTol);
  const Eigen::VectorXf x = Eigen::VectorXf::LinSpaced(40, 0.0f, 1.0f);
  const Eigen::MatrixXf y = sid::filtfilt(tf, x);
  EXPECT_EQ(y.rows(), 40);
}

TEST(Butterworth, ThrowsOnBadDesignInput) {
  EXPECT_THROW((void)sid::butterworth_lowpass(0, 0.1), std::invalid_argument);
  EXPECT_THROW((void)sid::butterworth_lowpass(3, 0.0), std::invalid_argument);
  EXPECT_THROW((void)sid::butterworth_lowpass(3, 1.0), std::invalid_argument);
  try {
    (void)sid::butterworth_lowpass(3, 1.5);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "sid::butterworth_lowpass: cutoff must be in (0, 1), got 1.5");
  }
}

TEST(Butterworth, FiltfiltThrowsWhenSignalNotLongerThanPadlen) {
  const auto tf = sid::butterworth_lowpass(3, 0.05);  // padlen = 3 * 4 = 12, as SciPy
  EXPECT_THROW((void)sid::filtfilt(tf, Eigen::VectorXd::Ones(12)), std::invalid_argument);
  EXPECT_NO_THROW((void)sid::filtfilt(tf, Eigen::VectorXd::Ones(13)));
}

TEST(Butterworth, ThrowsOnBadFilterInput) {
  const auto tf = sid::butterworth_lowpass(3, 0.05);
  Eigen::VectorXd x = Eigen::VectorXd::Ones(30);
  Eigen::VectorXd a_zero = tf.a;
  a_zero(0) = 0.0;
  EXPECT_THROW((void)sid::lfilter(tf.b, a_zero, x), std::invalid_argument);
  EXPECT_THROW((void)sid::lfilter_zi(Eigen::VectorXd(), tf.a), std::invalid_argument);
  EXPECT_THROW((void)sid::lfilter(tf.b, tf.a, x, Eigen::MatrixXd::Zero(2, 1)),
               std::invalid_argument);
  x(4) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW((void)sid::filtfilt(tf, x), std::invalid_argument);
  EXPECT_THROW((void)sid::lfilter(tf.b, tf.a, x), std::invalid_argument);
}
