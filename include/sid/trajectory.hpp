#pragma once
/// @file
/// @brief The data that flows through sid: measured trajectories and the kinematics estimated
/// from them (see docs/design.md).

#include <Eigen/Core>

#include <algorithm>
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

/// @brief The joint count a chain may have; per-sample vectors and the recursions' link states
/// live on the stack up to this size, so models run without heap memory in a control loop.
inline constexpr int kMaxChainJoints = 12;

namespace detail {
/// The storage bound of a joint-indexed vector: the count itself when it is known at compile
/// time, kMaxChainJoints when it is Eigen::Dynamic.
constexpr int max_joints(int joints) noexcept {
  return joints == Eigen::Dynamic ? kMaxChainJoints : joints;
}
}  // namespace detail

/// @brief One value per joint (angles, rates, torques of one sample), on the stack: Vector2 for
/// the paper's arm, a vector of at most kMaxChainJoints entries for a chain known at run time.
template <typename Scalar, int Joints = 2>
using JointVector =
    Eigen::Matrix<Scalar, Joints, 1, Eigen::ColMajor, detail::max_joints(Joints), 1>;

/// @brief Joint samples: one row per sample, one column per joint (fixed at compile time where
/// the arm is known, e.g. 2 for the paper's arm; Eigen::Dynamic for a chain read at run time).
template <typename Scalar, int Joints>
using JointSamples = Eigen::Matrix<Scalar, Eigen::Dynamic, Joints>;

/// @brief Measured samples of an arm: times t [s], angles q [rad], torques tau [N m], one
/// column per joint (two for the paper's arm; Eigen::Dynamic for any chain, see ChainTrajectory).
/// Class invariant (checked by validate()): t strictly increasing and finite, q and tau have one
/// row per time, the same number of columns, and finite entries.
template <typename Scalar, int Joints = 2>
struct Trajectory {
  VectorX<Scalar> t;
  JointSamples<Scalar, Joints> q;
  JointSamples<Scalar, Joints> tau;

  Eigen::Index size() const { return t.size(); }
  Eigen::Index joints() const { return q.cols(); }

  /// @throws std::invalid_argument naming the first violated invariant.
  void validate(const char* who = "sid::Trajectory") const {
    const std::string prefix = std::string(who) + ": ";
    if (q.rows() != t.size() || tau.rows() != t.size())
      throw std::invalid_argument(prefix + "t, q and tau must have the same number of rows (t: " +
                                  std::to_string(t.size()) + ", q: " + std::to_string(q.rows()) +
                                  ", tau: " + std::to_string(tau.rows()) + ")");
    if (q.cols() != tau.cols() || q.cols() == 0)
      throw std::invalid_argument(prefix + "q and tau must have the same number of joints, at " +
                                  "least one (q: " + std::to_string(q.cols()) +
                                  ", tau: " + std::to_string(tau.cols()) + ")");
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
template <typename Scalar, int Joints = 2>
struct Kinematics {
  VectorX<Scalar> t;
  JointSamples<Scalar, Joints> q;
  JointSamples<Scalar, Joints> qd;
  JointSamples<Scalar, Joints> qdd;
  JointSamples<Scalar, Joints> tau;

  Eigen::Index size() const { return t.size(); }
  Eigen::Index joints() const { return q.cols(); }
};

/// @brief Samples of a chain whose joint count is known at run time.
template <typename Scalar>
using ChainTrajectory = Trajectory<Scalar, Eigen::Dynamic>;
template <typename Scalar>
using ChainKinematics = Kinematics<Scalar, Eigen::Dynamic>;

namespace detail {

/// The drive at `time`: linear between the samples at t, held beyond the ends.
template <int Joints>
JointVector<double, Joints> drive_at(const VectorX<double>& t,
                                     const JointSamples<double, Joints>& drive, double time) {
  const Eigen::Index n = t.size();
  if (time <= t[0]) return drive.row(0).transpose();
  if (time >= t[n - 1]) return drive.row(n - 1).transpose();
  const Eigen::Index i = std::upper_bound(t.data(), t.data() + n, time) - t.data() - 1;
  const double a = (time - t[i]) / (t[i + 1] - t[i]);
  return (1.0 - a) * drive.row(i).transpose() + a * drive.row(i + 1).transpose();
}

}  // namespace detail

}  // namespace sid
