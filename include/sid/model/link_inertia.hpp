#pragma once
/// @file
/// @brief A link's mass, centre of mass and inertia, their ten standard parameters (the form
/// the chain regressor is linear in), and whether a parameter set can belong to a real body.

#include <sid/model/serial_chain.hpp>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include <stdexcept>
#include <string>

namespace sid {

template <typename Scalar>
using LinkParameters = Eigen::Matrix<Scalar, 10, 1>;

/// @brief A rigid link in its own frame: mass [kg], centre of mass [m] and inertia about the
/// centre of mass [kg m^2], both in the link frame's axes (as CAD tools and URDF give them,
/// once URDF's inertial rotation is applied).
template <typename Scalar>
struct LinkInertia {
  Scalar mass = Scalar(0);
  Vector3<Scalar> com = Vector3<Scalar>::Zero();
  Matrix3<Scalar> inertia_com = Matrix3<Scalar>::Zero();
};

/// @brief [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]: the first moments m c and the inertia
/// about the frame's origin, I = I_c + m (|c|^2 1 - c c^T) (parallel axes).
template <typename Scalar>
LinkParameters<Scalar> standard_parameters(const LinkInertia<Scalar>& link) {
  const Vector3<Scalar>& c = link.com;
  const Matrix3<Scalar> i =
      link.inertia_com +
      link.mass * (c.squaredNorm() * Matrix3<Scalar>::Identity() - c * c.transpose());
  LinkParameters<Scalar> phi;
  phi << link.mass, link.mass * c[0], link.mass * c[1], link.mass * c[2], i(0, 0), i(0, 1), i(1, 1),
      i(0, 2), i(1, 2), i(2, 2);
  return phi;
}

/// @brief The inertia about the frame's origin, I = I_c + m (|c|² 1 − c cᵀ), as a matrix.
template <typename Scalar>
Matrix3<Scalar> inertia_about_origin(const LinkParameters<Scalar>& phi) {
  Matrix3<Scalar> i;
  i << phi[4], phi[5], phi[7], phi[5], phi[6], phi[8], phi[7], phi[8], phi[9];
  return i;
}

/// @brief The body of ten parameters: the inverse of standard_parameters.
/// @pre phi[0] (the mass) > 0.
template <typename Scalar>
LinkInertia<Scalar> link_inertia(const LinkParameters<Scalar>& phi) {
  LinkInertia<Scalar> link;
  link.mass = phi[0];
  link.com = phi.template segment<3>(1) / phi[0];
  const Vector3<Scalar>& c = link.com;
  link.inertia_com =
      inertia_about_origin(phi) -
      link.mass * (c.squaredNorm() * Matrix3<Scalar>::Identity() - c * c.transpose());
  return link;
}

/// @brief The pose of a frame's parent in the frame itself: x_child = Rᵀ x_parent − Rᵀ p for
/// pose (R, p), x_parent = R x_child + p.
template <typename Scalar>
FramePose<Scalar> inverse_pose(const FramePose<Scalar>& pose) {
  FramePose<Scalar> inverse;
  inverse.rotation = pose.rotation.transpose();
  inverse.translation = -(inverse.rotation * pose.translation);
  return inverse;
}

/// @brief A body given in a child frame, expressed in its parent, where the child frame has pose
/// (R, p) (x_parent = R x_child + p): the centre of mass R c + p, the inertia about it R I_c Rᵀ.
template <typename Scalar>
LinkInertia<Scalar> expressed_in_parent(const LinkInertia<Scalar>& body,
                                        const FramePose<Scalar>& child_in_parent) {
  LinkInertia<Scalar> moved;
  moved.mass = body.mass;
  moved.com = child_in_parent.rotation * body.com + child_in_parent.translation;
  moved.inertia_com =
      child_in_parent.rotation * body.inertia_com * child_in_parent.rotation.transpose();
  return moved;
}

/// @brief The ten standard parameters under the same change of frame, linear in phi, so that it
/// holds for any phi, a massless or an impossible one too (an estimate, a covariance's columns):
/// h' = R h + m p and, about the parent's origin, with h_r = R h,
/// I' = R I Rᵀ + 2 (h_r·p) 1 − p h_rᵀ − h_r pᵀ + m (|p|² 1 − p pᵀ)
/// (I' = ∫ −[R x + p]ₓ² dm expanded, [·]ₓ the cross-product matrix).
template <typename Scalar>
LinkParameters<Scalar> expressed_in_parent(const LinkParameters<Scalar>& phi,
                                           const FramePose<Scalar>& child_in_parent) {
  const Matrix3<Scalar>& r = child_in_parent.rotation;
  const Vector3<Scalar>& p = child_in_parent.translation;
  const Scalar m = phi[0];
  const Vector3<Scalar> h = r * phi.template segment<3>(1);
  const Matrix3<Scalar> one = Matrix3<Scalar>::Identity();
  const Matrix3<Scalar> i = r * inertia_about_origin(phi) * r.transpose() +
                            Scalar(2) * h.dot(p) * one - p * h.transpose() - h * p.transpose() +
                            m * (p.squaredNorm() * one - p * p.transpose());
  LinkParameters<Scalar> out;
  out << m, h + m * p, i(0, 0), i(0, 1), i(1, 1), i(0, 2), i(1, 2), i(2, 2);
  return out;
}

/// @brief The pseudo-inertia [[tr(I)/2 · 1 − I, m c], [m cᵀ, m]] (I about the frame's origin),
/// linear in the ten parameters; they are a real body exactly when it is positive semidefinite
/// (Wensing, Kim & Slotine 2018).
template <typename Scalar>
Eigen::Matrix<Scalar, 4, 4> pseudo_inertia(const LinkParameters<Scalar>& phi) {
  const Matrix3<Scalar> i = inertia_about_origin(phi);
  Eigen::Matrix<Scalar, 4, 4> j;
  j.template topLeftCorner<3, 3>() = Scalar(0.5) * i.trace() * Matrix3<Scalar>::Identity() - i;
  j.template topRightCorner<3, 1>() = phi.template segment<3>(1);
  j.template bottomLeftCorner<1, 3>() = phi.template segment<3>(1).transpose();
  j(3, 3) = phi[0];
  return j;
}

/// @brief Why ten parameters cannot be a real body, or an empty string if they can: the mass
/// must be positive and the inertia about the centre of mass positive definite with principal
/// moments that satisfy the triangle inequality (each at most the sum of the other two).
/// @param tolerance slack on the inertia tests, relative to the largest principal moment.
template <typename Scalar>
std::string link_inconsistency(const LinkParameters<Scalar>& phi,
                               Scalar tolerance = Scalar(1e-12)) {
  if (!phi.allFinite()) return "a parameter is not finite";
  if (!(phi[0] > Scalar(0))) return "the mass is not positive";
  const Vector3<Scalar> moments =
      Eigen::SelfAdjointEigenSolver<Matrix3<Scalar>>(link_inertia(phi).inertia_com).eigenvalues();
  const Scalar slack = tolerance * moments.cwiseAbs().maxCoeff();
  if (!(moments[0] > slack)) return "the inertia about the centre of mass is not positive definite";
  if (moments[2] > moments[0] + moments[1] + slack)
    return "the principal moments break the triangle inequality";
  return {};
}

}  // namespace sid
