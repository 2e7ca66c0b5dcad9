#pragma once
/// @file
/// @brief sid::Model: an arm model as a sum of terms, and everything that follows from it
/// (regressor, inverse dynamics, mass matrix, bias torque, forward dynamics, state derivative).
///
/// One model serves every arm: the paper's two-link arm is its closed-form rigid-body term plus
/// friction terms (sid/model/two_link_arm.hpp), a serial chain its Newton-Euler rigid-body term
/// plus per-joint drive terms (sid/model/chain_model.hpp).

#include <sid/model/dynamics.hpp>
#include <sid/model/terms.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {

/// @brief A model tau = sum_k Z_k(q, qd, qdd) theta_k, theta the terms' parameters in order.
///
/// Class invariant: 1 <= joints() <= kMaxChainJoints (joints() == Joints when that is fixed);
/// terms_ valid, term names unique, num_parameters() <= max_parameters(); offsets_[k] is the
/// index of term k's first parameter in theta.
/// The evaluation members do not allocate (the regressor lives on the stack, terms write into it),
/// so a Model can run in a control loop; they throw only on wrongly sized arguments.
/// @tparam Scalar float, double or an autodiff scalar.
/// @tparam Joints 2 for the paper's arm (fixed-size, fastest), Eigen::Dynamic for a chain whose
///         joint count is known at run time.
template <typename Scalar, int Joints = 2>
class Model {
 public:
  using Vector = JointVector<Scalar, Joints>;
  using ModelTerm = Term<Scalar, Joints>;
  using ParameterRef = Eigen::Ref<const VectorX<Scalar>>;

  /// A model of Joints joints without terms (Joints fixed only).
  Model() {
    static_assert(Joints != Eigen::Dynamic, "sid::Model: give the joint count, Model(joints)");
  }

  /// @throws std::invalid_argument as add() does.
  explicit Model(std::vector<ModelTerm> terms) : Model() {
    for (auto& term : terms) add(std::move(term));
  }

  /// @throws std::invalid_argument if joints is outside 1..kMaxChainJoints or differs from a fixed
  ///         Joints, or as add() does.
  explicit Model(int joints, std::vector<ModelTerm> terms = {}) : joints_(joints) {
    if (joints < 1 || joints > kMaxChainJoints || (Joints != Eigen::Dynamic && joints != Joints))
      throw std::invalid_argument("sid::Model: " + std::to_string(joints) +
                                  " joints; a model has 1.." + std::to_string(kMaxChainJoints) +
                                  (Joints != Eigen::Dynamic
                                       ? " and this one exactly " + std::to_string(Joints)
                                       : std::string()));
    for (auto& term : terms) add(std::move(term));
  }

  /// The most parameters a model of this joint count may hold.
  static constexpr Eigen::Index max_parameters() noexcept {
    return detail::max_model_parameters(Joints);
  }

  /// @brief Appends a term; its parameters follow those already in the model.
  /// @throws std::invalid_argument if the term is invalid, its name is taken, or the model would
  ///         exceed max_parameters().
  Model& add(ModelTerm term) {
    term.validate("sid::Model::add");
    for (const auto& existing : terms_)
      if (existing.name == term.name)
        throw std::invalid_argument("sid::Model::add: term '" + term.name +
                                    "' is already in the model");
    if (num_parameters_ + term.size() > max_parameters())
      throw std::invalid_argument("sid::Model::add: term '" + term.name + "' would give " +
                                  std::to_string(num_parameters_ + term.size()) +
                                  " parameters, at most " + std::to_string(max_parameters()) +
                                  " allowed");
    offsets_.push_back(num_parameters_);
    num_parameters_ += term.size();
    terms_.push_back(std::move(term));
    return *this;
  }

  const std::vector<ModelTerm>& terms() const noexcept { return terms_; }
  int joints() const noexcept { return joints_; }
  Eigen::Index num_parameters() const noexcept { return num_parameters_; }

  /// @brief Parameter names in theta order (the terms' names concatenated).
  std::vector<std::string> parameter_names() const {
    std::vector<std::string> names;
    for (const auto& term : terms_)
      names.insert(names.end(), term.parameter_names.begin(), term.parameter_names.end());
    return names;
  }

  bool has_term(const std::string& name) const noexcept {
    for (const auto& term : terms_)
      if (term.name == name) return true;
    return false;
  }

  /// @brief Index in theta of the first parameter of the named term.
  /// @throws std::invalid_argument if there is no such term.
  Eigen::Index parameter_offset(const std::string& term_name) const {
    for (std::size_t k = 0; k < terms_.size(); ++k)
      if (terms_[k].name == term_name) return offsets_[k];
    throw std::invalid_argument("sid::Model::parameter_offset: no term named '" + term_name + "'");
  }

  /// @brief Index in theta of the parameter with this name (e.g. "theta4").
  /// @throws std::invalid_argument if there is no such parameter.
  Eigen::Index parameter_index(const std::string& parameter_name) const {
    for (std::size_t k = 0; k < terms_.size(); ++k) {
      const auto& names = terms_[k].parameter_names;
      for (std::size_t i = 0; i < names.size(); ++i)
        if (names[i] == parameter_name) return offsets_[k] + static_cast<Eigen::Index>(i);
    }
    throw std::invalid_argument("sid::Model::parameter_index: no parameter named '" +
                                parameter_name + "'");
  }

  /// @brief Z(q, qd, qdd) written into out (joints() x num_parameters()).
  /// @param q [rad], qd [rad/s], qdd [rad/s^2].
  /// @throws std::invalid_argument if a size does not match the model.
  void regressor(const Vector& q, const Vector& qd, const Vector& qdd,
                 RegressorView<Scalar, Joints> out) const {
    check_state("sid::Model::regressor", q, qd, qdd);
    if (out.rows() != joints_ || out.cols() != num_parameters_)
      throw std::invalid_argument("sid::Model::regressor: out is " + std::to_string(out.rows()) +
                                  " x " + std::to_string(out.cols()) + " but the model has " +
                                  std::to_string(joints_) + " joints and " +
                                  std::to_string(num_parameters_) + " parameters");
    regressor_unchecked(q, qd, qdd, out);
  }

  /// @brief Z(q, qd, qdd), joints() x num_parameters(), on the stack.
  ModelRegressor<Scalar, Joints> regressor(const Vector& q, const Vector& qd,
                                           const Vector& qdd) const {
    check_state("sid::Model::regressor", q, qd, qdd);
    ModelRegressor<Scalar, Joints> z(joints_, num_parameters_);
    regressor_unchecked(q, qd, qdd, z);
    return z;
  }

  /// @brief tau = Z(q, qd, qdd) theta [N m].
  /// @throws std::invalid_argument if theta.size() != num_parameters() or a joint vector's size
  ///         != joints().
  Vector inverse_dynamics(const ParameterRef& theta, const Vector& q, const Vector& qd,
                          const Vector& qdd) const {
    check_theta("sid::Model::inverse_dynamics", theta);
    check_state("sid::Model::inverse_dynamics", q, qd, qdd);
    return inverse_dynamics_unchecked(theta, q, qd, qdd);
  }

  /// @brief D(q) [kg m^2], column j = ID(q, 0, e_j) - ID(q, 0, 0).
  JointMatrix<Scalar, Joints> mass_matrix(const ParameterRef& theta, const Vector& q) const {
    check_theta("sid::Model::mass_matrix", theta);
    check_state("sid::Model::mass_matrix", q, q, q);
    return mass_matrix_from_inverse_dynamics<Scalar, Joints>(bind(theta), q);
  }

  /// @brief h(q, qd) = ID(q, qd, 0) [N m].
  Vector bias_torque(const ParameterRef& theta, const Vector& q, const Vector& qd) const {
    check_theta("sid::Model::bias_torque", theta);
    check_state("sid::Model::bias_torque", q, qd, qd);
    return bias_torque_from_inverse_dynamics<Scalar, Joints>(bind(theta), q, qd);
  }

  /// @brief qdd = D(q)^-1 (tau - h(q, qd)) [rad/s^2] for applied torques tau [N m].
  Vector forward_dynamics(const ParameterRef& theta, const Vector& q, const Vector& qd,
                          const Vector& tau) const {
    check_theta("sid::Model::forward_dynamics", theta);
    check_state("sid::Model::forward_dynamics", q, qd, tau);
    return forward_dynamics_from_inverse_dynamics<Scalar, Joints>(bind(theta), q, qd, tau);
  }

  /// @brief xdot = (qd, qdd) for x = (q, qd) under applied torques tau [N m].
  JointState<Scalar, Joints> state_derivative(const ParameterRef& theta,
                                              const JointState<Scalar, Joints>& x,
                                              const Vector& tau) const {
    check_theta("sid::Model::state_derivative", theta);
    if (x.size() != 2 * joints_ || tau.size() != joints_)
      throw std::invalid_argument(
          "sid::Model::state_derivative: x has " + std::to_string(x.size()) + " entries and tau " +
          std::to_string(tau.size()) + " for a model of " + std::to_string(joints_) + " joints");
    const auto id = bind(theta);
    return state_derivative_from_forward_dynamics<Scalar, Joints>(
        [&id](const Vector& q, const Vector& qd, const Vector& u) {
          return forward_dynamics_from_inverse_dynamics<Scalar, Joints>(id, q, qd, u);
        },
        x, tau);
  }

 private:
  void check_state(const char* who, const Vector& q, const Vector& qd, const Vector& qdd) const {
    if constexpr (Joints == Eigen::Dynamic) {
      if (q.size() != joints_ || qd.size() != joints_ || qdd.size() != joints_)
        throw std::invalid_argument(
            std::string(who) + ": joint vectors of " + std::to_string(q.size()) + ", " +
            std::to_string(qd.size()) + " and " + std::to_string(qdd.size()) +
            " entries for a model of " + std::to_string(joints_) + " joints");
    } else {
      (void)who, (void)q, (void)qd, (void)qdd;
    }
  }

  void check_theta(const char* who, const ParameterRef& theta) const {
    if (theta.size() != num_parameters_)
      throw std::invalid_argument(std::string(who) + ": theta has " + std::to_string(theta.size()) +
                                  " entries but the model has " + std::to_string(num_parameters_) +
                                  " parameters");
  }

  void regressor_unchecked(const Vector& q, const Vector& qd, const Vector& qdd,
                           RegressorView<Scalar, Joints> out) const {
    for (std::size_t k = 0; k < terms_.size(); ++k)
      terms_[k].columns(q, qd, qdd, out.middleCols(offsets_[k], terms_[k].size()));
  }

  Vector inverse_dynamics_unchecked(const ParameterRef& theta, const Vector& q, const Vector& qd,
                                    const Vector& qdd) const {
    ModelRegressor<Scalar, Joints> z(joints_, num_parameters_);
    regressor_unchecked(q, qd, qdd, z);
    Vector tau = Vector::Zero(joints_);
    for (Eigen::Index j = 0; j < num_parameters_; ++j) tau += z.col(j) * theta[j];
    return tau;
  }

  /// (q, qd, qdd) -> tau at fixed theta, the form dynamics.hpp works with.
  auto bind(const ParameterRef& theta) const {
    return [this, &theta](const Vector& q, const Vector& qd, const Vector& qdd) {
      return inverse_dynamics_unchecked(theta, q, qd, qdd);
    };
  }

  int joints_ = Joints == Eigen::Dynamic ? 0 : Joints;
  std::vector<ModelTerm> terms_;
  std::vector<Eigen::Index> offsets_;
  Eigen::Index num_parameters_ = 0;
};

}  // namespace sid
