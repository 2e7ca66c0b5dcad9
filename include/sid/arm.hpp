#pragma once
/// @file
/// @brief sid::Arm: the arm whose parameters a workflow estimates, one type for the paper's
/// two-link arm and for any serial chain, so that a workflow is written once over it.
///
/// Behind it each kind keeps its own kernel: the paper's closed-form regressor, whose seven
/// parameters θ are their own base set and simulate as they are; or a chain's model with its
/// base parameters, whose estimate is simulated through the nearest physically consistent links
/// (sid::consistent_chain_parameters) and the O(n) articulated-body dynamics. An Arm is an
/// immutable value; copies share the kernel. The kernel is called once per batch of rows or per
/// right-hand side of a simulation, never per regressor entry.

#include <sid/base_parameters.hpp>
#include <sid/chain_consistency.hpp>
#include <sid/chain_regression.hpp>
#include <sid/config.hpp>
#include <sid/least_squares.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <memory>
#include <vector>

namespace sid {

namespace detail {

/// What a kind of arm provides to the workflows (see sid::Arm, which forwards to it).
class ArmKernel {
 public:
  using Vector = JointVector<double, Eigen::Dynamic>;

  SID_INLINE virtual ~ArmKernel();
  virtual int joints() const = 0;
  virtual Eigen::Index parameters() const = 0;
  virtual ChainRegression regression(const ChainKinematics<double>& k,
                                     const std::vector<Eigen::Index>& samples) const = 0;
  virtual Eigen::VectorXd simulatable(const LeastSquaresResult<double>& estimate,
                                      double relative_residual, const Eigen::VectorXd& prior,
                                      const ChainConsistencyOptions& consistency) const = 0;
  virtual Vector forward_dynamics(const Eigen::VectorXd& body, const Vector& q, const Vector& qd,
                                  const Vector& tau) const = 0;
};

}  // namespace detail

/// @brief The arm of an identification: its joints, the regression rows of its estimated
/// parameters and a body to simulate for an estimate. Build it with sid::paper_arm() or
/// sid::chain_arm().
class Arm {
 public:
  using Vector = detail::ArmKernel::Vector;

  explicit Arm(std::shared_ptr<const detail::ArmKernel> kernel) : kernel_(std::move(kernel)) {}

  int joints() const { return kernel_->joints(); }
  /// The estimated parameters: the paper arm's seven θ, a chain's base parameters.
  Eigen::Index parameters() const { return kernel_->parameters(); }

  /// @brief The rows of the estimated parameters at k's `samples` (increasing indices of k),
  /// stacked joint by joint: row j·m + a is joint j at samples[a], with its measured τ in y.
  ChainRegression regression(const ChainKinematics<double>& k,
                             const std::vector<Eigen::Index>& samples) const {
    return kernel_->regression(k, samples);
  }

  /// @brief The parameters a simulation of `estimate` runs on, what forward_dynamics() takes:
  /// the paper arm's θ itself; for a chain, every parameter of the nearest physically
  /// consistent model (a base-parameter estimate's mass matrix need not be positive definite),
  /// weighed as consistent_chain_parameters() does, with `relative_residual` the least-squares
  /// fit's residual over the torque's norm, and `prior` and `consistency` its prior and options.
  Eigen::VectorXd simulatable(const LeastSquaresResult<double>& estimate, double relative_residual,
                              const Eigen::VectorXd& prior = {},
                              const ChainConsistencyOptions& consistency = {}) const {
    return kernel_->simulatable(estimate, relative_residual, prior, consistency);
  }

  /// @brief q̈ under the torque tau at the state (q, qd), for the parameters `body` that
  /// simulatable() gave. Allocates nothing.
  Vector forward_dynamics(const Eigen::VectorXd& body, const Vector& q, const Vector& qd,
                          const Vector& tau) const {
    return kernel_->forward_dynamics(body, q, qd, tau);
  }

 private:
  std::shared_ptr<const detail::ArmKernel> kernel_;
};

/// @brief The paper's two-link arm (sid/model/two_link_arm.hpp) under gravity g [m/s²].
SID_INLINE Arm paper_arm(double gravity = kPaperGravity);

/// @brief A serial chain: `model` with its base parameters `base` (chain_base_parameters()),
/// whose estimates are of those base parameters.
/// @throws std::invalid_argument if `base` does not split the model's parameters.
SID_INLINE Arm chain_arm(ChainModel model, BaseParameters<double> base);

/// @brief Arm::regression() of several runs, each at its own samples, stacked joint by joint
/// as one run's rows are (joint 0 of every run, then joint 1, ...): the per-joint statistics of
/// a fit on them need that layout.
/// @throws std::invalid_argument if there is not one sample list per run.
SID_INLINE ChainRegression
stacked_regression(const Arm& arm, const std::vector<ChainKinematics<double>>& runs,
                   const std::vector<std::vector<Eigen::Index>>& samples);

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/arm-inl.hpp>
#endif
