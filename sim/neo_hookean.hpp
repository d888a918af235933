// Stable Neo-Hookean (Smith, de Goes and Kim 2018, without the log term) on one linear
// tet: energy density, first Piola stress, its derivative dP/dF, the positive
// semi-definite projection of that derivative, and the tet's 12 x 12 Hessian. Used by the
// implicit integrator (implicit_step.hpp); Body uses the same formulas for its forces.
//
//   psi(F) = mu/2 (tr(F^T F) - 3) + lambda/2 (J - alpha)^2,  J = det F,  alpha = 1 + mu/lambda
//   P(F)   = mu F + lambda (J - alpha) cof(F)
//   dP/dF  = mu I9 + lambda g g^T + lambda (J - alpha) H_J,   g = vec(cof F), H_J = d2J/dF2
//
// vec() stacks the columns of a 3 x 3 matrix (Eigen's column-major order). Node order
// within a tet is the Tet's; a tet's 12 dofs are x0 y0 z0 x1 ... z3.
// Units: F dimensionless, mu and lambda in Pa, energies in J/m^3 (densities) or J.
#pragma once

#include <Eigen/Core>

namespace tc::sim {

using Matrix9d = Eigen::Matrix<double, 9, 9>;
using Matrix9x12d = Eigen::Matrix<double, 9, 12>;
using Matrix12d = Eigen::Matrix<double, 12, 12>;
using Vector12d = Eigen::Matrix<double, 12, 1>;

/// Cofactor matrix of F (= dJ/dF): columns f1 x f2, f2 x f0, f0 x f1.
Eigen::Matrix3d cofactor(const Eigen::Matrix3d& f);

/// Energy density psi(F), J/m^3, shifted so that psi(I) = 0.
double snh_energy_density(const Eigen::Matrix3d& f, double mu, double lambda);

/// First Piola-Kirchhoff stress P = dpsi/dF, Pa.
Eigen::Matrix3d snh_stress(const Eigen::Matrix3d& f, double mu, double lambda);

/// dP/dF as a 9 x 9 matrix on vec(F) (symmetric, indefinite in general), Pa.
Matrix9d snh_stress_derivative(const Eigen::Matrix3d& f, double mu, double lambda);

/// The nearest positive semi-definite matrix (Frobenius norm) to a symmetric 9 x 9 matrix:
/// eigen-decomposition, negative eigenvalues set to 0.
Matrix9d project_psd(const Matrix9d& a);

/// project_psd(snh_stress_derivative(F)) in closed form, ~5x cheaper: the analytic
/// eigensystem of stable Neo-Hookean (Smith, de Goes and Kim 2018/2019) from the
/// rotation-variant SVD F = U S V^T: three twist modes (eigenvalue mu + lambda (J - alpha)
/// s_k), three flip modes (mu - lambda (J - alpha) s_k) and three scaling modes (the
/// eigenvectors of d2psi/ds2), negative eigenvalues dropped.
Matrix9d snh_stress_derivative_psd(const Eigen::Matrix3d& f, double mu, double lambda);

/// dvec(F)/dx for F = Ds Dm^-1 (9 x 12; constant per tet). dm_inv: inverse rest edge matrix.
Matrix9x12d deformation_jacobian(const Eigen::Matrix3d& dm_inv);

/// Hessian of the tet's elastic energy V psi(F(x)) with respect to its 12 node
/// coordinates, J/m^2 (= N/m). `psd`: built from the projected dP/dF
/// (snh_stress_derivative_psd), so it is positive semi-definite (V D^T A D with A PSD);
/// otherwise the exact (indefinite) Hessian.
/// x: the tet's 4 node positions (3 x 4, metres); volume: rest volume, m^3.
Matrix12d snh_tet_hessian(const Eigen::Matrix<double, 3, 4>& x, const Eigen::Matrix3d& dm_inv,
                          double volume, double mu, double lambda, bool psd);

/// Elastic forces on the tet's 4 nodes, -d(V psi)/dx (12, newtons).
Vector12d snh_tet_forces(const Eigen::Matrix<double, 3, 4>& x, const Eigen::Matrix3d& dm_inv,
                         double volume, double mu, double lambda);

}  // namespace tc::sim
