#pragma once
// Test-only helpers for the six-joint reference arms in tests/data/ndof/.

#include <sid/model/chain_regressor.hpp>
#include <sid/model/serial_chain.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace sid_test {

// Both sides evaluate the same recursion in double: differences are round-off, ~1e-14.
constexpr double kChainRegressorTol = 1e-10;  // absolute, entries of Y

/// Row `row` of the columns stem1..stem6.
inline Eigen::VectorXd joints_of(const Table& table, Eigen::Index row, const std::string& stem) {
  Eigen::VectorXd v(6);
  for (int j = 0; j < 6; ++j) v[j] = table.data(row, table.column(stem + std::to_string(j + 1)));
  return v;
}

/// The chain's regressor against Pinocchio's on the 120 rows of ndof/regressor_<arm>.csv.
inline void expect_reference_regressor(const sid::SerialChain<double>& chain,
                                       const std::string& arm) {
  const Table table = read_table("ndof/regressor_" + arm + ".csv");
  const std::vector<std::string> names = sid::chain_parameter_names(6);
  ASSERT_EQ(static_cast<Eigen::Index>(names.size()), sid::chain_parameter_count(6));
  Eigen::MatrixXd y(6, sid::chain_parameter_count(6));
  for (Eigen::Index row = 0; row < table.data.rows(); ++row) {
    sid::chain_regressor(chain, joints_of(table, row, "q"), joints_of(table, row, "qd"),
                         joints_of(table, row, "qdd"), y);
    const auto joint = static_cast<Eigen::Index>(table.data(row, table.column("joint"))) - 1;
    for (std::size_t c = 0; c < names.size(); ++c)
      ASSERT_NEAR(y(joint, static_cast<Eigen::Index>(c)), table.data(row, table.column(names[c])),
                  kChainRegressorTol)
          << "sample " << table.data(row, 0) << ", joint " << joint + 1 << ", " << names[c];
  }
}

}  // namespace sid_test
