#pragma once
// Definitions of sid/arm.hpp (see sid/config.hpp).

#include <sid/arm.hpp>
#include <sid/chain_consistency.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/regressor.hpp>

#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>

namespace sid {

namespace detail {

// The key function: the compiled library emits the kernels' vtable once.
SID_INLINE ArmKernel::~ArmKernel() = default;

/// The paper's arm: the closed-form regressor of its seven parameters, which are their own base
/// set and a body as they are.
class PaperArmKernel final : public ArmKernel {
 public:
  explicit PaperArmKernel(double gravity) : gravity_(gravity) {}

  int joints() const override { return 2; }
  Eigen::Index parameters() const override { return 7; }

  ChainRegression regression(const ChainKinematics<double>& k,
                             const std::vector<Eigen::Index>& samples) const override {
    if (k.q.cols() != 2)
      throw std::invalid_argument(
          "sid::Arm::regression: the paper's arm has 2 joints, the "
          "kinematics " +
          std::to_string(k.q.cols()));
    const auto m = static_cast<Eigen::Index>(samples.size());
    Kinematics<double> at;
    at.t.resize(m);
    at.q.resize(m, 2);
    at.qd.resize(m, 2);
    at.qdd.resize(m, 2);
    at.tau.resize(m, 2);
    for (Eigen::Index a = 0; a < m; ++a) {
      const Eigen::Index i = samples[static_cast<std::size_t>(a)];
      at.t[a] = k.t[i];
      at.q.row(a) = k.q.row(i);
      at.qd.row(a) = k.qd.row(i);
      at.qdd.row(a) = k.qdd.row(i);
      at.tau.row(a) = k.tau.row(i);
    }
    StackedRegression<double> r = stack_two_link_regression(at, gravity_);
    return {std::move(r.X), std::move(r.y)};
  }

  Eigen::VectorXd simulatable(const LeastSquaresResult<double>& estimate, double,
                              const Eigen::VectorXd&,
                              const ChainConsistencyOptions&) const override {
    return estimate.theta;
  }

  Vector forward_dynamics(const Eigen::VectorXd& body, const Vector& q, const Vector& qd,
                          const Vector& tau) const override {
    const TwoLinkParameters<double> theta = body;
    return two_link_forward_dynamics(theta, Vector2<double>(q), Vector2<double>(qd),
                                     Vector2<double>(tau), gravity_);
  }

 private:
  double gravity_;
};

/// A serial chain: its base parameters are estimated, and simulated through the nearest
/// physically consistent links.
class ChainArmKernel final : public ArmKernel {
 public:
  ChainArmKernel(ChainModel model, BaseParameters<double> base)
      : model_(std::move(model)), base_(std::move(base)) {}

  int joints() const override { return model_.joints(); }
  Eigen::Index parameters() const override { return base_.rank(); }

  ChainRegression regression(const ChainKinematics<double>& k,
                             const std::vector<Eigen::Index>& samples) const override {
    return chain_regression(model_, base_.independent, k, samples);
  }

  Eigen::VectorXd simulatable(const LeastSquaresResult<double>& estimate, double relative_residual,
                              const Eigen::VectorXd& prior,
                              const ChainConsistencyOptions& consistency) const override {
    ChainIdentification identification;
    identification.base = base_;
    identification.fit = estimate;
    identification.fitted.relative_residual = relative_residual;
    return consistent_chain_parameters(model_, identification, prior, consistency).theta;
  }

  Vector forward_dynamics(const Eigen::VectorXd& body, const Vector& q, const Vector& qd,
                          const Vector& tau) const override {
    return model_.forward_dynamics(body, q, qd, tau);
  }

 private:
  ChainModel model_;
  BaseParameters<double> base_;
};

}  // namespace detail

SID_INLINE Arm paper_arm(double gravity) {
  return Arm(std::make_shared<const detail::PaperArmKernel>(gravity));
}

SID_INLINE Arm chain_arm(ChainModel model, BaseParameters<double> base) {
  if (static_cast<Eigen::Index>(base.independent.size() + base.dependent.size()) !=
      model.parameters())
    throw std::invalid_argument("sid::chain_arm: the base parameters are not the model's");
  return Arm(std::make_shared<const detail::ChainArmKernel>(std::move(model), std::move(base)));
}

SID_INLINE ChainRegression
stacked_regression(const Arm& arm, const std::vector<ChainKinematics<double>>& runs,
                   const std::vector<std::vector<Eigen::Index>>& samples) {
  if (runs.size() != samples.size())
    throw std::invalid_argument("sid::stacked_regression: " + std::to_string(runs.size()) +
                                " runs but " + std::to_string(samples.size()) + " sample lists");
  const int joints = arm.joints();
  std::vector<ChainRegression> parts;
  Eigen::Index rows = 0;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    parts.push_back(arm.regression(runs[r], samples[r]));
    rows += parts.back().y.size();
  }
  ChainRegression all{Eigen::MatrixXd(rows, arm.parameters()), Eigen::VectorXd(rows)};
  Eigen::Index at = 0;
  for (int j = 0; j < joints; ++j)
    for (const ChainRegression& part : parts) {
      const Eigen::Index m = part.y.size() / joints;
      all.x.middleRows(at, m) = part.x.middleRows(j * m, m);
      all.y.segment(at, m) = part.y.segment(j * m, m);
      at += m;
    }
  return all;
}

}  // namespace sid
