#pragma once
/// @file
/// @brief The torque residual that the noise of the measured angles leaves even with the right
/// model: the smoothing spline passes part of that noise into q̇ and q̈, and the regressor turns it
/// into torque (about D δq̈). With the torque's own noise it makes the floor below which a residual
/// says nothing about the model.

#include <sid/config.hpp>
#include <sid/model/model.hpp>
#include <sid/smoothing_spline.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>

namespace sid {

/// @brief RMS per joint of the torque error that angle noise of σ_q[j] causes through a penalty
/// smoothing spline with Reinsch multipliers p[j] (SmoothingReport), by Monte Carlo: `runs`
/// draws of white noise (std::mt19937_64(seed)), each smoothed on the spline's knots, and the
/// model's inverse dynamics at (q, q̇, q̈) + the smoothed noise minus at (q, q̇, q̈).
/// @param model, theta the model and its parameters (an identification of the data).
/// @param knots_kinematics the smoothed kinematics on the spline's knots (t strictly increasing).
/// @param first, count the rows the residual is judged on; weight (2 count: joint 1's rows, then
///   joint 2's) 1 for a row that counts, 0 for one that does not.
/// @throws std::invalid_argument on bad sizes, σ_q or p not finite and > 0, runs < 1.
SID_INLINE Vector2<double> kinematic_noise_rms(const Model<double>& model,
                                               const Eigen::Ref<const Eigen::VectorXd>& theta,
                                               const Kinematics<double>& knots_kinematics,
                                               const Vector2<double>& sigma_q,
                                               const Vector2<double>& p, Eigen::Index first,
                                               Eigen::Index count, const Eigen::VectorXd& weight,
                                               int runs, std::uint64_t seed);

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/diagnosis/kinematic_floor-inl.hpp>
#endif
