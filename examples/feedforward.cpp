// Model-based control at 1 kHz with an identified arm: gravity compensation plus PD, then
// computed torque, both tracking the same smooth trajectory on a simulated arm that is not quite
// the model (as a real one never is).
//
//   feedforward [robot.urdf [base_link tip_link [ARM.json]]]   (default: the UR5 of tests/data)
//
// ARM.json: `sid_identify --robot robot.urdf --base .. --tip .. --json ARM.json` on the arm's
// logs (default drive terms); without it, the URDF's links and made-up drives.
//
// Computed torque: tau = M(q) (qdd_ref + Kp e + Kd de) + c(q, qd) + g(q) + f(q, qd), e = q_ref - q.
// With a perfect model the closed loop is e'' + Kd e' + Kp e = 0 on every joint, whatever the
// pose; the error left is the model's. Gravity compensation alone (tau = g + f + PD) leaves the
// arm's inertia and Coriolis torques to the PD gains, and tracks far worse at the same gains.

#include <sid/arm_dynamics.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/transmission.hpp>
#include <sid/model/urdf.hpp>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using Vector = sid::ArmDynamics::Vector;  // on the stack: nothing in the loop allocates
using Matrix = sid::ArmDynamics::Matrix;

constexpr double kTick = 1e-3;     // [s] the control rate, 1 kHz
constexpr int kSubsteps = 10;      // the simulated arm moves in 0.1 ms steps between ticks
constexpr double kDuration = 4.0;  // [s]
constexpr double kKp = 400.0;      // [1/s^2] e'' + Kd e' + Kp e = 0: 20 rad/s, critically damped
constexpr double kKd = 40.0;       // [1/s]

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// The identified parameters of sid_identify --json: physically_consistent.theta, every link a
/// real body (ArmDynamics refuses the links an unconstrained fit can give), in the order of
/// model_parameters, which must be this model's.
Eigen::VectorXd fitted_parameters(const std::string& path, const sid::ChainModel& model) {
  const nlohmann::json fit = nlohmann::json::parse(read_text(path));
  if (fit.at("model_parameters").get<std::vector<std::string>>() != model.parameter_names())
    throw std::runtime_error(path + " is the fit of another model (its model_parameters differ)");
  if (!fit.at("physically_consistent").at("converged").get<bool>())
    throw std::runtime_error(path + ": its physically consistent fit did not converge");
  const auto theta = fit.at("physically_consistent").at("theta").get<std::vector<double>>();
  return Eigen::Map<const Eigen::VectorXd>(theta.data(), static_cast<Eigen::Index>(theta.size()));
}

/// The reference: each joint swings from the start pose and back, (1 - cos) so that it starts
/// at rest there.
void reference(double t, int n, Vector& q, Vector& qd, Vector& qdd) {
  for (int j = 0; j < n; ++j) {
    const double a = 0.4 / (1.0 + 0.2 * j), w = 2.0 + 0.5 * j;  // [rad], [rad/s]
    q[j] = a * (1.0 - std::cos(w * t));
    qd[j] = a * w * std::sin(w * t);
    qdd[j] = a * w * w * std::cos(w * t);
  }
}

/// Runs the loop; returns the largest tracking error [rad] of each second.
std::array<double, 8> track(const sid::ChainModel& model, const sid::ArmDynamics& controller,
                            const Eigen::VectorXd& truth, bool computed_torque) {
  const int n = model.joints();
  Vector q = Vector::Zero(n), qd = Vector::Zero(n);  // the simulated arm, at rest at the start
  Vector q_ref(n), qd_ref(n), qdd_ref(n), v(n), g(n), c(n), f(n), tau(n);
  Matrix m(n, n);
  std::array<double, 8> worst{};
  const int ticks = static_cast<int>(std::lround(kDuration / kTick));
  for (int k = 0; k < ticks; ++k) {
    const double t = k * kTick;
    reference(t, n, q_ref, qd_ref, qdd_ref);
    // The controller sees only q and qd (a real one: the encoders and their filtered rate).
    const Vector e = q_ref - q, de = qd_ref - qd;
    controller.gravity(q, g);
    controller.friction(q, qd, f);
    if (computed_torque) {
      v = qdd_ref + kKp * e + kKd * de;
      controller.mass_matrix(q, m);
      controller.coriolis(q, qd, c);
      tau.noalias() = m * v;
      tau += c + g + f;
      // The same torque in one O(n) pass, which a loop that needs no M should call:
      // controller.inverse_dynamics(q, qd, v, tau).
    } else {
      // Gains in [1/s^2] need an inertia to become torques: M's diagonal, frozen at the start.
      if (k == 0) controller.mass_matrix(q, m);
      tau = g + f + m.diagonal().cwiseProduct(kKp * e + kKd * de);
    }
    auto& second = worst[static_cast<std::size_t>(t)];
    second = std::max(second, e.cwiseAbs().maxCoeff());

    // The arm: the true parameters, the torque held over the tick (a zero-order hold), and the
    // library's O(n) forward dynamics with semi-implicit Euler steps (the Coulomb tanh is stiff).
    const double h = kTick / kSubsteps;
    for (int s = 0; s < kSubsteps; ++s) {
      qd += h * model.forward_dynamics(truth, q, qd, tau);
      q += h * qd;
    }
  }
  return worst;
}

}  // namespace

int main(int argc, char** argv) try {
  const std::string path = argc > 1 ? argv[1] : SID_EXAMPLE_DATA_DIR "/urdf/real/ur5_robot.urdf";
  const std::string base = argc > 3 ? argv[2] : "base_link", tip = argc > 3 ? argv[3] : "tool0";
  const sid::UrdfChain urdf = sid::chain_from_urdf(read_text(path), base, tip);
  const int n = urdf.chain.joints();
  const sid::Transmission direct(n);
  const sid::ChainModel model(urdf.chain, urdf.joint_names,
                              sid::drive_terms(sid::default_drive_term_kinds(), direct), direct);

  // The identified parameters: the fit's, or the URDF's own links and made-up drives.
  Eigen::VectorXd theta(model.parameters());
  const Eigen::Index links = model.rigid_body_parameters();
  theta.head(links) = urdf.theta.head(links);
  for (Eigen::Index i = 0; i < static_cast<Eigen::Index>(model.terms().size()); ++i) {
    const sid::DriveTerm& term = model.terms()[static_cast<std::size_t>(i)];
    const double size = 1.0 / (1.0 + term.index);  // drives get smaller towards the wrist
    // fv [N m s/rad], fc [N m], (fa), offset [N m], armature [kg m^2], (spring, Stribeck)
    const double value[] = {2.0, 3.0, 0.0, 0.5, 0.2, 0.0, 0.0};
    theta[links + i] = size * value[static_cast<int>(term.kind)];
  }
  if (argc > 4) theta = fitted_parameters(argv[4], model);
  const sid::ArmDynamics controller(model, theta);  // built once: the loop only reads it

  // The "real" arm: each link 4 % heavier or lighter (all ten parameters scaled, so still a
  // body) and drives with 10 % more friction and rotor inertia than identified.
  Eigen::VectorXd truth = theta;
  for (int i = 0; i < n; ++i)
    truth.segment<sid::kLinkParameters>(sid::kLinkParameters * i) *= i % 2 ? 0.96 : 1.04;
  truth.tail(truth.size() - links) *= 1.1;

  const std::array<double, 8> pd = track(model, controller, truth, false);
  const std::array<double, 8> ct = track(model, controller, truth, true);
  std::printf("%s, %d joints, %g Hz, Kp %g 1/s^2, Kd %g 1/s\n", path.c_str(), n, 1.0 / kTick, kKp,
              kKd);
  std::printf(
      "largest tracking error [rad] in each second:\n  second   gravity comp. + PD   "
      "computed torque\n");
  for (int s = 0; s < static_cast<int>(kDuration); ++s)
    std::printf("  %d        %.2e             %.2e\n", s + 1, pd[static_cast<std::size_t>(s)],
                ct[static_cast<std::size_t>(s)]);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "feedforward: %s\n", e.what());
  return 1;
}
