#pragma once
// The definitions of <sid/cvode/identify_robot_currents.hpp>: included by it in header-only mode,
// compiled once into sid::cvode_compiled otherwise.

#include <sid/cvode/identify_robot_currents.hpp>

#include <sid/detail/format.hpp>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace sid {

namespace detail {

/// The runs in N m: currents times the gains, the load's torque taken off the loaded runs
/// (computed on their kinematics smoothed at the gains' cutoffs).
inline std::vector<NamedChainRun> runs_in_torque(const ChainModel& model,
                                                 const std::vector<const NamedChainRun*>& runs,
                                                 const std::vector<bool>& loaded,
                                                 const LinkInertia<double>& payload,
                                                 const DriveGainIdentification& gains,
                                                 const ChainIdentifyOptions& options) {
  std::vector<NamedChainRun> out;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    ChainTrajectory<double> torque = torques_from_currents(model, runs[r]->data, gains.gain);
    if (r < loaded.size() && loaded[r])
      torque.tau -= payload_torque(model, smooth_chain_run(runs[r]->data, gains.cutoff_hz, options),
                                   standard_parameters(payload));
    out.push_back({runs[r]->name, std::move(torque)});
  }
  return out;
}

}  // namespace detail

SID_INLINE RobotCurrentsIdentification identify_robot_currents(
    const ChainModel& model, const NamedChainRun& loaded_run,
    const std::vector<NamedChainRun>& runs, const LinkInertia<double>& payload,
    const std::vector<NamedChainRun>& held_out, const RobotCurrentsOptions& options) {
  if (runs.empty())
    throw std::invalid_argument(
        "sid::identify_robot_currents: a run without the load is needed besides the loaded one: "
        "with the load alone it merges with the tip link and the gains' scale is not "
        "identifiable");
  const int n = model.joints();
  const ChainIdentifyOptions& chain = options.identify.fit;
  std::vector<const NamedChainRun*> all = {&loaded_run};
  for (const auto& r : runs) all.push_back(&r);
  std::vector<ChainTrajectory<double>> currents;
  for (const NamedChainRun* r : all) currents.push_back(r->data);
  std::vector<bool> carries(all.size(), false);
  carries.front() = true;

  // The gains at the cutoffs given. Else the identification's choice is made on the runs
  // converted by a first fit of the gains at the middle of its search range (where
  // identify_chain judges what the runs determine), and gains and arm are then fitted at it, so
  // that both smooth alike.
  const bool choose = chain.cutoff_hz.empty();
  Eigen::VectorXd cutoff(n);
  for (int j = 0; j < n; ++j)
    cutoff[j] =
        choose ? std::sqrt(chain.min_cutoff_hz * chain.max_cutoff_hz)
               : chain.cutoff_hz[chain.cutoff_hz.size() == 1 ? std::size_t{0} : std::size_t(j)];
  DriveGainOptions gain_options;
  gain_options.chain = chain;
  RobotCurrentsIdentification out;
  out.gains = identify_drive_gains(model, currents, carries, payload, cutoff, gain_options);
  out.first_cutoff_hz = choose ? cutoff[0] : std::numeric_limits<double>::quiet_NaN();
  RobotIdentifyOptions arm_options = options.identify;
  if (choose) {
    std::vector<ChainTrajectory<double>> data;
    for (auto& r : detail::runs_in_torque(model, all, carries, payload, out.gains, chain))
      data.push_back(std::move(r.data));
    ChainIdentifyOptions only_cutoffs = chain;
    only_cutoffs.statistics = false;
    cutoff = identify_chain(model, data, only_cutoffs).cutoff_hz;
    out.gains = identify_drive_gains(model, currents, carries, payload, cutoff, gain_options);
    arm_options.fit.cutoff_hz.assign(cutoff.data(), cutoff.data() + n);
  }
  std::vector<const NamedChainRun*> held;
  for (const auto& r : held_out) held.push_back(&r);
  out.arm = identify_robot(
      model, detail::runs_in_torque(model, all, carries, payload, out.gains, chain),
      detail::runs_in_torque(model, held, {}, payload, out.gains, chain), arm_options);
  if (choose) out.arm.identification.cutoff_chosen = true;
  const DriveGainIdentification& g = out.gains;
  for (Eigen::Index j = 0; j < n; ++j)
    if (!(g.std_dev[j] <= options.poor_gain * std::abs(g.gain[j]))) {
      out.arm.warnings.push_back(
          "the drive gain of " + model.joint_names()[static_cast<std::size_t>(j)] +
          " is poorly determined (std " +
          detail::format_number("%.3g", 100.0 * g.std_dev[j] / std::abs(g.gain[j])) +
          " %): the payload's torque there is small, or the loaded run moves it little");
    }
  return out;
}

}  // namespace sid
