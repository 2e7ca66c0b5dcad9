#pragma once
/// @file
/// @brief sid::Model: a two-joint arm model as a sum of terms, and everything that follows from
/// it (regressor, inverse dynamics, mass matrix, bias torque, forward dynamics, state derivative).

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
/// Class invariant: terms_ valid, term names unique, num_parameters() <= kMaxModelParameters;
/// offsets_[k] is the index of term k's first parameter in theta.
/// The evaluation members do not allocate (the regressor lives on the stack, terms write into it),
/// so a Model can run in a control loop; they throw only on wrongly sized arguments.
/// @tparam Scalar float, double or an autodiff scalar.
template <typename Scalar>
class Model {
 public:
  using Vector = Vector2<Scalar>;
  using ParameterRef = Eigen::Ref<const VectorX<Scalar>>;

  Model() = default;

  /// @throws std::invalid_argument as add() does.
  explicit Model(std::vector<Term<Scalar>> terms) {
    for (auto& term : terms) add(std::move(term));
  }

  /// @brief Appends a term; its parameters follow those already in the model.
  /// @throws std::invalid_argument if the term is invalid, its name is taken, or the model would
  ///         exceed kMaxModelParameters.
  Model& add(Term<Scalar> term) {
    term.validate("sid::Model::add");
    for (const auto& existing : terms_)
      if (existing.name == term.name)
        throw std::invalid_argument("sid::Model::add: term '" + term.name +
                                    "' is already in the model");
    if (num_parameters_ + term.size() > kMaxModelParameters)
      throw std::invalid_argument("sid::Model::add: term '" + term.name + "' would give " +
                                  std::to_string(num_parameters_ + term.size()) +
                                  " parameters, at most " + std::to_string(kMaxModelParameters) +
                                  " allowed");
    offsets_.push_back(num_parameters_);
    num_parameters_ += term.size();
    terms_.push_back(std::move(term));
    return *this;
  }

  const std::vector<Term<Scalar>>& terms() const noexcept { return terms_; }
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

  /// @brief Z(q, qd, qdd) written into out (2 x num_parameters()).
  /// @param q [rad], qd [rad/s], qdd [rad/s^2].
  /// @throws std::invalid_argument if out has the wrong number of columns.
  void regressor(const Vector& q, const Vector& qd, const Vector& qdd,
                 RegressorView<Scalar> out) const {
    if (out.cols() != num_parameters_)
      throw std::invalid_argument("sid::Model::regressor: out has " + std::to_string(out.cols()) +
                                  " columns but the model has " + std::to_string(num_parameters_) +
                                  " parameters");
    regressor_unchecked(q, qd, qdd, out);
  }

  /// @brief Z(q, qd, qdd), 2 x num_parameters(), on the stack.
  ModelRegressor<Scalar> regressor(const Vector& q, const Vector& qd, const Vector& qdd) const {
    ModelRegressor<Scalar> z(2, num_parameters_);
    regressor_unchecked(q, qd, qdd, z);
    return z;
  }

  /// @brief tau = Z(q, qd, qdd) theta [N m].
  /// @throws std::invalid_argument if theta.size() != num_parameters().
  Vector inverse_dynamics(const ParameterRef& theta, const Vector& q, const Vector& qd,
                          const Vector& qdd) const {
    check_theta("sid::Model::inverse_dynamics", theta);
    return inverse_dynamics_unchecked(theta, q, qd, qdd);
  }

  /// @brief D(q) [kg m^2], column j = ID(q, 0, e_j) - ID(q, 0, 0).
  Matrix2<Scalar> mass_matrix(const ParameterRef& theta, const Vector& q) const {
    check_theta("sid::Model::mass_matrix", theta);
    return mass_matrix_from_inverse_dynamics<Scalar>(bind(theta), q);
  }

  /// @brief h(q, qd) = ID(q, qd, 0) [N m].
  Vector bias_torque(const ParameterRef& theta, const Vector& q, const Vector& qd) const {
    check_theta("sid::Model::bias_torque", theta);
    return bias_torque_from_inverse_dynamics<Scalar>(bind(theta), q, qd);
  }

  /// @brief qdd = D(q)^-1 (tau - h(q, qd)) [rad/s^2] for applied torques tau [N m].
  Vector forward_dynamics(const ParameterRef& theta, const Vector& q, const Vector& qd,
                          const Vector& tau) const {
    check_theta("sid::Model::forward_dynamics", theta);
    return forward_dynamics_from_inverse_dynamics<Scalar>(bind(theta), q, qd, tau);
  }

  /// @brief xdot = (qd, qdd) for x = (q, qd) under applied torques tau [N m].
  ArmState<Scalar> state_derivative(const ParameterRef& theta, const ArmState<Scalar>& x,
                                    const Vector& tau) const {
    check_theta("sid::Model::state_derivative", theta);
    const auto id = bind(theta);
    return state_derivative_from_forward_dynamics<Scalar>(
        [&id](const Vector& q, const Vector& qd, const Vector& u) {
          return forward_dynamics_from_inverse_dynamics<Scalar>(id, q, qd, u);
        },
        x, tau);
  }

 private:
  void check_theta(const char* who, const ParameterRef& theta) const {
    if (theta.size() != num_parameters_)
      throw std::invalid_argument(std::string(who) + ": theta has " + std::to_string(theta.size()) +
                                  " entries but the model has " + std::to_string(num_parameters_) +
                                  " parameters");
  }

  void regressor_unchecked(const Vector& q, const Vector& qd, const Vector& qdd,
                           RegressorView<Scalar> out) const {
    for (std::size_t k = 0; k < terms_.size(); ++k)
      terms_[k].columns(q, qd, qdd, out.middleCols(offsets_[k], terms_[k].size()));
  }

  Vector inverse_dynamics_unchecked(const ParameterRef& theta, const Vector& q, const Vector& qd,
                                    const Vector& qdd) const {
    ModelRegressor<Scalar> z(2, num_parameters_);
    regressor_unchecked(q, qd, qdd, z);
    Vector tau = Vector::Zero();
    for (Eigen::Index j = 0; j < num_parameters_; ++j) tau += z.col(j) * theta[j];
    return tau;
  }

  /// (q, qd, qdd) -> tau at fixed theta, the form dynamics.hpp works with.
  auto bind(const ParameterRef& theta) const {
    return [this, &theta](const Vector& q, const Vector& qd, const Vector& qdd) {
      return inverse_dynamics_unchecked(theta, q, qd, qdd);
    };
  }

  std::vector<Term<Scalar>> terms_;
  std::vector<Eigen::Index> offsets_;
  Eigen::Index num_parameters_ = 0;
};

}  // namespace sid
