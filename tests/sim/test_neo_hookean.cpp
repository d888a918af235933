// Stable Neo-Hookean on one tet: the stress is the derivative of the energy, the 12x12
// Hessian is the derivative of the forces (central differences, stretched, compressed,
// sheared, nearly flat and inverted tets), the PSD projection leaves PSD matrices alone
// and makes indefinite ones PSD, and the projected body Hessian is PSD.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "body.hpp"
#include "implicit_step.hpp"
#include "neo_hookean.hpp"
#include "test_meshes.hpp"

namespace tc::sim {
namespace {

constexpr double kMu = 1.1e5;
constexpr double kLambda = 3.6e5;

/// A rest tet (unit right-angle corner, scaled) and a deformation of it.
struct Case {
  const char* name;
  Eigen::Matrix3d f;  ///< applied to the rest shape
};

std::vector<Case> cases() {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  Eigen::Matrix3d random = Eigen::Matrix3d::Identity();
  for (int i = 0; i < 9; ++i) random.data()[i] += u(rng);
  Eigen::Matrix3d inverted = Eigen::Matrix3d::Identity();
  inverted(2, 2) = -0.3;
  Eigen::Matrix3d flat = Eigen::Matrix3d::Identity();
  flat(2, 2) = 1e-3;
  Eigen::Matrix3d shear = Eigen::Matrix3d::Identity();
  shear(0, 1) = 0.8;
  return {{"rest", Eigen::Matrix3d::Identity()},
          {"stretched", Eigen::Vector3d(1.4, 1.0, 0.9).asDiagonal()},
          {"compressed", Eigen::Vector3d(0.6, 0.7, 0.8).asDiagonal()},
          {"sheared", shear},
          {"random", random},
          {"nearly_flat", flat},
          {"inverted", inverted}};
}

class NeoHookean : public ::testing::TestWithParam<Case> {
 protected:
  // Rest tet with edge lengths 0.1 m, not axis-aligned.
  Eigen::Matrix<double, 3, 4> rest() const {
    Eigen::Matrix<double, 3, 4> x;
    x << 0.0, 0.1, 0.02, 0.01, 0.0, 0.0, 0.09, 0.03, 0.0, 0.01, 0.0, 0.11;
    return x;
  }
  Eigen::Matrix3d dm_inv() const {
    const auto x = rest();
    Eigen::Matrix3d dm;
    dm << x.col(1) - x.col(0), x.col(2) - x.col(0), x.col(3) - x.col(0);
    return dm.inverse();
  }
  double volume() const {
    const auto x = rest();
    Eigen::Matrix3d dm;
    dm << x.col(1) - x.col(0), x.col(2) - x.col(0), x.col(3) - x.col(0);
    return dm.determinant() / 6.0;
  }
  Eigen::Matrix<double, 3, 4> deformed() const { return GetParam().f * rest(); }
};

TEST_P(NeoHookean, StressIsTheEnergyDerivative) {
  const Eigen::Matrix3d f = GetParam().f;
  const Eigen::Matrix3d p = snh_stress(f, kMu, kLambda);
  const double eps = 1e-6;
  for (int i = 0; i < 9; ++i) {
    Eigen::Matrix3d fp = f, fm = f;
    fp.data()[i] += eps;
    fm.data()[i] -= eps;
    const double fd =
        (snh_energy_density(fp, kMu, kLambda) - snh_energy_density(fm, kMu, kLambda)) / (2 * eps);
    // Round-off of the differenced energy (~1e5 Pa * 1e-16 / eps) bounds the tolerance.
    EXPECT_NEAR(p.data()[i], fd, 1e-8 * (kMu + kLambda) + 1e-6 * std::abs(fd)) << i;
  }
}

TEST_P(NeoHookean, HessianMatchesFiniteDifferencesOfTheForces) {
  const auto x = deformed();
  const Matrix12d hess = snh_tet_hessian(x, dm_inv(), volume(), kMu, kLambda, false);
  const double eps = 1e-7;  // metres, on 0.1 m edges
  Matrix12d fd;
  for (int k = 0; k < 12; ++k) {
    Eigen::Matrix<double, 3, 4> xp = x, xm = x;
    xp.data()[k] += eps;
    xm.data()[k] -= eps;
    // H = d2E/dx2 = -df/dx.
    fd.col(k) = -(snh_tet_forces(xp, dm_inv(), volume(), kMu, kLambda) -
                  snh_tet_forces(xm, dm_inv(), volume(), kMu, kLambda)) /
                (2 * eps);
  }
  const double scale = hess.cwiseAbs().maxCoeff();
  EXPECT_LT((hess - fd).cwiseAbs().maxCoeff(), 1e-6 * scale) << GetParam().name;
  EXPECT_LT((hess - hess.transpose()).cwiseAbs().maxCoeff(), 1e-12 * scale);
}

TEST_P(NeoHookean, ProjectedHessianIsPsdAndNeverStiffensAPsdOne) {
  const auto x = deformed();
  const Matrix12d exact = snh_tet_hessian(x, dm_inv(), volume(), kMu, kLambda, false);
  const Matrix12d psd = snh_tet_hessian(x, dm_inv(), volume(), kMu, kLambda, true);
  const double scale = exact.cwiseAbs().maxCoeff();
  const Eigen::SelfAdjointEigenSolver<Matrix12d> ee(exact);
  const Eigen::SelfAdjointEigenSolver<Matrix12d> ep(psd);
  EXPECT_GE(ep.eigenvalues().minCoeff(), -1e-9 * scale) << GetParam().name;
  // Six rigid modes (translation, rotation) stay in the null space at rest... and
  // translations always: the projected Hessian has no net force for a translation.
  for (int axis = 0; axis < 3; ++axis) {
    Vector12d t = Vector12d::Zero();
    for (int k = 0; k < 4; ++k) t(3 * k + axis) = 1.0;
    EXPECT_LT((psd * t).norm(), 1e-9 * scale);
  }
  if (ee.eigenvalues().minCoeff() >= -1e-9 * scale) {
    EXPECT_LT((psd - exact).cwiseAbs().maxCoeff(), 1e-9 * scale) << "PSD already: unchanged";
  }
}

TEST_P(NeoHookean, AnalyticProjectionEqualsTheNumericalOne) {
  const Eigen::Matrix3d f = GetParam().f;
  const Matrix9d exact = snh_stress_derivative(f, kMu, kLambda);
  const Matrix9d numeric = project_psd(exact);
  const Matrix9d analytic = snh_stress_derivative_psd(f, kMu, kLambda);
  const double scale = exact.cwiseAbs().maxCoeff();
  EXPECT_LT((analytic - numeric).cwiseAbs().maxCoeff(), 1e-9 * scale) << GetParam().name;
}

INSTANTIATE_TEST_SUITE_P(Deformations, NeoHookean, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<Case>& p) {
                           return std::string(p.param.name);
                         });

TEST(NeoHookeanProjection, AnalyticEqualsNumericalOverRandomDeformations) {
  // 200 seeded F: mild to strong, a quarter of them inverted, some near-repeated singular
  // values (the SVD's degenerate case).
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  int indefinite = 0;
  for (int n = 0; n < 200; ++n) {
    Eigen::Matrix3d f = Eigen::Matrix3d::Identity();
    const double amount = (n % 4 == 0) ? 1e-4 : 1.0;
    for (int i = 0; i < 9; ++i) f.data()[i] += amount * u(rng);
    if (n % 4 == 1) f.col(2) *= -1.0;
    const Matrix9d exact = snh_stress_derivative(f, kMu, kLambda);
    const Matrix9d numeric = project_psd(exact);
    const Matrix9d analytic = snh_stress_derivative_psd(f, kMu, kLambda);
    const double scale = exact.cwiseAbs().maxCoeff();
    EXPECT_LT((analytic - numeric).cwiseAbs().maxCoeff(), 1e-9 * scale) << "case " << n;
    indefinite +=
        Eigen::SelfAdjointEigenSolver<Matrix9d>(exact).eigenvalues().minCoeff() < -1e-9 * scale;
  }
  EXPECT_GT(indefinite, 50) << "the sweep must exercise the projection";
}

TEST(NeoHookeanProjection, ClampsNegativeEigenvaluesOnly) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  Matrix9d q;
  for (int i = 0; i < 81; ++i) q.data()[i] = g(rng);
  const Eigen::HouseholderQR<Matrix9d> qr(q);
  const Matrix9d basis = qr.householderQ();
  Eigen::Matrix<double, 9, 1> lam;
  lam << -3, -1, -1e-3, 0, 0.5, 1, 2, 4, 8;
  const Matrix9d a = basis * lam.asDiagonal() * basis.transpose();
  const Matrix9d p = project_psd(a);
  Eigen::Matrix<double, 9, 1> want = lam.cwiseMax(0.0);
  const Matrix9d expected = basis * want.asDiagonal() * basis.transpose();
  EXPECT_LT((p - expected).cwiseAbs().maxCoeff(), 1e-12 * 8);
  const Matrix9d spd = basis * want.cwiseMax(0.1).asDiagonal() * basis.transpose();
  EXPECT_EQ(project_psd(spd), spd);
}

TEST(NeoHookeanBody, BodyForcesAgreeWithTheTetFormulaAndTheProjectedHessianIsPsd) {
  auto b = Body::create(test::structured_box(2, 2, 2, {0, 0, 0}, {0.2, 0.2, 0.2}),
                        {.young = 2e5, .poisson = 0.4});
  ASSERT_TRUE(b);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-0.03, 0.03);
  Eigen::Matrix3Xd x = b->positions();
  x.row(2) *= 0.6;  // squashed: compressed tets, indefinite exact Hessians
  for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] += u(rng);
  b->set_positions(x);
  ASSERT_EQ(b->inverted_tets(), 0u);
  // Body's forces are the sum of snh_tet_forces.
  Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, b->node_count());
  for (std::size_t t = 0; t < b->rest_mesh().tets.size(); ++t) {
    const Tet& tet = b->rest_mesh().tets[t];
    Eigen::Matrix<double, 3, 4> p;
    for (int k = 0; k < 4; ++k) p.col(k) = x.col(tet[static_cast<std::size_t>(k)]);
    const Vector12d ft = snh_tet_forces(p, b->dm_inv()[t], b->volumes()[t], b->mu(), b->lambda());
    for (int k = 0; k < 4; ++k) f.col(tet[static_cast<std::size_t>(k)]) += ft.segment<3>(3 * k);
  }
  EXPECT_LT((f - b->elastic_forces()).cwiseAbs().maxCoeff(), 1e-9 * f.cwiseAbs().maxCoeff());
  const Eigen::MatrixXd exact = Eigen::MatrixXd(elastic_hessian(*b, false));
  const Eigen::MatrixXd psd = Eigen::MatrixXd(elastic_hessian(*b, true));
  const double scale = exact.cwiseAbs().maxCoeff();
  EXPECT_LT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(exact).eigenvalues().minCoeff(),
            -1e-6 * scale)
      << "the case must exercise the projection";
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(psd).eigenvalues().minCoeff(),
            -1e-9 * scale);
}

}  // namespace
}  // namespace tc::sim
