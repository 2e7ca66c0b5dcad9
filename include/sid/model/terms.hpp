#pragma once
/// @file
/// @brief A model term: a named group of regressor columns, linear in the term's own parameters.
///
/// A robot model is a sum of terms, tau = sum_k Z_k(q, qd, qdd) theta_k (paper eq. 9). A term only
/// says how to fill its 2 x p_k block Z_k; the columns may depend in any nonlinear way on q, qd,
/// qdd and on fixed hyper-parameters captured by the term (a Coulomb smoothing width, a known
/// offset). Regressor, inverse dynamics and forward dynamics all follow from the columns
/// (sid/model/model.hpp), so adding an effect means writing one term and nothing else.

#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {

namespace detail {
template <typename T>
struct NoDeduceImpl {
  using type = T;
};
/// Keeps a parameter out of template argument deduction (C++20 std::type_identity_t), so that
/// Scalar comes from one argument and the others may be Eigen expressions such as Zero().
template <typename T>
using NoDeduce = typename NoDeduceImpl<T>::type;
}  // namespace detail

/// Most parameters a two-joint model may have; lets regressors and parameter vectors live on the
/// stack.
inline constexpr Eigen::Index kMaxModelParameters = 32;

/// Most parameters a model of any other joint count may have: ten per link and the drive terms of
/// a kMaxChainJoints chain, with room to spare.
inline constexpr Eigen::Index kMaxChainModelParameters = 256;

namespace detail {
constexpr Eigen::Index max_model_parameters(int joints) noexcept {
  return joints == 2 ? kMaxModelParameters : kMaxChainModelParameters;
}
}  // namespace detail

/// @brief A writable joints x p view with arbitrary strides into which a term writes its columns.
/// Row j is joint j + 1. Arbitrary strides let the stacker write rows i and n + i of a stacked
/// regressor (paper eq. 10) in place, without a temporary.
template <typename Scalar, int Joints = 2>
using RegressorView = Eigen::Ref<Eigen::Matrix<Scalar, Joints, Eigen::Dynamic>, 0,
                                 Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>>;

/// @brief A joints x p regressor stored without heap memory (p at most kMaxModelParameters for
/// two joints, kMaxChainModelParameters otherwise).
template <typename Scalar, int Joints = 2>
using ModelRegressor =
    Eigen::Matrix<Scalar, Joints, Eigen::Dynamic, Eigen::ColMajor, detail::max_joints(Joints),
                  detail::max_model_parameters(Joints)>;

/// @brief A parameter vector stored without heap memory, bounded as ModelRegressor.
template <typename Scalar, int Joints = 2>
using ModelParameters = Eigen::Matrix<Scalar, Eigen::Dynamic, 1, Eigen::ColMajor,
                                      detail::max_model_parameters(Joints), 1>;

/// @brief One term of a model: tau_k = Z_k(q, qd, qdd) theta_k with Z_k of size joints x size().
///
/// Class invariant (checked by validate()): name not empty, at least one parameter, no empty
/// parameter name, columns callable.
/// @tparam Scalar float, double or an autodiff scalar.
/// @tparam Joints 2 for the paper's arm, Eigen::Dynamic for a chain known at run time.
template <typename Scalar, int Joints = 2>
struct Term {
  using Vector = JointVector<Scalar, Joints>;
  /// Fills out (joints x size(), already sized) with Z_k at angles q [rad], velocities qd [rad/s]
  /// and accelerations qdd [rad/s^2]. Must not allocate if the model is to be used in a control
  /// loop.
  using ColumnFunction = std::function<void(const Vector& q, const Vector& qd, const Vector& qdd,
                                            RegressorView<Scalar, Joints> out)>;

  std::string name;                          ///< e.g. "rigid_body", "coulomb_friction"
  std::vector<std::string> parameter_names;  ///< one per column, e.g. {"theta6", "theta7"}
  ColumnFunction columns;

  Eigen::Index size() const { return static_cast<Eigen::Index>(parameter_names.size()); }

  /// @throws std::invalid_argument (message starts with who) naming the violated invariant.
  void validate(const char* who = "sid::Term") const {
    const std::string prefix = std::string(who) + ": ";
    if (name.empty()) throw std::invalid_argument(prefix + "term name is empty");
    if (parameter_names.empty())
      throw std::invalid_argument(prefix + "term '" + name + "' has no parameters");
    for (const auto& p : parameter_names)
      if (p.empty())
        throw std::invalid_argument(prefix + "term '" + name + "' has an empty parameter name");
    if (!columns)
      throw std::invalid_argument(prefix + "term '" + name + "' has no column function");
  }
};

/// @brief Builds a term from its torque formula instead of its columns.
///
/// Column j is torque(e_j, q, qd, qdd): the torque at the j-th unit parameter vector. This is the
/// "no symbolic algebra" route: write tau_k(theta_k) once, get the regressor for free.
/// @pre torque is linear (homogeneous) in theta_k; an affine torque would leak its constant part
///      into every column.
/// @param torque callable (const ModelParameters<Scalar>& theta_k, const Vector2<Scalar>& q,
///        const Vector2<Scalar>& qd, const Vector2<Scalar>& qdd) -> Vector2<Scalar> [N m].
/// @throws std::invalid_argument if name or parameter_names are empty or too many parameters.
template <typename Scalar, typename TorqueFunction>
Term<Scalar> term_from_torque(std::string name, std::vector<std::string> parameter_names,
                              TorqueFunction torque) {
  if (static_cast<Eigen::Index>(parameter_names.size()) > kMaxModelParameters)
    throw std::invalid_argument("sid::term_from_torque: parameter_names has " +
                                std::to_string(parameter_names.size()) + " entries, at most " +
                                std::to_string(kMaxModelParameters) + " allowed");
  const auto p = static_cast<Eigen::Index>(parameter_names.size());
  Term<Scalar> term{std::move(name), std::move(parameter_names),
                    [p, torque](const Vector2<Scalar>& q, const Vector2<Scalar>& qd,
                                const Vector2<Scalar>& qdd, RegressorView<Scalar> out) {
                      ModelParameters<Scalar> unit = ModelParameters<Scalar>::Zero(p);
                      for (Eigen::Index j = 0; j < p; ++j) {
                        unit[j] = Scalar(1);
                        out.col(j) =
                            torque(static_cast<const ModelParameters<Scalar>&>(unit), q, qd, qdd);
                        unit[j] = Scalar(0);
                      }
                    }};
  term.validate("sid::term_from_torque");
  return term;
}

}  // namespace sid
