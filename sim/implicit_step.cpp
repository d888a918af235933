#include "implicit_step.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <limits>

#include "neo_hookean.hpp"

namespace tc::sim {
namespace {

using SpMat = Eigen::SparseMatrix<double>;  // column-major, int indices

Eigen::Matrix<double, 3, 4> tet_positions(const Eigen::Matrix3Xd& x, const Tet& t) {
  Eigen::Matrix<double, 3, 4> p;
  for (int k = 0; k < 4; ++k) p.col(k) = x.col(t[static_cast<std::size_t>(k)]);
  return p;
}

double tet_det(const Eigen::Matrix<double, 3, 4>& p) {
  Eigen::Matrix3d d;
  d.col(0) = p.col(1) - p.col(0);
  d.col(1) = p.col(2) - p.col(0);
  d.col(2) = p.col(3) - p.col(0);
  return d.determinant();
}

/// The sparse pattern of a body's 3n x 3n matrices (3x3 blocks for every node pair that
/// shares a tet) and where each tet's and node's blocks live in its value array.
struct Pattern {
  SpMat a;
  std::vector<Tet> tets;  ///< the topology the pattern is for
  Index nodes = -1;
  /// Per tet, per (row node a, column node b, column c): the value index of the entry
  /// (3 t[a], 3 t[b] + c); rows 3 t[a] + 1 and + 2 follow it.
  std::vector<int> tet_slot;
  std::vector<int> diag_slot;  ///< per node, per column c: index of (3i, 3i + c)

  [[nodiscard]] bool matches(const Body& body) const {
    return nodes == body.node_count() && tets == body.rest_mesh().tets;
  }

  void build(const Body& body) {
    tets = body.rest_mesh().tets;
    nodes = body.node_count();
    const Index n3 = 3 * nodes;
    std::vector<Eigen::Triplet<double>> trip;
    trip.reserve(tets.size() * 144 + static_cast<std::size_t>(nodes) * 9);
    for (Index i = 0; i < nodes; ++i)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) trip.emplace_back(3 * i + r, 3 * i + c, 0.0);
    for (const Tet& t : tets)
      for (const Index i : t)
        for (const Index j : t)
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) trip.emplace_back(3 * i + r, 3 * j + c, 0.0);
    a.resize(n3, n3);
    a.setFromTriplets(trip.begin(), trip.end());
    a.makeCompressed();
    const auto find = [&](Index row, Index col) {
      const int* begin = a.innerIndexPtr() + a.outerIndexPtr()[col];
      const int* end = a.innerIndexPtr() + a.outerIndexPtr()[col + 1];
      const int* it = std::lower_bound(begin, end, row);
      return static_cast<int>(it - a.innerIndexPtr());
    };
    diag_slot.resize(static_cast<std::size_t>(nodes) * 3);
    for (Index i = 0; i < nodes; ++i)
      for (int c = 0; c < 3; ++c)
        diag_slot[static_cast<std::size_t>(3 * i + c)] = find(3 * i, 3 * i + c);
    tet_slot.resize(tets.size() * 48);
    for (std::size_t e = 0; e < tets.size(); ++e)
      for (int ka = 0; ka < 4; ++ka)
        for (int kb = 0; kb < 4; ++kb)
          for (int c = 0; c < 3; ++c)
            tet_slot[e * 48 + static_cast<std::size_t>((ka * 4 + kb) * 3 + c)] =
                find(3 * tets[e][static_cast<std::size_t>(ka)],
                     3 * tets[e][static_cast<std::size_t>(kb)] + c);
  }
};

}  // namespace

InertiaAndContact::InertiaAndContact(const Eigen::VectorXd& mass, double h, double damping,
                                     const Eigen::Vector3d& gravity, const Eigen::Matrix3Xd& xn,
                                     const Eigen::Matrix3Xd& vn, const Eigen::Matrix3Xd& forces,
                                     const Eigen::Matrix3Xd& blocks)
    : mass_(mass), h_(h), damping_(damping), xn_(xn), forces_(forces), target_(xn + h * vn) {
  target_.colwise() += h * h * gravity;
  // Contact blocks, symmetrised (the service's are symmetric up to rounding).
  if (blocks.cols() == 3 * xn.cols()) {
    kc_.resize(static_cast<std::size_t>(xn.cols()));
    for (Index i = 0; i < xn.cols(); ++i) {
      const Eigen::Matrix3d b = blocks.middleCols<3>(3 * i);
      kc_[static_cast<std::size_t>(i)] = 0.5 * (b + b.transpose());
    }
  }
}

double InertiaAndContact::energy(Index i, const Eigen::Matrix3Xd& x) const {
  const double m = mass_[i];
  const Eigen::Vector3d dx = x.col(i) - xn_.col(i);
  double e = 0.5 * m / (h_ * h_) * (x.col(i) - target_.col(i)).squaredNorm() +
             0.5 * damping_ * m / h_ * dx.squaredNorm();
  if (forces_.cols() == xn_.cols()) e -= forces_.col(i).dot(dx);
  if (!kc_.empty()) e -= 0.5 * dx.dot(kc_[static_cast<std::size_t>(i)] * dx);
  return e;
}

Eigen::Vector3d InertiaAndContact::gradient(Index i, const Eigen::Matrix3Xd& x) const {
  const double m = mass_[i];
  const Eigen::Vector3d dx = x.col(i) - xn_.col(i);
  Eigen::Vector3d g = m / (h_ * h_) * (x.col(i) - target_.col(i)) + damping_ * m / h_ * dx;
  if (forces_.cols() == xn_.cols()) g -= forces_.col(i);
  if (!kc_.empty()) g -= kc_[static_cast<std::size_t>(i)] * dx;
  return g;
}

Eigen::Matrix3d InertiaAndContact::hessian(Index i) const {
  Eigen::Matrix3d d =
      (mass_[i] / (h_ * h_) + damping_ * mass_[i] / h_) * Eigen::Matrix3d::Identity();
  if (!kc_.empty()) d -= kc_[static_cast<std::size_t>(i)];
  return d;
}

double InertiaAndContact::damping_work(const Eigen::Matrix3Xd& v) const {
  double lost = 0.0;
  for (Index i = 0; i < v.cols(); ++i) lost += damping_ * mass_[i] * v.col(i).squaredNorm() * h_;
  return lost;
}

struct ImplicitStepper::Impl {
  Pattern pattern;
  Eigen::SimplicialLDLT<SpMat, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
  bool analysed = false;
  std::vector<Matrix12d> hess;  ///< per tet, scratch
};

ImplicitStepper::ImplicitStepper(ImplicitOptions options)
    : options_(options), impl_(std::make_unique<Impl>()) {
  options_.max_newton = std::max(1, options_.max_newton);
}
ImplicitStepper::~ImplicitStepper() = default;
ImplicitStepper::ImplicitStepper(ImplicitStepper&&) noexcept = default;
ImplicitStepper& ImplicitStepper::operator=(ImplicitStepper&&) noexcept = default;

StepReport ImplicitStepper::step(Body& body, double dt, const Eigen::Vector3d& gravity,
                                 const Eigen::Matrix3Xd& forces, const Eigen::Matrix3Xd& blocks) {
  StepReport report;
  const Index n = body.node_count();
  const auto& tets = body.rest_mesh().tets;
  const auto& dm_inv = body.dm_inv();
  const auto& vol = body.volumes();
  const auto& mass = body.masses();
  const auto& pinned = body.pinned();
  const double mu = body.mu();
  const double lambda = body.lambda();
  const double damping = body.material().damping;
  const double h = dt;
  const Eigen::Matrix3Xd xn = body.positions();
  const Eigen::Matrix3Xd vn = body.velocities();
  const InertiaAndContact terms(mass, h, damping, gravity, xn, vn, forces, blocks);

  Impl& im = *impl_;
  if (!im.pattern.matches(body)) {
    im.pattern.build(body);
    im.analysed = false;
  }
  SpMat& a = im.pattern.a;
  const auto is_pinned = [&](Index i) { return pinned[static_cast<std::size_t>(i)]; };
  // The incremental potential E(x); +inf when a tet is inverted or flat.
  const auto potential = [&](const Eigen::Matrix3Xd& x) {
    double e = 0.0;
    for (std::size_t t = 0; t < tets.size(); ++t) {
      const auto p = tet_positions(x, tets[t]);
      if (!(tet_det(p) > 0.0)) return std::numeric_limits<double>::infinity();
      Eigen::Matrix3d ds;
      ds.col(0) = p.col(1) - p.col(0);
      ds.col(1) = p.col(2) - p.col(0);
      ds.col(2) = p.col(3) - p.col(0);
      e += vol[t] * snh_energy_density(ds * dm_inv[t], mu, lambda);
    }
    for (Index i = 0; i < n; ++i) e += terms.energy(i, x);
    return e;
  };
  // Gradient of E (3 x n), zero on pinned nodes.
  const auto gradient = [&](const Eigen::Matrix3Xd& x) {
    Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, n);
    for (std::size_t t = 0; t < tets.size(); ++t) {
      const Vector12d f = snh_tet_forces(tet_positions(x, tets[t]), dm_inv[t], vol[t], mu, lambda);
      for (int k = 0; k < 4; ++k)
        g.col(tets[t][static_cast<std::size_t>(k)]) -= f.segment<3>(3 * k);
    }
    for (Index i = 0; i < n; ++i) {
      if (is_pinned(i))
        g.col(i).setZero();
      else
        g.col(i) += terms.gradient(i, x);
    }
    return g;
  };
  // The system matrix at x: M/h^2 + a M/h + H_psd(x) - Kc, identity rows for pinned nodes.
  const auto assemble = [&](const Eigen::Matrix3Xd& x) {
    im.hess.resize(tets.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tets.size(), 256),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t t = r.begin(); t != r.end(); ++t)
                          im.hess[t] = snh_tet_hessian(tet_positions(x, tets[t]), dm_inv[t], vol[t],
                                                       mu, lambda, true);
                      });
    double* val = a.valuePtr();
    std::fill(val, val + a.nonZeros(), 0.0);
    for (std::size_t t = 0; t < tets.size(); ++t) {
      const Tet& tet = tets[t];
      const Matrix12d& he = im.hess[t];
      for (int ka = 0; ka < 4; ++ka) {
        if (is_pinned(tet[static_cast<std::size_t>(ka)])) continue;
        for (int kb = 0; kb < 4; ++kb) {
          if (is_pinned(tet[static_cast<std::size_t>(kb)])) continue;
          const int* slot =
              &im.pattern.tet_slot[t * 48 + static_cast<std::size_t>((ka * 4 + kb) * 3)];
          for (int c = 0; c < 3; ++c)
            for (int r = 0; r < 3; ++r) val[slot[c] + r] += he(3 * ka + r, 3 * kb + c);
        }
      }
    }
    for (Index i = 0; i < n; ++i) {
      const int* slot = &im.pattern.diag_slot[static_cast<std::size_t>(3 * i)];
      if (is_pinned(i)) {
        for (int c = 0; c < 3; ++c) val[slot[c] + c] = 1.0;
        continue;
      }
      const Eigen::Matrix3d d = terms.hessian(i);
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) val[slot[c] + r] += d(r, c);
    }
  };

  // Start from the free flight x = xn + h vn when it inverts nothing, else from xn.
  Eigen::Matrix3Xd x = xn + h * vn;
  for (Index i = 0; i < n; ++i)
    if (is_pinned(i)) x.col(i) = xn.col(i);
  double e = potential(x);
  if (!std::isfinite(e)) {
    x = xn;
    e = potential(x);
  }
  for (int it = 0; it < options_.max_newton; ++it) {
    const Eigen::Matrix3Xd g = gradient(x);
    assemble(x);
    const Eigen::Map<const Eigen::VectorXd> rhs_view(g.data(), g.size());
    const Eigen::VectorXd rhs = -rhs_view;
    Eigen::VectorXd d;
    if (options_.solver == LinearSolver::kLdlt) {
      if (!im.analysed) {
        im.ldlt.analyzePattern(a);
        im.analysed = true;
      }
      im.ldlt.factorize(a);
      if (im.ldlt.info() == Eigen::Success) d = im.ldlt.solve(rhs);
    } else {
      Eigen::ConjugateGradient<SpMat, Eigen::Lower | Eigen::Upper> cg;
      cg.setTolerance(options_.cg_tolerance);
      cg.compute(a);
      d = cg.solve(rhs);
    }
    ++report.newton_iterations;
    if (d.size() != rhs.size() || !d.allFinite()) {
      report.linear_solver_failed = true;
      break;
    }
    const Eigen::Map<const Eigen::Matrix3Xd> dir(d.data(), 3, n);
    const double slope = rhs_view.dot(d);  // g . d < 0 for a descent direction
    if (!line_search(potential, dir, slope, h, x, e, report)) break;
    if (report.last_update < options_.velocity_tolerance) break;
  }
  Eigen::Matrix3Xd v = (x - xn) / h;
  for (Index i = 0; i < n; ++i)
    if (is_pinned(i)) {
      x.col(i) = xn.col(i);
      v.col(i).setZero();
    }
  body.add_dissipated(terms.damping_work(v));  // work of the damping force -a M v
  body.set_positions(x);
  body.set_velocities(v);
  return report;
}

Eigen::SparseMatrix<double> elastic_hessian(const Body& body, bool psd) {
  const auto& tets = body.rest_mesh().tets;
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(tets.size() * 144);
  for (std::size_t t = 0; t < tets.size(); ++t) {
    const Matrix12d he = snh_tet_hessian(tet_positions(body.positions(), tets[t]), body.dm_inv()[t],
                                         body.volumes()[t], body.mu(), body.lambda(), psd);
    for (int ka = 0; ka < 4; ++ka)
      for (int kb = 0; kb < 4; ++kb)
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c)
            trip.emplace_back(3 * tets[t][static_cast<std::size_t>(ka)] + r,
                              3 * tets[t][static_cast<std::size_t>(kb)] + c,
                              he(3 * ka + r, 3 * kb + c));
  }
  Eigen::SparseMatrix<double> out(3 * body.node_count(), 3 * body.node_count());
  out.setFromTriplets(trip.begin(), trip.end());
  return out;
}

}  // namespace tc::sim
