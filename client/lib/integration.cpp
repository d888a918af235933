#include "tetcollide/integration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace tc::client {
namespace {

/// The unique edges of the mesh's cells (tets, else triangles), as sorted node pairs.
std::vector<std::pair<std::int32_t, std::int32_t>> unique_edges(const Mesh& mesh) {
  std::vector<std::pair<std::int32_t, std::int32_t>> edges;
  const auto add = [&](std::int32_t a, std::int32_t b) {
    edges.emplace_back(std::min(a, b), std::max(a, b));
  };
  if (!mesh.tets.empty()) {
    edges.reserve(mesh.tets.size() / 4 * 6);
    for (std::size_t t = 0; t + 3 < mesh.tets.size(); t += 4)
      for (std::size_t i = 0; i < 4; ++i)
        for (std::size_t j = i + 1; j < 4; ++j) add(mesh.tets[t + i], mesh.tets[t + j]);
  } else {
    edges.reserve(mesh.triangles.size());
    for (std::size_t t = 0; t + 2 < mesh.triangles.size(); t += 3)
      for (std::size_t i = 0; i < 3; ++i)
        add(mesh.triangles[t + i], mesh.triangles[t + (i + 1) % 3]);
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  return edges;
}

}  // namespace

std::vector<double> node_weights(const Mesh& mesh) {
  const std::size_t n = mesh.rest_positions.size() / 3;
  std::vector<double> w(n, 0.0);
  for (const auto& [a, b] : unique_edges(mesh)) {
    if (a < 0 || b < 0 || static_cast<std::size_t>(b) >= n)
      throw std::invalid_argument("node_weights: a cell uses node " + std::to_string(b) +
                                  ", outside [0, " + std::to_string(n) + ")");
    double sq = 0.0;
    for (std::size_t k = 0; k < 3; ++k) {
      const double d = mesh.rest_positions[3 * static_cast<std::size_t>(a) + k] -
                       mesh.rest_positions[3 * static_cast<std::size_t>(b) + k];
      sq += d * d;
    }
    const double half = 0.5 * std::sqrt(sq);
    w[static_cast<std::size_t>(a)] += half;
    w[static_cast<std::size_t>(b)] += half;
  }
  return w;
}

double max_explicit_stiffness(const Mesh& mesh, std::span<const double> node_masses, double dt,
                              double damping) {
  const std::vector<double> w = node_weights(mesh);
  if (node_masses.size() != w.size())
    throw std::invalid_argument("max_explicit_stiffness: " + std::to_string(node_masses.size()) +
                                " node masses for " + std::to_string(w.size()) + " nodes");
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw std::invalid_argument("max_explicit_stiffness: dt must be finite and > 0");
  if (!(damping >= 0.0) || !std::isfinite(damping))
    throw std::invalid_argument("max_explicit_stiffness: damping must be finite and >= 0");
  double k = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < w.size(); ++i) {
    const double m = node_masses[i];
    if (!(m > 0.0) || !std::isfinite(m))
      throw std::invalid_argument("max_explicit_stiffness: node " + std::to_string(i) +
                                  " has mass " + std::to_string(m) + " (must be finite and > 0)");
    if (!(w[i] > 0.0)) continue;  // in no cell: never in contact
    const double margin = 4.0 * m - 2.0 * damping * w[i] * dt;
    if (!(margin > 0.0)) return 0.0;
    k = std::min(k, margin / (w[i] * dt * dt));
  }
  return std::isfinite(k) ? k : 0.0;
}

}  // namespace tc::client
