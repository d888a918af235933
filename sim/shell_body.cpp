#include "shell_body.hpp"

#include <Eigen/Dense>
#include <Eigen/IterativeLinearSolvers>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace tc::sim {

using SpMat = Eigen::SparseMatrix<double>;

// Conjugate gradients with a diagonal preconditioner: M/h^2 dominates the diagonal (a
// vertex of the demo's sphere: 1.9e5 N/m against ~7e3 N/m of springs) and contact adds to
// it, so a few iterations reach the tolerance; a sparse LDL^T of the closed surface took
// ~6 ms a factorisation for 642 vertices (its fill-in).
struct ShellBody::Solver {
  std::vector<Eigen::Triplet<double>> triplets;  ///< scratch
};

ShellBody::ShellBody() : solver_(std::make_unique<Solver>()) {}
ShellBody::~ShellBody() = default;
ShellBody::ShellBody(ShellBody&&) noexcept = default;
ShellBody& ShellBody::operator=(ShellBody&&) noexcept = default;

Expected<ShellBody> ShellBody::create(SurfaceMesh surface, const ShellMaterial& material) {
  const auto bad = [](const std::string& what) { return Error{ErrorCode::kInvalidArgument, what}; };
  if (!(material.mass > 0.0) || !std::isfinite(material.mass))
    return bad("shell mass must be > 0 kg, got " + std::to_string(material.mass));
  if (!(material.stretch > 0.0) || !std::isfinite(material.stretch))
    return bad("shell stretch must be > 0 N/m, got " + std::to_string(material.stretch));
  if (!(material.pressure >= 0.0) || !std::isfinite(material.pressure))
    return bad("shell pressure must be >= 0 Pa, got " + std::to_string(material.pressure));
  if (!(material.damping >= 0.0) || !std::isfinite(material.damping))
    return bad("shell damping must be >= 0 1/s, got " + std::to_string(material.damping));
  const auto report = validate_surface(surface);
  if (auto st = require_valid_surface(report, "shell"); !st) return st.error();
  const SurfaceEdges edges = build_surface_edges(surface.triangles);
  const SurfaceStats stats = compute_surface_stats(surface, edges, report);
  const auto invalid = [](const std::string& what) {
    return Error{ErrorCode::kInvalidMesh, "shell: " + what};
  };
  if (!stats.closed)
    return invalid("the surface is not closed (" + std::to_string(stats.boundary_edges) +
                   " boundary edges, " + std::to_string(stats.nonmanifold_edges) +
                   " non-manifold edges): a triangle-based body needs a closed surface to hold "
                   "its gas");
  if (!stats.oriented)
    return invalid(std::to_string(stats.misoriented_edges) +
                   " edges join triangles of opposite orientation: the enclosed volume is not "
                   "defined");
  if (stats.unused_nodes > 0)
    return invalid(std::to_string(stats.unused_nodes) +
                   " vertices are in no triangle (they would carry mass but no force)");
  if (!stats.outward)
    for (Triangle& t : surface.triangles) std::swap(t[1], t[2]);

  ShellBody b;
  b.material_ = material;
  b.rest_ = std::move(surface);
  b.x_ = b.rest_.positions;
  const Index n = b.rest_.num_nodes();
  b.v_ = Eigen::Matrix3Xd::Zero(3, n);
  b.mass_ = Eigen::VectorXd::Zero(n);
  std::vector<double> edge_area(edges.edges.size(), 0.0);
  double total_area = 0.0;
  for (std::size_t t = 0; t < b.rest_.triangles.size(); ++t) {
    const Triangle& tri = b.rest_.triangles[t];
    const Eigen::Vector3d p0 = b.x_.col(tri[0]);
    const double area = 0.5 * (b.x_.col(tri[1]) - p0).cross(b.x_.col(tri[2]) - p0).norm();
    total_area += area;
    for (const Index i : tri) b.mass_[i] += area / 3.0;
    for (const Index e : edges.triangle_edges[t]) edge_area[static_cast<std::size_t>(e)] += area;
  }
  b.mass_ *= material.mass / total_area;
  b.edges_ = edges.edges;
  b.rest_length_.resize(b.edges_.size());
  b.spring_k_.resize(b.edges_.size());
  for (std::size_t e = 0; e < b.edges_.size(); ++e) {
    const double l = (b.x_.col(b.edges_[e][1]) - b.x_.col(b.edges_[e][0])).norm();
    b.rest_length_[e] = l;
    b.spring_k_[e] = material.stretch * edge_area[e] / (3.0 * l * l);
  }
  b.rest_volume_ = b.volume_of(b.x_);
  return b;
}

double ShellBody::volume_of(const Eigen::Matrix3Xd& x) const {
  double v = 0.0;
  for (const Triangle& t : rest_.triangles) v += x.col(t[0]).dot(x.col(t[1]).cross(x.col(t[2])));
  return v / 6.0;
}

Eigen::Matrix3Xd ShellBody::volume_gradient(const Eigen::Matrix3Xd& x) const {
  Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, x.cols());
  for (const Triangle& t : rest_.triangles) {
    const Eigen::Vector3d a = x.col(t[0]);
    const Eigen::Vector3d b = x.col(t[1]);
    const Eigen::Vector3d c = x.col(t[2]);
    g.col(t[0]) += b.cross(c) / 6.0;
    g.col(t[1]) += c.cross(a) / 6.0;
    g.col(t[2]) += a.cross(b) / 6.0;
  }
  return g;
}

double ShellBody::potential_of(const Eigen::Matrix3Xd& x) const {
  const double v = volume_of(x);
  if (!(v > 0.0)) return std::numeric_limits<double>::infinity();
  double e = 0.0;
  for (std::size_t k = 0; k < edges_.size(); ++k) {
    const double s = (x.col(edges_[k][1]) - x.col(edges_[k][0])).norm() - rest_length_[k];
    e += 0.5 * spring_k_[k] * s * s;
  }
  const double p0 = material_.pressure;
  return e + p0 * (v - rest_volume_) - p0 * rest_volume_ * std::log(v / rest_volume_);
}

Eigen::Matrix3Xd ShellBody::potential_gradient(const Eigen::Matrix3Xd& x) const {
  Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, x.cols());
  for (std::size_t k = 0; k < edges_.size(); ++k) {
    const Eigen::Vector3d d = x.col(edges_[k][1]) - x.col(edges_[k][0]);
    const double l = d.norm();
    if (!(l > 0.0)) continue;
    const Eigen::Vector3d f = spring_k_[k] * (l - rest_length_[k]) / l * d;
    g.col(edges_[k][1]) += f;
    g.col(edges_[k][0]) -= f;
  }
  const double p0 = material_.pressure;
  const double dpsi_dv = p0 - p0 * rest_volume_ / volume_of(x);  // -(overpressure)
  g += dpsi_dv * volume_gradient(x);
  return g;
}

Eigen::Matrix3Xd ShellBody::internal_forces() const {
  return -potential_gradient(x_);
}

Energy ShellBody::energy(const Eigen::Vector3d& gravity) const {
  Energy e;
  for (Index i = 0; i < node_count(); ++i) {
    e.kinetic += 0.5 * mass_[i] * v_.col(i).squaredNorm();
    e.gravity -= mass_[i] * gravity.dot(x_.col(i));
  }
  e.elastic = potential_of(x_);
  return e;
}

StepReport ShellBody::step(double dt, const Eigen::Vector3d& gravity,
                           const Eigen::Matrix3Xd& forces, const Eigen::Matrix3Xd& blocks,
                           int max_newton) {
  StepReport report;
  const Index n = node_count();
  const double h = dt;
  const double damping = material_.damping;
  const double p0 = material_.pressure;
  const Eigen::Matrix3Xd xn = x_;
  const Eigen::Matrix3Xd vn = v_;
  const InertiaAndContact terms(mass_, h, damping, gravity, xn, vn, forces, blocks);
  // The incremental potential (implicit_step.hpp) with Psi of the shell.
  const auto potential = [&](const Eigen::Matrix3Xd& x) {
    double e = potential_of(x);
    for (Index i = 0; i < n; ++i) e += terms.energy(i, x);
    return e;
  };
  const auto gradient = [&](const Eigen::Matrix3Xd& x) {
    Eigen::Matrix3Xd g = potential_gradient(x);
    for (Index i = 0; i < n; ++i) g.col(i) += terms.gradient(i, x);
    return g;
  };
  // M/h^2 + a M/h - Kc + the springs' Hessians projected to PSD (the gas's rank-one term is
  // added by Sherman-Morrison in the loop).
  const auto assemble = [&](const Eigen::Matrix3Xd& x, SpMat& out) {
    auto& trip = solver_->triplets;
    trip.clear();
    trip.reserve(static_cast<std::size_t>(n) * 9 + edges_.size() * 36);
    for (Index i = 0; i < n; ++i) {
      const Eigen::Matrix3d d = terms.hessian(i);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) trip.emplace_back(3 * i + r, 3 * i + c, d(r, c));
    }
    for (std::size_t k = 0; k < edges_.size(); ++k) {
      const Index a = edges_[k][0];
      const Index b = edges_[k][1];
      const Eigen::Vector3d d = x.col(b) - x.col(a);
      const double l = d.norm();
      Eigen::Matrix3d he = Eigen::Matrix3d::Zero();
      if (l > 0.0) {
        const Eigen::Vector3d u = d / l;
        const Eigen::Matrix3d uu = u * u.transpose();
        he = spring_k_[k] *
             (uu + std::max(0.0, 1.0 - rest_length_[k] / l) * (Eigen::Matrix3d::Identity() - uu));
      }
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
          trip.emplace_back(3 * a + r, 3 * a + c, he(r, c));
          trip.emplace_back(3 * b + r, 3 * b + c, he(r, c));
          trip.emplace_back(3 * a + r, 3 * b + c, -he(r, c));
          trip.emplace_back(3 * b + r, 3 * a + c, -he(r, c));
        }
    }
    out.resize(3 * n, 3 * n);
    out.setFromTriplets(trip.begin(), trip.end());
    out.makeCompressed();
  };

  Eigen::Matrix3Xd x = xn + h * vn;
  double e = potential(x);
  if (!std::isfinite(e)) {
    x = xn;
    e = potential(x);
  }
  for (int it = 0; it < std::max(1, max_newton); ++it) {
    const Eigen::Matrix3Xd g = gradient(x);
    SpMat a;
    assemble(x, a);
    Eigen::ConjugateGradient<SpMat, Eigen::Lower | Eigen::Upper> cg;
    cg.setTolerance(1e-10);
    cg.compute(a);
    ++report.newton_iterations;
    const Eigen::Map<const Eigen::VectorXd> gv(g.data(), g.size());
    Eigen::VectorXd d = cg.solve(-gv);
    // (A + c w w^T) d = -g with c = d2Psi/dV2 = p0 V0 / V^2 and w = dV/dx.
    const double v = volume_of(x);
    if (p0 > 0.0 && v > 0.0) {
      const Eigen::Matrix3Xd w3 = volume_gradient(x);
      const Eigen::Map<const Eigen::VectorXd> w(w3.data(), w3.size());
      const Eigen::VectorXd u = cg.solve(w);
      const double c = p0 * rest_volume_ / (v * v);
      d -= (c * w.dot(d) / (1.0 + c * w.dot(u))) * u;
    }
    if (!d.allFinite()) {
      report.linear_solver_failed = true;
      break;
    }
    const Eigen::Map<const Eigen::Matrix3Xd> dir(d.data(), 3, n);
    const double slope = gv.dot(d);
    if (!line_search(potential, dir, slope, h, x, e, report)) break;
    if (report.last_update < 1e-4) break;
  }
  v_ = (x - xn) / h;
  x_ = std::move(x);
  dissipated_ += terms.damping_work(v_);
  return report;
}

}  // namespace tc::sim
