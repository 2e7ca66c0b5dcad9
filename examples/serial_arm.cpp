// Identifies the base parameters of a six-joint arm (a Staubli TX40 in modified DH) from a
// 10 s Fourier excitation at 1 kHz with noisy torques, and prints the estimates beside the
// truth. Needs Eigen only.

#include <sid/base_parameters.hpp>
#include <sid/least_squares.hpp>
#include <sid/model/chain_regressor.hpp>
#include <sid/model/link_inertia.hpp>
#include <sid/model/serial_chain.hpp>

#include <Eigen/Core>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

namespace {

constexpr double kPi = 3.14159265358979323846;

// One link's ten standard parameters from its mass, centre of mass c and principal inertias
// about c (principal axes along the link frame's).
void set_link(Eigen::VectorXd& theta, int link, double m, const Eigen::Vector3d& c,
              const Eigen::Vector3d& inertia_c) {
  const sid::LinkInertia<double> body{m, c, inertia_c.asDiagonal().toDenseMatrix()};
  theta.segment<10>(10 * link) = sid::standard_parameters(body);
}

}  // namespace

int main() {
  const sid::SerialChain<double> arm(sid::DhConvention::Modified, {{0.0, 0.0, 0.0, 0.0},
                                                                   {0.0, -kPi / 2, 0.0, 0.0},
                                                                   {0.225, 0.0, 0.035, 0.0},
                                                                   {0.0, kPi / 2, 0.225, 0.0},
                                                                   {0.0, -kPi / 2, 0.0, 0.0},
                                                                   {0.0, kPi / 2, 0.0, 0.0}});
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(sid::chain_parameter_count(6));
  set_link(theta, 0, 10.5, {0.0, 0.02, -0.043}, {0.055, 0.047, 0.035});
  set_link(theta, 1, 3.6, {0.109, -0.002, 0.134}, {0.038, 0.009, 0.04});
  set_link(theta, 2, 4.07, {0.008, 0.006, 0.041}, {0.012, 0.012, 0.004});
  set_link(theta, 3, 3.62, {-0.004, 0.002, -0.107}, {0.014, 0.013, 0.004});
  set_link(theta, 4, 1.02, {-0.004, -0.003, -0.001}, {0.001, 0.001, 0.001});
  set_link(theta, 5, 0.2, {0.0, 0.0, 0.042}, {8e-5, 8e-5, 1.6e-4});
  theta.segment<6>(60) << 8.05, 5.53, 1.97, 1.11, 1.86, 0.65;   // viscous [N m s/rad]
  theta.segment<6>(66) << 7.14, 8.26, 6.34, 2.48, 3.03, 0.282;  // Coulomb [N m]

  // Five harmonics of 0.1 Hz per joint, exact derivatives; torques with 0.05 N m noise.
  const Eigen::Index samples = 10000;
  const double wf = 2 * kPi * 0.1;
  std::mt19937_64 rng(40);
  std::uniform_real_distribution<double> coefficient(-0.25, 0.25);
  std::normal_distribution<double> noise(0.0, 0.05);
  Eigen::MatrixXd a(6, 5), b(6, 5);
  for (auto& v : a.reshaped()) v = coefficient(rng);
  for (auto& v : b.reshaped()) v = coefficient(rng);
  Eigen::MatrixXd q = Eigen::MatrixXd::Zero(samples, 6), qd = q, qdd = q, tau(samples, 6);
  for (Eigen::Index k = 0; k < samples; ++k) {
    const double t = 1e-3 * static_cast<double>(k);
    for (int j = 0; j < 6; ++j)
      for (int l = 1; l <= 5; ++l) {
        const double w = l * wf, s = std::sin(w * t), c = std::cos(w * t);
        q(k, j) += (a(j, l - 1) * s - b(j, l - 1) * c) / w;
        qd(k, j) += a(j, l - 1) * c + b(j, l - 1) * s;
        qdd(k, j) += w * (b(j, l - 1) * c - a(j, l - 1) * s);
      }
    tau.row(k) = sid::chain_inverse_dynamics(arm, theta, q.row(k).transpose(),
                                             qd.row(k).transpose(), qdd.row(k).transpose())
                     .transpose();
    for (int j = 0; j < 6; ++j) tau(k, j) += noise(rng);
  }

  const sid::StackedRegression<double> r = sid::stack_chain_regression(arm, q, qd, qdd, tau);
  const sid::BaseParameters<double> base = sid::base_parameters(r.X);
  sid::LeastSquaresOptions options;
  const std::vector<std::string> names = sid::chain_parameter_names(6);
  for (const Eigen::Index c : base.independent)
    options.column_names.push_back(names[static_cast<std::size_t>(c)]);
  const auto fit = sid::least_squares(base.base_regressor(r.X), r.y, 6, options);
  if (!fit.ok()) {
    std::fprintf(stderr, "%s\n", fit.message.c_str());
    return 1;
  }
  const Eigen::VectorXd beta = base.beta(theta);
  std::printf("%zu base parameters of %ld; condition number %.1f\n", base.independent.size(),
              static_cast<long>(theta.size()), fit.condition_number);
  std::printf("%-8s %12s %12s %10s\n", "column", "true beta", "estimate", "std dev");
  for (Eigen::Index k = 0; k < base.rank(); ++k)
    std::printf("%-8s %12.5f %12.5f %10.5f\n",
                options.column_names[static_cast<std::size_t>(k)].c_str(), beta[k], fit.theta[k],
                fit.std_dev[k]);
  return 0;
}
