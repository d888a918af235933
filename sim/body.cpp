#include "body.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>

#include "neo_hookean.hpp"

namespace tc::sim {
namespace {

Eigen::Matrix3d edge_matrix(const Eigen::Matrix3Xd& x, const Tet& t) {
  Eigen::Matrix3d d;
  d.col(0) = x.col(t[1]) - x.col(t[0]);
  d.col(1) = x.col(t[2]) - x.col(t[0]);
  d.col(2) = x.col(t[3]) - x.col(t[0]);
  return d;
}

}  // namespace

Expected<Body> Body::create(TetMesh mesh, const Material& material) {
  if (!(material.density > 0.0) || !(material.young > 0.0) || !(material.poisson >= 0.0) ||
      !(material.poisson < 0.5) || !(material.damping >= 0.0))
    return Error{ErrorCode::kInvalidArgument,
                 "material: density and young must be > 0, poisson in [0, 0.5), damping >= 0"};
  Body b;
  b.rest_ = std::move(mesh);
  b.material_ = material;
  const double e = material.young;
  const double nu = material.poisson;
  b.mu_ = e / (2.0 * (1.0 + nu));
  b.lambda_ = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)) + b.mu_;
  for (std::size_t i = 0; i < b.rest_.tets.size(); ++i) {
    const Tet& t = b.rest_.tets[i];
    for (const Index n : t)
      if (n < 0 || n >= b.rest_.num_nodes())
        return Error{ErrorCode::kInvalidMesh, "tet " + std::to_string(i) + " refers to node " +
                                                  std::to_string(n) + " of " +
                                                  std::to_string(b.rest_.num_nodes())};
    const double det = edge_matrix(b.rest_.positions, t).determinant();
    if (!(det > 0.0))
      return Error{ErrorCode::kInvalidMesh,
                   "tet " + std::to_string(i) +
                       " is degenerate or inverted at rest (6V = " + std::to_string(det) + ")"};
  }
  b.x_ = b.rest_.positions;
  b.v_ = Eigen::Matrix3Xd::Zero(3, b.x_.cols());
  b.pinned_.assign(static_cast<std::size_t>(b.x_.cols()), false);
  b.precompute();
  return b;
}

void Body::precompute() {
  const std::size_t m = rest_.tets.size();
  dm_inv_.resize(m);
  volume_.resize(m);
  mass_ = Eigen::VectorXd::Zero(rest_.num_nodes());
  for (std::size_t i = 0; i < m; ++i) {
    const Eigen::Matrix3d dm = edge_matrix(rest_.positions, rest_.tets[i]);
    dm_inv_[i] = dm.inverse();
    volume_[i] = dm.determinant() / 6.0;
    for (const Index n : rest_.tets[i]) mass_[n] += material_.density * volume_[i] / 4.0;
  }
  force_.resize(3, rest_.num_nodes());
}

void Body::fix_nodes(const std::vector<Index>& nodes) {
  for (const Index n : nodes) {
    if (n < 0 || n >= node_count()) continue;
    pinned_[static_cast<std::size_t>(n)] = true;
    v_.col(n).setZero();
  }
}

std::vector<Index> Body::border_nodes(double limit_x, double limit_y) const {
  std::vector<Index> out;
  for (Index n = 0; n < rest_.num_nodes(); ++n)
    if (std::abs(rest_.positions(0, n)) >= limit_x || std::abs(rest_.positions(1, n)) >= limit_y)
      out.push_back(n);
  return out;
}

void Body::add_elastic_forces(Eigen::Matrix3Xd& f) const {
  const double alpha = 1.0 + mu_ / lambda_;
  for (std::size_t i = 0; i < rest_.tets.size(); ++i) {
    const Tet& t = rest_.tets[i];
    const Eigen::Matrix3d fm = edge_matrix(x_, t) * dm_inv_[i];
    const double j = fm.determinant();
    // P = mu F + lambda (J - alpha) dJ/dF; nodal forces -V P Dm^-T.
    const Eigen::Matrix3d p = mu_ * fm + lambda_ * (j - alpha) * cofactor(fm);
    const Eigen::Matrix3d h = -volume_[i] * p * dm_inv_[i].transpose();
    f.col(t[1]) += h.col(0);
    f.col(t[2]) += h.col(1);
    f.col(t[3]) += h.col(2);
    f.col(t[0]) -= h.col(0) + h.col(1) + h.col(2);
  }
}

Eigen::Matrix3Xd Body::elastic_forces() const {
  Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, x_.cols());
  add_elastic_forces(f);
  return f;
}

void Body::step(double dt, int substeps, const Eigen::Vector3d& gravity,
                const Eigen::Matrix3Xd& contact) {
  if (substeps < 1) substeps = 1;
  const double h = dt / substeps;
  const bool has_contact = contact.cols() == x_.cols();
  const double keep = std::exp(-material_.damping * h);
  for (int s = 0; s < substeps; ++s) {
    force_.setZero();
    add_elastic_forces(force_);
    if (has_contact) force_ += contact;
    for (Index n = 0; n < node_count(); ++n) {
      if (pinned_[static_cast<std::size_t>(n)]) continue;
      // Symplectic Euler: velocity first (forces at x_k), then position with v_{k+1}.
      Eigen::Vector3d a = gravity;
      if (mass_[n] > 0.0) a += force_.col(n) / mass_[n];
      const Eigen::Vector3d free = v_.col(n) + h * a;
      v_.col(n) = keep * free;
      dissipated_ += 0.5 * mass_[n] * (1.0 - keep * keep) * free.squaredNorm();
      x_.col(n) += h * v_.col(n);
    }
  }
}

std::size_t Body::tear(double strain) {
  const double limit = 1.0 + strain;
  std::vector<bool> keep(rest_.tets.size(), true);
  std::size_t removed = 0;
  for (std::size_t i = 0; i < rest_.tets.size(); ++i) {
    const Eigen::Matrix3d fm = edge_matrix(x_, rest_.tets[i]) * dm_inv_[i];
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(fm.transpose() * fm, Eigen::EigenvaluesOnly);
    const double stretch = std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff()));
    if (!(stretch <= limit)) {
      keep[i] = false;
      ++removed;
    }
  }
  if (removed == 0) return 0;
  // Nodes still used by a kept tet, renumbered in their old order.
  std::vector<Index> remap(static_cast<std::size_t>(node_count()), -1);
  for (std::size_t i = 0; i < rest_.tets.size(); ++i)
    if (keep[i])
      for (const Index n : rest_.tets[i]) remap[static_cast<std::size_t>(n)] = 0;
  Index next = 0;
  for (auto& r : remap)
    if (r == 0) r = next++;
  TetMesh mesh;
  mesh.positions.resize(3, next);
  Eigen::Matrix3Xd x(3, next);
  Eigen::Matrix3Xd v(3, next);
  std::vector<bool> pinned(static_cast<std::size_t>(next), false);
  for (Index n = 0; n < node_count(); ++n) {
    const Index r = remap[static_cast<std::size_t>(n)];
    if (r < 0) continue;
    if (!rest_.node_ids.empty())
      mesh.node_ids.push_back(rest_.node_ids[static_cast<std::size_t>(n)]);
    mesh.positions.col(r) = rest_.positions.col(n);
    x.col(r) = x_.col(n);
    v.col(r) = v_.col(n);
    pinned[static_cast<std::size_t>(r)] = pinned_[static_cast<std::size_t>(n)];
  }
  for (std::size_t i = 0; i < rest_.tets.size(); ++i) {
    if (!keep[i]) continue;
    Tet t = rest_.tets[i];
    for (auto& n : t) n = remap[static_cast<std::size_t>(n)];
    mesh.tets.push_back(t);
  }
  rest_ = std::move(mesh);
  x_ = std::move(x);
  v_ = std::move(v);
  pinned_ = std::move(pinned);
  precompute();
  return removed;
}

double Body::max_strain() const {
  double worst = 0.0;
  for (std::size_t i = 0; i < rest_.tets.size(); ++i) {
    const Eigen::Matrix3d fm = edge_matrix(x_, rest_.tets[i]) * dm_inv_[i];
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(fm.transpose() * fm, Eigen::EigenvaluesOnly);
    worst = std::max(worst, std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff())) - 1.0);
  }
  return worst;
}

Energy Body::energy(const Eigen::Vector3d& gravity) const {
  Energy e;
  const double alpha = 1.0 + mu_ / lambda_;
  const double rest_density = 0.5 * lambda_ * (1.0 - alpha) * (1.0 - alpha);
  for (std::size_t i = 0; i < rest_.tets.size(); ++i) {
    const Eigen::Matrix3d fm = edge_matrix(x_, rest_.tets[i]) * dm_inv_[i];
    const double j = fm.determinant();
    const double psi = 0.5 * mu_ * ((fm.transpose() * fm).trace() - 3.0) +
                       0.5 * lambda_ * (j - alpha) * (j - alpha) - rest_density;
    e.elastic += volume_[i] * psi;
  }
  for (Index n = 0; n < node_count(); ++n) {
    e.kinetic += 0.5 * mass_[n] * v_.col(n).squaredNorm();
    e.gravity -= mass_[n] * gravity.dot(x_.col(n));
  }
  return e;
}

std::size_t Body::inverted_tets() const {
  std::size_t n = 0;
  for (const Tet& t : rest_.tets)
    if (!(edge_matrix(x_, t).determinant() > 0.0)) ++n;
  return n;
}

double Body::stable_dt() const {
  const double c = std::sqrt((lambda_ + mu_) / material_.density);  // P-wave speed
  double shortest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < rest_.tets.size(); ++i) {
    // Shortest altitude = 3V / largest face area.
    const Tet& t = rest_.tets[i];
    const auto& p = rest_.positions;
    double largest = 0.0;
    static constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    for (const auto& f : kFaces) {
      const Eigen::Vector3d a = p.col(t[f[1]]) - p.col(t[f[0]]);
      const Eigen::Vector3d b = p.col(t[f[2]]) - p.col(t[f[0]]);
      largest = std::max(largest, 0.5 * a.cross(b).norm());
    }
    shortest = std::min(shortest, 3.0 * volume_[i] / largest);
  }
  return shortest / c;
}

}  // namespace tc::sim
