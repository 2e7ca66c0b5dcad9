// Tests of sid/base_parameters.hpp: which columns of a regressor are base parameters and how the
// others regroup onto them.

#include <sid/base_parameters.hpp>

#include <gtest/gtest.h>

#include <stdexcept>

namespace {

using Eigen::MatrixXd;

TEST(BaseParametersInOrder, KeepsEarlierColumnsAndRegroupsExactly) {
  MatrixXd w(4, 4);
  w << 1, 0, 2, 1,  //
      0, 1, 0, 1,   //
      0, 0, 0, 0,   //
      1, 1, 2, 2;
  // Column 2 is twice column 0 and column 3 the sum of columns 0 and 1: the earlier ones stay.
  const auto base = sid::base_parameters_in_order(w, 1e-8);
  ASSERT_EQ(base.independent, (std::vector<Eigen::Index>{0, 1}));
  ASSERT_EQ(base.dependent, (std::vector<Eigen::Index>{2, 3}));
  EXPECT_LT((w(Eigen::all, base.independent) * base.K - w(Eigen::all, base.dependent)).norm(),
            1e-14);
}

// Each kept column is farther than the tolerance from the span of those before it, yet a
// pivoted QR of the kept columns may put its last pivot below the tolerance (by up to √2
// among three): they are independent, and the regrouping must go through.
TEST(BaseParametersInOrder, RegroupsOntoColumnsJustAboveTheToleranceInAnyPivotOrder) {
  const double tolerance = 1e-3, delta = 1.2e-3;
  MatrixXd w(3, 4);
  w.col(0) << 1, 0, 0;
  w.col(1) << 1, delta, 0;
  w.col(2) << 1, delta, delta;
  w.col(3) = w.col(0) + 2.0 * w.col(2);
  const auto base = sid::base_parameters_in_order(w, tolerance);
  ASSERT_EQ(base.independent, (std::vector<Eigen::Index>{0, 1, 2}));
  ASSERT_EQ(base.dependent, (std::vector<Eigen::Index>{3}));
  EXPECT_NEAR(base.K(0, 0), 1.0, 1e-9);
  EXPECT_NEAR(base.K(1, 0), 0.0, 1e-9);
  EXPECT_NEAR(base.K(2, 0), 2.0, 1e-9);
}

TEST(BaseParameters, RefusesGivenColumnsThatAreDependent) {
  MatrixXd w(3, 3);
  w << 1, 2, 0,  //
      0, 0, 1,   //
      1, 2, 1;
  EXPECT_THROW(sid::base_parameters(w, std::vector<Eigen::Index>{0, 1}), std::invalid_argument);
  EXPECT_NO_THROW(sid::base_parameters(w, std::vector<Eigen::Index>{0, 2}));
  EXPECT_THROW(sid::base_parameters_in_order(MatrixXd::Zero(3, 2)), std::invalid_argument);
}

}  // namespace
