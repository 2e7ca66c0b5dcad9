#pragma once
/// @file
/// @brief The whole chain diagnosis as `sid_diagnose --robot` makes it: which drive terms the
/// logs support beyond the nominal model (sid::diagnose_chain), then free simulations of the
/// nominal and the final model, each at its physically consistent fit near the description,
/// judged against exact-model replicates of the log (sid::check_chain_motion). One call gives a
/// C++ program the tool's verdict.

#include <sid/config.hpp>
#include <sid/cvode/chain_motion_check.hpp>
#include <sid/description_prior.hpp>
#include <sid/diagnose_chain.hpp>

#include <string>
#include <vector>

namespace sid {

/// @brief What diagnose_robot() found.
struct RobotDiagnosis {
  ChainDiagnosis diagnosis;
  /// The free simulations' verdict; empty (no final_error) when there is none.
  ChainMotionCheck motion;
  /// Why there is no verdict, when there is none (no link inertias to simulate, a model that
  /// could not be fitted or simulated); else empty.
  std::string motion_note;
  double motion_seconds = 0.0;  ///< wall time of the free simulations [s]
};

/// @brief Diagnoses runs (joint side) against the nominal model, then simulates its nominal and
/// final models freely when the description gives link inertias.
/// @throws std::invalid_argument as diagnose_chain and check_chain_motion.
SID_INLINE RobotDiagnosis diagnose_robot(const ChainModel& nominal,
                                         const std::vector<ChainTrajectory<double>>& runs,
                                         const ChainDiagnoseOptions& options = {},
                                         const DescriptionDynamics& description = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/cvode/diagnose_robot-inl.hpp>
#endif
