#pragma once
/// @file
/// @brief The stacked regression of a chain on its kinematics: the rows a fit, its instruments
/// and its scoring share, so that they line up row by row.

#include <sid/base_parameters.hpp>
#include <sid/least_squares.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief Y_b and τ stacked joint by joint: row j·m + a is joint j at the a-th chosen sample.
struct ChainRegression {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
};

/// @brief The samples of a uniformly sampled record to take at about rate_hz: every
/// round(1 / (period · rate_hz))-th, from the first (all of them when the rate is above the
/// sampling rate).
inline std::vector<Eigen::Index> chain_regression_samples(
    const Eigen::Ref<const Eigen::VectorXd>& t, double rate_hz) {
  const Eigen::Index n = t.size();
  std::vector<Eigen::Index> samples;
  if (n == 0) return samples;
  const double period = n > 1 ? (t[n - 1] - t[0]) / static_cast<double>(n - 1) : 1.0;
  const auto stride =
      static_cast<Eigen::Index>(std::max(1.0, std::round(1.0 / (period * rate_hz))));
  for (Eigen::Index i = 0; i < n; i += stride) samples.push_back(i);
  return samples;
}

/// @brief The base regressor's columns `columns` and the torque of k at `samples`.
/// @throws std::invalid_argument if a sample or a column is out of range.
inline ChainRegression chain_regression(const ChainModel& model,
                                        const std::vector<Eigen::Index>& columns,
                                        const ChainKinematics<double>& k,
                                        const std::vector<Eigen::Index>& samples) {
  const int joints = model.joints();
  for (Eigen::Index i : samples)
    if (i < 0 || i >= k.size())
      throw std::invalid_argument("sid::chain_regression: sample " + std::to_string(i) +
                                  " is outside the kinematics' " + std::to_string(k.size()));
  for (Eigen::Index c : columns)
    if (c < 0 || c >= model.parameters())
      throw std::invalid_argument("sid::chain_regression: column " + std::to_string(c) +
                                  " is outside the model's " + std::to_string(model.parameters()) +
                                  " parameters");
  const auto m = static_cast<Eigen::Index>(samples.size());
  ChainRegression r{Eigen::MatrixXd(m * joints, static_cast<Eigen::Index>(columns.size())),
                    Eigen::VectorXd(m * joints)};
  Eigen::MatrixXd y(joints, model.parameters());
  Eigen::VectorXd q(joints), qd(joints), qdd(joints);
  for (Eigen::Index a = 0; a < m; ++a) {
    const Eigen::Index i = samples[static_cast<std::size_t>(a)];
    q = k.q.row(i).transpose();
    qd = k.qd.row(i).transpose();
    qdd = k.qdd.row(i).transpose();
    model.regressor(q, qd, qdd, y);
    for (int j = 0; j < joints; ++j) {
      r.x.row(j * m + a) = y.row(j)(columns);
      r.y[j * m + a] = k.tau(i, j);
    }
  }
  return r;
}

/// @brief Thrown by a refinement that judged its own estimate no better than the first fit
/// (an IV iteration that did not converge, weak instruments): the first fit stands, and what()
/// says why.
class RefinementDeclined : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// @brief A refinement of a chain's first fit, such as the IDIM-IV step of
/// sid/cvode/chain_instrumental_variables.hpp: (model, base parameters, windowed kinematics, the
/// samples of its rows, first fit) -> refined fit. The chain study takes it as a function so as
/// to stay free of SUNDIALS. It throws RefinementDeclined to keep the first fit, anything else
/// to fail a run.
using ChainEstimateRefinement = std::function<LeastSquaresResult<double>(
    const ChainModel&, const BaseParameters<double>&, const ChainKinematics<double>&,
    const std::vector<Eigen::Index>&, const LeastSquaresResult<double>&)>;

}  // namespace sid
