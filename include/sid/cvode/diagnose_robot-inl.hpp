#pragma once
// The definitions of <sid/cvode/diagnose_robot.hpp>: included by it in header-only mode, compiled
// once into sid::cvode_compiled otherwise.

#include <sid/cvode/diagnose_robot.hpp>

#include <chrono>

namespace sid {

SID_INLINE RobotDiagnosis diagnose_robot(const ChainModel& nominal,
                                         const std::vector<ChainTrajectory<double>>& runs,
                                         const ChainDiagnoseOptions& options,
                                         const DescriptionDynamics& description) {
  RobotDiagnosis out;
  out.diagnosis = diagnose_chain(nominal, runs, options);
  if (description.link_parameters.size() == 0) {
    out.motion_note = "no free simulation: the description has no link inertias (a DH table)";
    return out;
  }
  const auto start = std::chrono::steady_clock::now();
  const ChainModel final_model(nominal.chain(), nominal.joint_names(), out.diagnosis.final_terms,
                               nominal.transmission(), nominal.coulomb_epsilon());
  ChainMotionCheck& m = out.motion;
  m = check_chain_motion(nominal, out.diagnosis, runs, options.identify,
                         description_prior(final_model, description));
  if (!m.final_error.allFinite() || !m.threshold.allFinite())
    out.motion_note = "no free-simulation verdict: " +
                      std::string(m.final_error.allFinite()
                                      ? "no exact-model replicate could be fitted and simulated"
                                      : "the final model could not be fitted or simulated") +
                      (m.failure.empty() ? "" : " (" + m.failure + ")");
  out.motion_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace sid
