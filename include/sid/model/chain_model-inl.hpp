#pragma once
// Definitions of sid/model/chain_model.hpp (see sid/config.hpp): the members whose bodies
// instantiate the model, the regressor and the articulated-body algorithm, several seconds of
// front end in every file that includes the header.

#include <sid/model/chain_model.hpp>

namespace sid {

SID_INLINE ChainModel::ChainModel(SerialChain<double> chain, std::vector<std::string> joint_names,
                                  std::vector<DriveTerm> terms, Transmission transmission,
                                  double coulomb_epsilon)
    : chain_(std::move(chain)),
      joint_names_(std::move(joint_names)),
      terms_(std::move(terms)),
      transmission_(std::move(transmission)),
      epsilon_(coulomb_epsilon),
      model_(chain_.joints()) {
  const std::string who = "sid::ChainModel: ";
  const int n = chain_.joints();
  if (joint_names_.empty())
    for (int j = 1; j <= n; ++j) joint_names_.push_back(std::to_string(j));
  if (static_cast<int>(joint_names_.size()) != n || transmission_.joints() != n)
    throw std::invalid_argument(who + "the chain has " + std::to_string(n) + " joints, the names " +
                                std::to_string(joint_names_.size()) + ", the transmission " +
                                std::to_string(transmission_.joints()));
  if (!(epsilon_ >= 0.0) || !std::isfinite(epsilon_))
    throw std::invalid_argument(who + "coulomb_epsilon must be finite and >= 0");
  for (std::size_t a = 0; a < terms_.size(); ++a) {
    const DriveTerm& t = terms_[a];
    if (t.kind == DriveTermKind::Stribeck && !(t.velocity > 0.0 && std::isfinite(t.velocity)))
      throw std::invalid_argument(who + "the Stribeck term of " + term_place(t) +
                                  " needs a finite velocity > 0");
    if (t.index < 0 || t.index >= n)
      throw std::invalid_argument(who + "a " + drive_term_keyword(t.kind) + " term is on joint " +
                                  std::to_string(t.index + 1) + " of " + std::to_string(n));
    for (std::size_t b = 0; b < a; ++b)
      if (same_term(terms_[b], t))
        throw std::invalid_argument(who + "the " + drive_term_keyword(t.kind) + " term of " +
                                    term_place(t) + " is given twice");
  }
  directions_.resize(n, n);
  for (int m = 0; m < n; ++m) directions_.row(m) = transmission_.motor_direction(m);
  model_.add(rigid_body_term());
  for (const DriveTerm& t : terms_) model_.add(drive_term(t));
  names_ = model_.parameter_names();
}

SID_INLINE ChainModel::Vector ChainModel::forward_dynamics(
    const Eigen::Ref<const Eigen::VectorXd>& theta, const Vector& q, const Vector& qd,
    const Vector& tau) const {
  const int n = joints();
  if (theta.size() != parameters() || q.size() != n || qd.size() != n || tau.size() != n)
    throw std::invalid_argument(
        "sid::ChainModel::forward_dynamics: sizes do not match the "
        "model's " +
        std::to_string(n) + " joints and " + std::to_string(parameters()) + " parameters");
  Vector armature = Vector::Zero(n), applied = tau;
  JointMatrix<double, Eigen::Dynamic> motors(n, 0);  // directions of coupled rotors
  JointVector<double, Eigen::Dynamic> motor_inertia(0);
  Eigen::Index column = rigid_body_parameters();
  for (const DriveTerm& t : terms_) {
    const double value = theta[column++];
    const bool rotor = t.kind == DriveTermKind::Armature;
    if (!t.on_motor) {
      if (rotor)
        armature[t.index] += value;
      else
        applied[t.index] -= value * drive_term_value(t, epsilon_, q[t.index], qd[t.index], 0.0);
    } else if (!rotor) {
      const double angle = directions_.row(t.index).dot(q);
      const double rate = directions_.row(t.index).dot(qd);
      applied -= directions_.row(t.index).transpose() *
                 (value * drive_term_value(t, epsilon_, angle, rate, 0.0));
    } else if (value != 0.0) {
      const Eigen::Index m = motors.cols();
      motors.conservativeResize(n, m + 1);
      motors.col(m) = directions_.row(t.index).transpose();
      motor_inertia.conservativeResize(m + 1);
      motor_inertia[m] = value;
    }
  }
  const auto links = theta.head(rigid_body_parameters());
  Vector qdd = detail::articulated_body_unchecked(chain_, links, armature, q, qd, applied, true);
  if (motors.cols() == 0 || !qdd.allFinite()) return qdd;
  // (M + U C U^T)^-1 r = x - Y (C^-1 + U^T Y)^-1 U^T x, x = M^-1 r, Y = M^-1 U.
  const Eigen::Index k = motors.cols();
  JointMatrix<double, Eigen::Dynamic> y(n, k), small(k, k);
  for (Eigen::Index m = 0; m < k; ++m) {
    const Vector direction = motors.col(m);
    y.col(m) = detail::articulated_body_unchecked(chain_, links, armature, q, qd, direction, false);
  }
  small = motors.transpose() * y;
  small.diagonal() += motor_inertia.cwiseInverse();
  const Vector correction = small.partialPivLu().solve(Vector(motors.transpose() * qdd));
  return qdd - y * correction;
}

SID_INLINE ChainModel::ModelTerm ChainModel::rigid_body_term() const {
  std::vector<std::string> names = chain_parameter_names(joints());
  names.resize(static_cast<std::size_t>(rigid_body_parameters()));
  return {"rigid_body", std::move(names),
          [chain = chain_](const Vector& q, const Vector& qd, const Vector& qdd,
                           RegressorView<double, Eigen::Dynamic> out) {
            detail::chain_link_columns_unchecked(chain, q, qd, qdd, out);
          }};
}

SID_INLINE ChainModel::ModelTerm ChainModel::drive_term(const DriveTerm& t) const {
  const std::string name = term_name(t);
  if (!t.on_motor)
    return {name,
            {name},
            [t, epsilon = epsilon_](const Vector& q, const Vector& qd, const Vector& qdd,
                                    RegressorView<double, Eigen::Dynamic> out) {
              out.setZero();
              out(t.index, 0) = drive_term_value(t, epsilon, q[t.index], qd[t.index], qdd[t.index]);
            }};
  // The motor turns with direction . qd; its torque reaches every joint it turns.
  const Eigen::VectorXd direction = directions_.row(t.index).transpose();
  return {name,
          {name},
          [t, epsilon = epsilon_, direction](const Vector& q, const Vector& qd, const Vector& qdd,
                                             RegressorView<double, Eigen::Dynamic> out) {
            out.col(0) = direction * drive_term_value(t, epsilon, direction.dot(q),
                                                      direction.dot(qd), direction.dot(qdd));
          }};
}

}  // namespace sid
