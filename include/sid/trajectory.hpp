#pragma once
/// @file
/// @brief The data that flows through sid: measured trajectories and the kinematics estimated
/// from them (see docs/design.md).

#include <Eigen/Core>

#include <cmath>
#include <stdexcept>
#include <string>

namespace sid {

template <typename Scalar>
using VectorX = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
template <typename Scalar>
using MatrixX2 = Eigen::Matrix<Scalar, Eigen::Dynamic, 2>;
template <typename Scalar>
using Vector2 = Eigen::Matrix<Scalar, 2, 1>;

/// @brief Measured samples of a two-joint arm: times t [s], angles q [rad], torques tau [N m].
/// Class invariant (checked by validate()): t strictly increasing and finite, q and tau have one
/// row per time and finite entries.
template <typename Scalar>
struct Trajectory {
  VectorX<Scalar> t;
  MatrixX2<Scalar> q;
  MatrixX2<Scalar> tau;

  Eigen::Index size() const { return t.size(); }

  /// @throws std::invalid_argument naming the first violated invariant.
  void validate(const char* who = "sid::Trajectory") const {
    const std::string prefix = std::string(who) + ": ";
    if (q.rows() != t.size() || tau.rows() != t.size())
      throw std::invalid_argument(prefix + "t, q and tau must have the same number of rows (t: " +
                                  std::to_string(t.size()) + ", q: " + std::to_string(q.rows()) +
                                  ", tau: " + std::to_string(tau.rows()) + ")");
    for (Eigen::Index i = 0; i < t.size(); ++i) {
      using std::isfinite;
      if (!isfinite(t[i]))
        throw std::invalid_argument(prefix + "t[" + std::to_string(i) + "] is not finite");
      if (i > 0 && !(t[i] > t[i - 1]))
        throw std::invalid_argument(prefix + "t must be strictly increasing (t[" +
                                    std::to_string(i) + "] <= t[" + std::to_string(i - 1) + "])");
      if (!q.row(i).allFinite())
        throw std::invalid_argument(prefix + "q at row " + std::to_string(i) + " is not finite");
      if (!tau.row(i).allFinite())
        throw std::invalid_argument(prefix + "tau at row " + std::to_string(i) + " is not finite");
    }
  }
};

/// @brief Angles, velocities [rad/s], accelerations [rad/s^2] and torques at the samples an
/// estimator kept (a derivative method may drop samples at the ends).
template <typename Scalar>
struct Kinematics {
  VectorX<Scalar> t;
  MatrixX2<Scalar> q;
  MatrixX2<Scalar> qd;
  MatrixX2<Scalar> qdd;
  MatrixX2<Scalar> tau;

  Eigen::Index size() const { return t.size(); }
};

}  // namespace sid
