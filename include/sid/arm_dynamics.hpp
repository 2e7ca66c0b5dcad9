#pragma once
/// @file
/// @brief sid::ArmDynamics: an identified arm's dynamics for a control loop: inverse dynamics
/// by the recursive Newton-Euler algorithm with every drive term, gravity, the mass matrix, the
/// Coriolis and centrifugal torques, and the generalized momentum a collision observer needs.
///
/// Built once from a sid::ChainModel and its parameters (a physically consistent fit); every
/// call after that is noexcept and allocates nothing (the state lives on the stack, at most
/// kMaxChainJoints joints). The identification's regressor gives the same torques, Y(q, qd, qdd)
/// theta, in O(n) too but with ten times the arithmetic; this is the form to run at 1 kHz.

#include <sid/model/chain_dynamics.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/link_inertia.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief The dynamics of a serial chain with identified links and drives:
/// tau = M(q) qdd + c(q, qd) + g(q) + f(q, qd), where M holds the rotors' inertia (armature
/// terms), c the Coriolis and centrifugal torques, g what holds the arm still (gravity, the
/// drives' offsets and springs) and f friction (the drive terms that vanish at rest).
///
/// Vectors are passed as Eigen::Ref of contiguous storage (Eigen::VectorXd or
/// sid::ChainVector<double>, sized joints()): nothing is copied or allocated. Sizes are a
/// precondition of the noexcept calls (checked by eigen_assert in debug builds).
/// Class invariant: every link's parameters are a real body.
class ArmDynamics {
 public:
  using Vector = ChainVector<double>;
  using Matrix = ChainMatrix<double>;
  using In = Eigen::Ref<const Eigen::VectorXd>;
  using Out = Eigen::Ref<Eigen::VectorXd>;

  /// @param theta every parameter of model (model.parameters(): ten per link, then its drive
  ///        terms), e.g. a physically consistent fit.
  /// @throws std::invalid_argument if theta's size is not the model's, a value is not finite, a
  ///         link is not a real body or a rotor inertia is negative.
  ArmDynamics(const ChainModel& model, const In& theta)
      : chain_(model.chain()), n_(model.joints()), epsilon_(model.coulomb_epsilon()) {
    const std::string who = "sid::ArmDynamics: ";
    if (theta.size() != model.parameters())
      throw std::invalid_argument(who + "theta has " + std::to_string(theta.size()) +
                                  " values, the model " + std::to_string(model.parameters()));
    if (!theta.allFinite()) throw std::invalid_argument(who + "theta holds a value not finite");
    for (int i = 0; i < n_; ++i) {
      const LinkParameters<double> phi = theta.segment<kLinkParameters>(kLinkParameters * i);
      const std::string why = link_inconsistency(phi);
      if (!why.empty())
        throw std::invalid_argument(who + "link " + std::to_string(i + 1) +
                                    " is not a real body: " + why);
      auto& link = links_[static_cast<std::size_t>(i)];
      link.mass = phi[0];
      link.first_moment = phi.segment<3>(1);
      link.inertia = inertia_about_origin(phi);
      const JointAxis<double> axis = chain_.joint_axis(i);
      auto& s = axes_[static_cast<std::size_t>(i)];
      if (chain_.joint_type(i) == JointType::Prismatic) {
        s.angular.setZero();
        s.linear = axis.direction;
      } else {
        s.angular = axis.direction;
        s.linear = axis.point.cross(axis.direction);
      }
    }
    armature_.setZero(n_);
    Eigen::Index column = model.rigid_body_parameters();
    for (const DriveTerm& t : model.terms()) {
      const double value = theta[column++];
      Drive d{t, value, Vector::Zero(n_)};
      if (t.on_motor)
        d.direction = model.transmission().motor_direction(t.index).transpose();
      else
        d.direction[t.index] = 1.0;
      if (t.kind == DriveTermKind::Armature) {
        if (!(value >= 0.0))
          throw std::invalid_argument(who + "the rotor inertia of " +
                                      (t.on_motor ? "motor " : "joint ") +
                                      std::to_string(t.index + 1) + " is negative");
        if (t.on_motor)
          motor_rotors_.push_back(d);
        else
          armature_[t.index] += value;
      } else {
        drives_.push_back(d);
      }
    }
  }

  int joints() const noexcept { return n_; }

  /// @brief tau [N m or N] = M(q) qdd + c(q, qd) + g(q) + f(q, qd): the torque the drives give
  /// for the motion (q [rad or m], qd, qdd), as the identification's model predicts the logs.
  void inverse_dynamics(const In& q, const In& qd, const In& qdd, Out tau) const noexcept {
    check(q, qd, qdd, tau);
    newton_euler(q, &qd, &qdd, true, tau);
    add_rotors(qdd, tau);
    add_drives(q, qd, Drives::All, tau);
  }

  /// @brief g(q): the torque that holds the arm still at q: gravity, springs and offsets.
  void gravity(const In& q, Out tau) const noexcept {
    check(q, q, q, tau);
    newton_euler(q, nullptr, nullptr, true, tau);
    add_drives(q, q, Drives::AtRest, tau);
  }

  /// @brief c(q, qd) = C(q, qd) qd: the Coriolis and centrifugal torques of the links alone.
  void coriolis(const In& q, const In& qd, Out c) const noexcept {
    check(q, qd, qd, c);
    newton_euler(q, &qd, nullptr, false, c);
  }

  /// @brief f(q, qd): friction, the drive terms that vanish at rest (viscous, Coulomb and its
  /// asymmetry, Stribeck).
  void friction(const In& q, const In& qd, Out tau) const noexcept {
    check(q, qd, qd, tau);
    tau.setZero();
    add_drives(q, qd, Drives::Moving, tau);
  }

  /// @brief M(q) [kg m^2], with the rotors, by the composite-rigid-body algorithm (O(n^2)).
  /// @pre m is joints() x joints().
  void mass_matrix(const In& q, Eigen::Ref<Eigen::MatrixXd> m) const noexcept {
    eigen_assert(q.size() == n_ && m.rows() == n_ && m.cols() == n_);
    Poses pose;
    poses(q, pose);
    std::array<Body, kMaxChainJoints> composite;
    std::copy_n(links_.begin(), n_, composite.begin());
    for (int i = n_ - 1; i >= 0; --i) {
      if (i > 0) composite[k(i - 1)] += composite[k(i)].seen_from_parent(pose[k(i)]);
      Force f = composite[k(i)].times(axes_[k(i)]);
      m(i, i) = axes_[k(i)].dot(f) + armature_[i];
      for (int j = i; j > 0; --j) {
        f = f.to_parent(pose[k(j)]);
        m(j - 1, i) = m(i, j - 1) = axes_[k(j - 1)].dot(f);
      }
    }
    for (const Drive& r : motor_rotors_)
      m.noalias() += r.value * r.direction * r.direction.transpose();
  }

  /// @brief The generalized momentum p = M(q) qd and the torques beta(q, qd) = g(q) + f(q, qd)
  /// - C(q, qd)^T qd of the momentum's balance, dp/dt = tau + tau_ext - beta, in one O(n) pass:
  /// what a momentum observer needs, without the acceleration.
  void momentum(const In& q, const In& qd, Out p, Out beta) const noexcept {
    check(q, qd, qd, p);
    eigen_assert(beta.size() == n_);
    Poses pose;
    poses(q, pose);
    std::array<Motion, kMaxChainJoints> v;
    std::array<Force, kMaxChainJoints> h;
    Motion parent;
    for (int i = 0; i < n_; ++i) {
      v[k(i)] = parent.to_child(pose[k(i)]) + axes_[k(i)] * qd[i];
      h[k(i)] = links_[k(i)].times(v[k(i)]);
      parent = v[k(i)];
    }
    // C^T qd = dM/dt qd - C qd is the gradient of the kinetic energy, 1/2 qd^T dM/dq qd: joint
    // i turns every link after it, so d(v_j)/dq_i = v_j x s_i for them, and the subtree's
    // momentum H_i collects the rest.
    for (int i = n_ - 1; i >= 0; --i) {
      if (i + 1 < n_) h[k(i)] += h[k(i + 1)].to_parent(pose[k(i + 1)]);
      p[i] = axes_[k(i)].dot(h[k(i)]) + armature_[i] * qd[i];
      beta[i] = -v[k(i)].cross(axes_[k(i)]).dot(h[k(i)]);
    }
    for (const Drive& r : motor_rotors_) p += r.value * r.direction * r.direction.dot(qd);
    Vector g(n_);
    newton_euler(pose, nullptr, nullptr, true, g);  // the same poses: computed once
    beta += g;
    add_drives(q, qd, Drives::All, beta);
  }

 private:
  static std::size_t k(int i) noexcept { return static_cast<std::size_t>(i); }

  using Pose = FramePose<double>;
  using V3 = Vector3<double>;

  /// A spatial force (moment about the frame's origin, force) in a link's frame.
  struct Force {
    V3 moment = V3::Zero(), force = V3::Zero();
    Force& operator+=(const Force& o) {
      moment += o.moment;
      force += o.force;
      return *this;
    }
    /// The same force in the parent frame, for this frame's pose x in it.
    Force to_parent(const Pose& x) const {
      const V3 f = x.rotation * force;
      return {x.rotation * moment + x.translation.cross(f), f};
    }
  };

  /// A spatial motion (angular, linear of the frame's origin) in a link's frame.
  struct Motion {
    V3 angular = V3::Zero(), linear = V3::Zero();
    Motion operator+(const Motion& o) const { return {angular + o.angular, linear + o.linear}; }
    Motion operator*(double s) const { return {angular * s, linear * s}; }
    /// The motion seen in the child frame at pose (the child in this one's frame).
    Motion to_child(const Pose& x) const {
      const auto rt = x.rotation.transpose();
      return {rt * angular, rt * (linear + angular.cross(x.translation))};
    }
    Motion cross(const Motion& m) const {
      return {angular.cross(m.angular), angular.cross(m.linear) + linear.cross(m.angular)};
    }
    /// The power of a force along this motion.
    double dot(const Force& f) const { return angular.dot(f.moment) + linear.dot(f.force); }
  };

  /// Ten parameters of a body: mass, first moment m c, inertia about the frame's origin.
  struct Body {
    double mass = 0.0;
    V3 first_moment = V3::Zero();
    Matrix3<double> inertia = Matrix3<double>::Zero();
    Force times(const Motion& v) const {
      return {inertia * v.angular + first_moment.cross(v.linear),
              mass * v.linear - first_moment.cross(v.angular)};
    }
    Body& operator+=(const Body& o) {
      mass += o.mass;
      first_moment += o.first_moment;
      inertia += o.inertia;
      return *this;
    }
    /// The same body in the parent frame (parallel axes from this frame's origin to the
    /// parent's), for this frame's pose x in it.
    Body seen_from_parent(const Pose& x) const {
      const V3 h = x.rotation * first_moment, p = x.translation;
      Body b;
      b.mass = mass;
      b.first_moment = h + mass * p;
      b.inertia = x.rotation * inertia * x.rotation.transpose();
      const Matrix3<double> hp = h * p.transpose();
      b.inertia.diagonal().array() += 2.0 * h.dot(p) + mass * p.squaredNorm();
      b.inertia -= hp + hp.transpose() + mass * p * p.transpose();
      return b;
    }
  };

  /// A joint's motion subspace in its link's frame.
  using Axis = Motion;

  /// A drive term with its value; direction: the joint rates it acts along (a unit vector for
  /// a joint's own term, the motor's combination for a coupled motor's).
  struct Drive {
    DriveTerm term;
    double value = 0.0;
    Vector direction;
  };

  void check(const In& a, const In& b, const In& c, const Out& out) const noexcept {
    eigen_assert(a.size() == n_ && b.size() == n_ && c.size() == n_ && out.size() == n_);
    (void)a, (void)b, (void)c, (void)out;
  }

  using Poses = std::array<Pose, kMaxChainJoints>;

  /// Each link frame's pose in its parent's at q.
  void poses(const In& q, Poses& pose) const noexcept {
    for (int i = 0; i < n_; ++i) pose[k(i)] = chain_.link_pose(i, q[i]);
  }

  /// The links' torques: M_links qdd + c (qd, qdd null: zero), plus g with gravity.
  void newton_euler(const In& q, const In* qd, const In* qdd, bool with_gravity,
                    Out tau) const noexcept {
    Poses pose;
    poses(q, pose);
    newton_euler(pose, qd, qdd, with_gravity, tau);
  }

  void newton_euler(const Poses& pose, const In* qd, const In* qdd, bool with_gravity,
                    Out tau) const noexcept {
    std::array<Force, kMaxChainJoints> f;
    Motion v, a;
    if (with_gravity) a.linear = -chain_.gravity();  // the base accelerates up
    for (int i = 0; i < n_; ++i) {
      const Axis& s = axes_[k(i)];
      a = a.to_child(pose[k(i)]);
      if (qd) {
        const Motion joint_motion = s * (*qd)[i];
        v = v.to_child(pose[k(i)]) + joint_motion;
        a = a + v.cross(joint_motion);
      }
      if (qdd) a = a + s * (*qdd)[i];
      f[k(i)] = links_[k(i)].times(a);
      if (qd) {
        const Force h = links_[k(i)].times(v);  // v x* (I v)
        f[k(i)].moment += v.angular.cross(h.moment) + v.linear.cross(h.force);
        f[k(i)].force += v.angular.cross(h.force);
      }
    }
    for (int i = n_ - 1; i >= 0; --i) {
      tau[i] = axes_[k(i)].dot(f[k(i)]);
      if (i > 0) f[k(i - 1)] += f[k(i)].to_parent(pose[k(i)]);
    }
  }

  void add_rotors(const In& qdd, Out tau) const noexcept {
    tau += armature_.cwiseProduct(qdd);
    for (const Drive& r : motor_rotors_) tau += r.value * r.direction * r.direction.dot(qdd);
  }

  enum class Drives { All, AtRest, Moving };

  /// Adds the drive terms that are not inertia, or those that act at rest (offsets, springs),
  /// or the others (friction).
  void add_drives(const In& q, const In& qd, Drives which, Out tau) const noexcept {
    for (const Drive& d : drives_) {
      const bool at_rest =
          d.term.kind == DriveTermKind::Offset || d.term.kind == DriveTermKind::Spring;
      if ((which == Drives::AtRest && !at_rest) || (which == Drives::Moving && at_rest)) continue;
      const int j = d.term.index;
      if (!d.term.on_motor) {
        tau[j] += d.value * drive_term_value(d.term, epsilon_, q[j], qd[j], 0.0);
        continue;
      }
      const double x = d.direction.dot(q), rate = d.direction.dot(qd);
      tau += (d.value * drive_term_value(d.term, epsilon_, x, rate, 0.0)) * d.direction;
    }
  }

  SerialChain<double> chain_;
  int n_;
  double epsilon_;
  std::array<Body, kMaxChainJoints> links_{};
  std::array<Axis, kMaxChainJoints> axes_{};
  Vector armature_;
  std::vector<Drive> drives_;        ///< every term but the rotors
  std::vector<Drive> motor_rotors_;  ///< coupled motors' rotor inertias
};

}  // namespace sid
