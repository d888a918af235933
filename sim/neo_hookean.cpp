#include "neo_hookean.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace tc::sim {
namespace {

/// [a]_x: the matrix with [a]_x b = a x b.
Eigen::Matrix3d cross_matrix(const Eigen::Vector3d& a) {
  Eigen::Matrix3d m;
  m << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return m;
}

Eigen::Matrix3d deformation_gradient(const Eigen::Matrix<double, 3, 4>& x,
                                     const Eigen::Matrix3d& dm_inv) {
  Eigen::Matrix3d ds;
  ds.col(0) = x.col(1) - x.col(0);
  ds.col(1) = x.col(2) - x.col(0);
  ds.col(2) = x.col(3) - x.col(0);
  return ds * dm_inv;
}

}  // namespace

Eigen::Matrix3d cofactor(const Eigen::Matrix3d& f) {
  Eigen::Matrix3d c;
  c.col(0) = f.col(1).cross(f.col(2));
  c.col(1) = f.col(2).cross(f.col(0));
  c.col(2) = f.col(0).cross(f.col(1));
  return c;
}

double snh_energy_density(const Eigen::Matrix3d& f, double mu, double lambda) {
  const double alpha = 1.0 + mu / lambda;
  const double j = f.determinant();
  const double rest = 0.5 * lambda * (1.0 - alpha) * (1.0 - alpha);
  return 0.5 * mu * (f.squaredNorm() - 3.0) + 0.5 * lambda * (j - alpha) * (j - alpha) - rest;
}

Eigen::Matrix3d snh_stress(const Eigen::Matrix3d& f, double mu, double lambda) {
  const double alpha = 1.0 + mu / lambda;
  return mu * f + lambda * (f.determinant() - alpha) * cofactor(f);
}

Matrix9d snh_stress_derivative(const Eigen::Matrix3d& f, double mu, double lambda) {
  const double alpha = 1.0 + mu / lambda;
  const double j = f.determinant();
  const Eigen::Matrix3d cof = cofactor(f);
  Eigen::Matrix<double, 9, 1> g;
  g << cof.col(0), cof.col(1), cof.col(2);
  // H_J = d vec(cof F) / d vec(F): g0 = f1 x f2, g1 = f2 x f0, g2 = f0 x f1, and
  // d(a x b)/da = -[b]_x, d(a x b)/db = [a]_x.
  Matrix9d hj = Matrix9d::Zero();
  const Eigen::Matrix3d c0 = cross_matrix(f.col(0));
  const Eigen::Matrix3d c1 = cross_matrix(f.col(1));
  const Eigen::Matrix3d c2 = cross_matrix(f.col(2));
  hj.block<3, 3>(0, 3) = -c2;
  hj.block<3, 3>(0, 6) = c1;
  hj.block<3, 3>(3, 0) = c2;
  hj.block<3, 3>(3, 6) = -c0;
  hj.block<3, 3>(6, 0) = -c1;
  hj.block<3, 3>(6, 3) = c0;
  Matrix9d a = mu * Matrix9d::Identity() + lambda * g * g.transpose() + lambda * (j - alpha) * hj;
  return a;
}

Matrix9d project_psd(const Matrix9d& a) {
  // Most tets of a simulation are PSD already: a Cholesky factorisation of a + eps I
  // (eps = 1e-12 of the diagonal's scale) proves it for ~1/10 of an eigen-decomposition.
  const double eps = 1e-12 * a.diagonal().cwiseAbs().maxCoeff();
  if (Eigen::LLT<Matrix9d> llt(a + eps * Matrix9d::Identity()); llt.info() == Eigen::Success)
    return a;
  const Eigen::SelfAdjointEigenSolver<Matrix9d> es(0.5 * (a + a.transpose()));
  const Eigen::Matrix<double, 9, 1> clamped = es.eigenvalues().cwiseMax(0.0);
  if (es.eigenvalues().minCoeff() >= 0.0) return a;
  return es.eigenvectors() * clamped.asDiagonal() * es.eigenvectors().transpose();
}

Matrix9d snh_stress_derivative_psd(const Eigen::Matrix3d& f, double mu, double lambda) {
  // Rotation-variant SVD F = U diag(s) V^T with det U = det V = 1 (s2 < 0: inverted).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(f, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  Eigen::Matrix3d v = svd.matrixV();
  Eigen::Vector3d s = svd.singularValues();
  if (u.determinant() < 0.0) {
    u.col(2) *= -1.0;
    s(2) *= -1.0;
  }
  if (v.determinant() < 0.0) {
    v.col(2) *= -1.0;
    s(2) *= -1.0;
  }
  const double alpha = 1.0 + mu / lambda;
  const double j = s(0) * s(1) * s(2);
  const double c = lambda * (j - alpha);
  Matrix9d out = Matrix9d::Zero();
  const auto add = [&](double eigenvalue, const Eigen::Matrix3d& q) {
    if (!(eigenvalue > 0.0)) return;
    const Eigen::Map<const Eigen::Matrix<double, 9, 1>> vq(q.data());
    out.noalias() += eigenvalue * vq * vq.transpose();
  };
  // Twist (U (e_i e_j^T - e_j e_i^T) V^T / sqrt 2) and flip (+) modes of each pair (i, j),
  // k the third axis: eigenvalues mu + c s_k and mu - c s_k.
  static constexpr int kPairs[3][3] = {{0, 1, 2}, {1, 2, 0}, {0, 2, 1}};
  const double r = 1.0 / std::sqrt(2.0);
  for (const auto& p : kPairs) {
    const int i = p[0], jj = p[1], k = p[2];
    const Eigen::Matrix3d a = u.col(i) * v.col(jj).transpose();
    const Eigen::Matrix3d b = u.col(jj) * v.col(i).transpose();
    add(mu + c * s(k), r * (a - b));
    add(mu - c * s(k), r * (a + b));
  }
  // Scaling modes U diag(w) V^T: w the eigenvectors of d2psi/ds2, with
  // d2psi/ds_i^2 = mu + lambda (s_j s_k)^2, d2psi/ds_i ds_j = lambda s_i s_j s_k^2 + c s_k.
  Eigen::Matrix3d hs;
  for (int i = 0; i < 3; ++i) {
    const int a = (i + 1) % 3, b = (i + 2) % 3;
    hs(i, i) = mu + lambda * (s(a) * s(b)) * (s(a) * s(b));
  }
  for (int i = 0; i < 3; ++i)
    for (int jn = i + 1; jn < 3; ++jn) {
      const int k = 3 - i - jn;
      hs(i, jn) = hs(jn, i) = lambda * s(i) * s(jn) * s(k) * s(k) + c * s(k);
    }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(hs);
  for (int m = 0; m < 3; ++m)
    add(es.eigenvalues()(m), u * es.eigenvectors().col(m).asDiagonal() * v.transpose());
  return out;
}

Matrix9x12d deformation_jacobian(const Eigen::Matrix3d& dm_inv) {
  // F_ab = sum_c Ds_ac Dminv_cb with Ds_ac = x_(c+1),a - x_0,a, so
  // dF_ab / dx_k,a = B_kb with B_(k>0),b = Dminv_(k-1),b and B_0,b = -sum_c Dminv_cb.
  Matrix9x12d d = Matrix9x12d::Zero();
  for (int b = 0; b < 3; ++b) {
    const double b0 = -(dm_inv(0, b) + dm_inv(1, b) + dm_inv(2, b));
    for (int a = 0; a < 3; ++a) {
      d(a + 3 * b, a) = b0;
      for (int k = 1; k < 4; ++k) d(a + 3 * b, 3 * k + a) = dm_inv(k - 1, b);
    }
  }
  return d;
}

Matrix12d snh_tet_hessian(const Eigen::Matrix<double, 3, 4>& x, const Eigen::Matrix3d& dm_inv,
                          double volume, double mu, double lambda, bool psd) {
  const Eigen::Matrix3d f = deformation_gradient(x, dm_inv);
  const Matrix9d a =
      psd ? snh_stress_derivative_psd(f, mu, lambda) : snh_stress_derivative(f, mu, lambda);
  // V D^T A D with D = deformation_jacobian(): D(r + 3b, 3k + r) = B(k, b), so the (k, l)
  // node block's entry (r, c) is sum_{b,d} B(k, b) A(r + 3b, c + 3d) B(l, d). Written out
  // (a dense 12x9x12 product costs ~4x more and goes through Eigen's GEMM path).
  Eigen::Matrix<double, 4, 3> bm;
  bm.bottomRows<3>() = dm_inv;
  bm.row(0) = -dm_inv.colwise().sum();
  Matrix12d h;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      Eigen::Matrix3d arc;
      for (int b = 0; b < 3; ++b)
        for (int d = 0; d < 3; ++d) arc(b, d) = a(r + 3 * b, c + 3 * d);
      const Eigen::Matrix4d blk = volume * bm * arc * bm.transpose();
      for (int k = 0; k < 4; ++k)
        for (int l = 0; l < 4; ++l) h(3 * k + r, 3 * l + c) = blk(k, l);
    }
  return 0.5 * (h + h.transpose());
}

Vector12d snh_tet_forces(const Eigen::Matrix<double, 3, 4>& x, const Eigen::Matrix3d& dm_inv,
                         double volume, double mu, double lambda) {
  const Eigen::Matrix3d p = snh_stress(deformation_gradient(x, dm_inv), mu, lambda);
  const Eigen::Map<const Eigen::Matrix<double, 9, 1>> vp(p.data());
  return -volume * deformation_jacobian(dm_inv).transpose() * vp;
}

}  // namespace tc::sim
