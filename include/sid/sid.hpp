#pragma once
/// @file
/// @brief Everything of sid that needs Eigen only: the smoother, the model and its effects,
/// identification (one run or several), physical consistency, the diagnosis in the torque
/// domain and the Monte Carlo study. The simulator and what is built on it (free simulation,
/// output error, instrumental variables) need SUNDIALS and are included from sid/cvode/.

#include <sid/arm.hpp>
#include <sid/banded.hpp>
#include <sid/base_parameters.hpp>
#include <sid/butterworth.hpp>
#include <sid/close_abscissae.hpp>
#include <sid/cubic_spline.hpp>
#include <sid/diagnose.hpp>
#include <sid/diagnose_runs.hpp>
#include <sid/finite_difference.hpp>
#include <sid/identify.hpp>
#include <sid/identify_runs.hpp>
#include <sid/least_squares.hpp>
#include <sid/logged_sensors.hpp>
#include <sid/measurement_noise.hpp>
#include <sid/model/chain_dynamics.hpp>
#include <sid/model/chain_regressor.hpp>
#include <sid/model/dynamics.hpp>
#include <sid/model/effects.hpp>
#include <sid/model/joint_dynamics.hpp>
#include <sid/model/link_inertia.hpp>
#include <sid/model/model.hpp>
#include <sid/model/regressor.hpp>
#include <sid/model/robot_description.hpp>
#include <sid/model/serial_chain.hpp>
#include <sid/model/terms.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/model/urdf.hpp>
#include <sid/physical_consistency.hpp>
#include <sid/smoothing_spline.hpp>
#include <sid/study/montecarlo.hpp>
#include <sid/trajectory.hpp>
