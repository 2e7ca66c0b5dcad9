// The whole pipeline in a few lines (the README's example): simulate the paper's experiment,
// add noise, smooth, build the regressor, solve by QR.
#include <sid/cvode/experiment.hpp>
#include <sid/identify.hpp>
#include <sid/measurement_noise.hpp>

#include <cstdio>
#include <random>

int main() {
  const auto theta = sid::paper_arm_parameters<double>();
  const auto run = sid::simulate_arm_experiment(  // CVODE, u = (6 sin t, 4 cos t), 10 s at 400 Hz
      [&](const auto& q, const auto& qd, const auto& tau) {
        return sid::two_link_forward_dynamics(theta, q, qd, tau);
      });
  std::mt19937_64 rng(1);
  const sid::Trajectory<double> measured = sid::add_measurement_noise(run.truth, {1e-6, 1e-2}, rng);

  sid::IdentifyOptions options;  // CSS: Reinsch spline with delta_q = sigma_q and S = n
  options.sigma_q.setConstant(1e-3);
  const sid::Identification id = sid::identify(measured, options);

  for (int k = 0; k < 7; ++k)
    std::printf("theta%d = %.5f +- %.5f (true %.5f)\n", k + 1, id.fit.theta[k], id.fit.std_dev[k],
                theta[k]);
  return id.fit.ok() ? 0 : 1;
}
