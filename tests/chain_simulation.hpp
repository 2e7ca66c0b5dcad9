#pragma once
// Test-only: a simulated three-joint arm with drives, for the chain identification's tests.

#include <sid/model/chain_model.hpp>
#include <sid/model/link_inertia.hpp>
#include <sid/trajectory.hpp>

#include <cmath>
#include <random>
#include <vector>

namespace sid_test {

/// A three-joint arm (standard DH) with drives: its true parameters and a run on a jittered
/// 1 kHz grid whose torques are exact.
struct SimulatedArm {
  sid::ChainModel model;
  Eigen::VectorXd theta;

  static sid::ChainModel make_model() {
    const std::vector<sid::DhJoint<double>> dh = {
        {0.0, M_PI / 2, 0.4, 0.0}, {0.5, 0.0, 0.0, 0.0}, {0.4, 0.0, 0.0, 0.0}};
    const sid::Transmission t(3);
    return sid::ChainModel(sid::SerialChain<double>(sid::DhConvention::Standard, dh),
                           {"a", "b", "c"}, sid::drive_terms(sid::default_drive_term_kinds(), t), t,
                           0.02);
  }

  SimulatedArm() : model(make_model()), theta(model.parameters()) {
    const double mass[3] = {4.0, 3.0, 2.0};
    for (int i = 0; i < 3; ++i) {
      sid::LinkInertia<double> link;
      link.mass = mass[i];
      link.com = sid::Vector3<double>(-0.2 + 0.05 * i, 0.02, 0.01 * i);
      link.inertia_com = sid::Vector3<double>(0.02, 0.05, 0.04 + 0.01 * i).asDiagonal();
      theta.segment<10>(10 * i) = sid::standard_parameters(link);
    }
    // fv, fc, offset, armature per joint.
    theta.tail(12) << 1.5, 2.0, 0.3, 0.2, 1.0, 1.2, -0.2, 0.1, 0.5, 0.6, 0.1, 0.05;
  }

  /// torque_delay [s]: the torque logged at t is the one at t − torque_delay.
  sid::ChainTrajectory<double> run(double duration, unsigned seed, double torque_noise,
                                   double torque_delay = 0.0) const {
    std::mt19937 g(seed);
    std::uniform_real_distribution<double> jitter(-0.3e-3, 0.3e-3);
    std::normal_distribution<double> noise(0.0, torque_noise);
    const auto n = static_cast<Eigen::Index>(duration * 1000.0);
    sid::ChainTrajectory<double> r;
    r.t.resize(n);
    r.q.resize(n, 3);
    r.tau.resize(n, 3);
    Eigen::MatrixXd y(3, model.parameters());
    Eigen::Vector3d q, qd, qdd;
    const auto state_at = [&](double t) {
      for (int j = 0; j < 3; ++j) {  // two harmonics per joint
        q[j] = qd[j] = qdd[j] = 0.0;
        for (int h = 1; h <= 2; ++h) {
          const double w = 2.0 * M_PI * (0.3 + 0.17 * j) * h, a = 0.8 / h, phase = 0.7 * j + h;
          q[j] += a * std::sin(w * t + phase);
          qd[j] += a * w * std::cos(w * t + phase);
          qdd[j] -= a * w * w * std::sin(w * t + phase);
        }
      }
    };
    for (Eigen::Index k = 0; k < n; ++k) {
      const double t = 1e-3 * static_cast<double>(k) + (k > 0 ? jitter(g) : 0.0);
      state_at(t);
      r.t[k] = t;
      r.q.row(k) = q.transpose();
      if (torque_delay != 0.0) state_at(t - torque_delay);
      model.regressor(q, qd, qdd, y);
      r.tau.row(k) = (y * theta).transpose();
      for (int j = 0; j < 3; ++j) r.tau(k, j) += noise(g);
    }
    return r;
  }
};

}  // namespace sid_test
