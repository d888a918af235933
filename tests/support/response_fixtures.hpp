// Test and benchmark helpers for the response stage: an object bundle (mesh, topology, depth),
// analytic box depth, and brute-force contacts (point-in-tet by signed sub-volumes,
// segment clipping against the four face half-spaces). Independent of the code under
// test: nothing here calls service/core/response.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <span>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/depth/depth_solver.hpp"
#include "core/detect/contacts.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"
#include "core/response/penalty.hpp"
#include "test_meshes.hpp"

namespace tc::test {

/// Options that evaluate depth by the paper's interpolation of the nodes' depth values: the
/// tests of the paper's formulas write depth fields by hand (half-spaces, linear fields),
/// which the nearest-face evaluation (the default) does not read.
inline ResponseOptions paper() {
  ResponseOptions o;
  o.evaluation = DepthEvaluation::kInterpolate;
  return o;
}

/// One object of a response test: mesh, topology, depth values, optional velocities.
struct TestObject {
  TetMesh mesh;
  Topology topology;
  std::vector<double> depth;
  std::vector<Index> anchor;  ///< empty unless compute_depth_map() ran
  std::optional<Positions> velocities;

  explicit TestObject(TetMesh m) : mesh(std::move(m)) {
    topology = build_topology(mesh.tets, mesh.num_nodes());
    depth.assign(static_cast<std::size_t>(mesh.num_nodes()), 0.0);
  }
  [[nodiscard]] ResponseObject view() const {
    ResponseObject o;
    o.positions = &mesh.positions;
    o.tets = mesh.tets;
    o.topology = &topology;
    o.depth = depth;
    o.velocities = velocities ? &*velocities : nullptr;
    o.anchor = anchor;
    return o;
  }
  /// Depths and anchors from a full depth map of the current positions.
  void compute_depth_map(DepthMethod method = DepthMethod::kCpfm) {
    DepthSolver solver(std::span<const Tet>(mesh.tets), topology, {.method = method});
    const Status st = solver.compute(mesh.positions);
    if (!st) throw std::runtime_error(st.error().message);
    depth.assign(solver.depth().begin(), solver.depth().end());
    anchor.assign(solver.anchor().begin(), solver.anchor().end());
  }
  template <typename F>
  void set_depth(F&& f) {
    for (Index i = 0; i < mesh.num_nodes(); ++i)
      depth[static_cast<std::size_t>(i)] = f(Eigen::Vector3d(mesh.positions.col(i)));
  }
};

/// Distance from x to the boundary of the box [lo, hi] (x inside), metres.
inline double box_depth(const Eigen::Vector3d& x, const Eigen::Vector3d& lo,
                        const Eigen::Vector3d& hi) {
  return std::max(0.0, std::min((x - lo).minCoeff(), (hi - x).minCoeff()));
}

/// Barycentric coordinates by signed sub-volumes (the textbook formula, not the frame).
inline Eigen::Vector4d bary_by_volumes(const std::array<Eigen::Vector3d, 4>& x,
                                       const Eigen::Vector3d& p) {
  const double v = signed_volume(x[0], x[1], x[2], x[3]);
  Eigen::Vector4d b;
  for (int k = 0; k < 4; ++k) {
    std::array<Eigen::Vector3d, 4> y = x;
    y[k] = p;
    b[k] = signed_volume(y[0], y[1], y[2], y[3]) / v;
  }
  return b;
}

inline std::array<Eigen::Vector3d, 4> tet_points(const Positions& pos, const Tet& t) {
  return {pos.col(t[0]), pos.col(t[1]), pos.col(t[2]), pos.col(t[3])};
}

/// Part of the segment a + lambda (b - a), lambda in [0, 1], inside the tet x; nullopt
/// when the part is shorter than `min_length` in lambda.
inline std::optional<std::pair<double, double>> clip_segment(
    const std::array<Eigen::Vector3d, 4>& x, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
    double min_length = 1e-12) {
  const Eigen::Vector4d ba = bary_by_volumes(x, a), bb = bary_by_volumes(x, b);
  double lo = 0.0, hi = 1.0;
  for (int k = 0; k < 4; ++k) {
    // b_k(lambda) = ba + lambda (bb - ba) >= 0
    const double s = bb[k] - ba[k];
    if (s == 0.0) {
      if (ba[k] < 0.0) return std::nullopt;
    } else if (s > 0.0) {
      lo = std::max(lo, -ba[k] / s);
    } else {
      hi = std::min(hi, -ba[k] / s);
    }
  }
  if (hi - lo < min_length) return std::nullopt;
  return std::make_pair(lo, hi);
}

struct Box3 {
  Eigen::Vector3d lo, hi;
  [[nodiscard]] bool overlaps(const Box3& o) const {
    return (lo.array() <= o.hi.array()).all() && (o.lo.array() <= hi.array()).all();
  }
};

inline Box3 tet_box(const Positions& pos, const Tet& t) {
  Box3 box{pos.col(t[0]), pos.col(t[0])};
  for (int k = 1; k < 4; ++k) {
    box.lo = box.lo.cwiseMin(pos.col(t[k]));
    box.hi = box.hi.cwiseMax(pos.col(t[k]));
  }
  return box;
}

/// Tets of a mesh using each edge of its topology (edge index -> sorted tet list).
inline std::vector<std::vector<Index>> edge_tets(const TetMesh& mesh, const Topology& topo) {
  std::vector<std::vector<Index>> out(topo.edges.size());
  for (Index t = 0; t < mesh.num_tets(); ++t)
    for (const auto& e : kTetEdges) {
      std::array<Index, 2> key{mesh.tets[t][e[0]], mesh.tets[t][e[1]]};
      if (key[0] > key[1]) std::swap(key[0], key[1]);
      const auto it = std::lower_bound(topo.edges.begin(), topo.edges.end(), key);
      out[static_cast<std::size_t>(it - topo.edges.begin())].push_back(t);
    }
  return out;
}

/// Nodes of X inside tets of Y (first containing tet in tet order, barycentric
/// coordinates >= -tol) and edges of X crossing tets of Y; fills `pairs` with the
/// overlapping (tet of X, tet of Y) pairs found through the edges.
inline void brute_force_one_way(const TestObject& x, const TestObject& y,
                                std::vector<IntrudingNode>& nodes,
                                std::vector<IntrudingEdge>& edges,
                                std::vector<std::pair<Index, Index>>& pairs, double tol = 1e-12) {
  const Positions& px = x.mesh.positions;
  const Positions& py = y.mesh.positions;
  std::vector<Box3> boxes;
  for (const Tet& t : y.mesh.tets) boxes.push_back(tet_box(py, t));
  for (Index i = 0; i < x.mesh.num_nodes(); ++i) {
    const Eigen::Vector3d p = px.col(i);
    for (Index t = 0; t < y.mesh.num_tets(); ++t) {
      if (!boxes[t].overlaps(Box3{p, p})) continue;
      const Eigen::Vector4d b = bary_by_volumes(tet_points(py, y.mesh.tets[t]), p);
      if (b.minCoeff() >= -tol) {
        nodes.push_back({i, t, b});
        break;
      }
    }
  }
  const auto tets_of_edge = edge_tets(x.mesh, x.topology);
  for (Index e = 0; e < static_cast<Index>(x.topology.edges.size()); ++e) {
    const Eigen::Vector3d a = px.col(x.topology.edges[e][0]);
    const Eigen::Vector3d b = px.col(x.topology.edges[e][1]);
    const Box3 eb{a.cwiseMin(b), a.cwiseMax(b)};
    for (Index t = 0; t < y.mesh.num_tets(); ++t) {
      if (!boxes[t].overlaps(eb)) continue;
      const auto clip = clip_segment(tet_points(py, y.mesh.tets[t]), a, b);
      if (!clip) continue;
      edges.push_back({e, t, clip->first, clip->second});
      for (const Index s : tets_of_edge[e]) pairs.emplace_back(s, t);
    }
  }
}

/// Brute-force PairContacts of (A, B), in the order and form detection documents.
inline PairContacts brute_force_contacts(const TestObject& a, const TestObject& b) {
  PairContacts c;
  std::vector<std::pair<Index, Index>> ab, ba;
  brute_force_one_way(a, b, c.nodes_a_in_b, c.edges_a_in_b, ab);
  brute_force_one_way(b, a, c.nodes_b_in_a, c.edges_b_in_a, ba);
  for (const auto& [tb, ta] : ba) ab.emplace_back(ta, tb);
  std::sort(ab.begin(), ab.end());
  ab.erase(std::unique(ab.begin(), ab.end()), ab.end());
  for (const auto& [ta, tb] : ab) {
    c.overlapping.push_back({ta, tb});
    c.marked_a.push_back(ta);
    c.marked_b.push_back(tb);
  }
  for (auto* m : {&c.marked_a, &c.marked_b}) {
    std::sort(m->begin(), m->end());
    m->erase(std::unique(m->begin(), m->end()), m->end());
  }
  return c;
}

/// Moves every node by `offset` and scales about the origin: x -> scale x + offset.
inline void transform(TetMesh& mesh, double scale, const Eigen::Vector3d& offset) {
  for (Index i = 0; i < mesh.num_nodes(); ++i)
    mesh.positions.col(i) = scale * mesh.positions.col(i) + offset;
}

}  // namespace tc::test
