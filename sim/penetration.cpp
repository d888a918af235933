#include "penetration.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <optional>
#include <unordered_map>

#include "core/depth/boundary_bvh.hpp"
#include "core/depth/depth_solver.hpp"
#include "core/depth/self_depth.hpp"

namespace tc::sim {
namespace {

struct Box {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  void grow(const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  [[nodiscard]] bool overlaps(const Box& o) const {
    return (lo.array() <= o.hi.array()).all() && (o.lo.array() <= hi.array()).all();
  }
  [[nodiscard]] bool contains(const Eigen::Vector3d& p) const {
    return (lo.array() <= p.array()).all() && (p.array() <= hi.array()).all();
  }
};

/// Uniform grid of one object's tet boxes for point location.
class TetGrid {
 public:
  TetGrid(const Eigen::Matrix3Xd& x, const std::vector<Tet>& tets, const Box& bounds) {
    double edge = 0.0;
    for (const Tet& t : tets) edge += (x.col(t[1]) - x.col(t[0])).norm();
    cell_ = std::max(1e-9, 1.5 * edge / static_cast<double>(std::max<std::size_t>(1, tets.size())));
    origin_ = bounds.lo;
    for (std::size_t i = 0; i < tets.size(); ++i) {
      Box b;
      for (const Index n : tets[i]) b.grow(x.col(n));
      const auto lo = key(b.lo);
      const auto hi = key(b.hi);
      for (auto a = lo[0]; a <= hi[0]; ++a)
        for (auto c = lo[1]; c <= hi[1]; ++c)
          for (auto d = lo[2]; d <= hi[2]; ++d)
            cells_[pack({a, c, d})].push_back(static_cast<Index>(i));
    }
  }
  [[nodiscard]] const std::vector<Index>* at(const Eigen::Vector3d& p) const {
    const auto it = cells_.find(pack(key(p)));
    return it == cells_.end() ? nullptr : &it->second;
  }

 private:
  [[nodiscard]] std::array<std::int64_t, 3> key(const Eigen::Vector3d& p) const {
    std::array<std::int64_t, 3> k{};
    for (int i = 0; i < 3; ++i)
      k[static_cast<std::size_t>(i)] =
          static_cast<std::int64_t>(std::floor((p[i] - origin_[i]) / cell_));
    return k;
  }
  static std::uint64_t pack(const std::array<std::int64_t, 3>& k) {
    return (static_cast<std::uint64_t>(k[0] & 0x1fffff) << 42) |
           (static_cast<std::uint64_t>(k[1] & 0x1fffff) << 21) |
           static_cast<std::uint64_t>(k[2] & 0x1fffff);
  }
  double cell_ = 1.0;
  Eigen::Vector3d origin_;
  std::unordered_map<std::uint64_t, std::vector<Index>> cells_;
};

}  // namespace

void PenetrationProbe::set_object(std::size_t i, const std::vector<Tet>& tets, Index n) {
  if (objects_.size() <= i) objects_.resize(i + 1);
  objects_[i].tets = tets;
  objects_[i].topology = build_topology(tets, n);
  const Topology& topo = objects_[i].topology;
  objects_[i].node_component.assign(static_cast<std::size_t>(n), -1);
  for (Index v = 0; v < n; ++v)
    if (!topo.node_tets.row(v).empty())
      objects_[i].node_component[static_cast<std::size_t>(v)] =
          topo.tet_component[static_cast<std::size_t>(topo.node_tets.row(v)[0])];
  objects_[i].ready = true;
}

namespace {

/// Barycentric coordinates of p in tet t (l0, l1, l2, l3); false for a flat tet.
bool barycentric_in(const Eigen::Matrix3Xd& x, const Tet& t, const Eigen::Vector3d& p,
                    Eigen::Vector4d& out) {
  Eigen::Matrix3d m;
  for (int c = 0; c < 3; ++c) m.col(c) = x.col(t[static_cast<std::size_t>(c + 1)]) - x.col(t[0]);
  if (!(std::abs(m.determinant()) > 0.0)) return false;
  const Eigen::Vector3d l = m.partialPivLu().solve(p - x.col(t[0]));
  out << 1.0 - l.sum(), l;
  return true;
}

}  // namespace

double PenetrationProbe::self_depth(std::size_t i, const Eigen::Matrix3Xd& x) const {
  if (i >= objects_.size() || !objects_[i].ready || objects_[i].tets.empty()) return 0.0;
  const Object& o = objects_[i];
  if (!x.allFinite()) return 0.0;
  Box bounds;
  for (Eigen::Index n = 0; n < x.cols(); ++n) bounds.grow(x.col(n));
  const TetGrid grid(x, o.tets, bounds);
  std::optional<BoundaryBvh<3>> faces;  // built at the first node inside
  double deepest = 0.0;
  for (Index v = 0; v < static_cast<Index>(x.cols()); ++v) {
    if (o.node_component[static_cast<std::size_t>(v)] < 0) continue;
    const Eigen::Vector3d p = x.col(v);
    const auto* cands = grid.at(p);
    if (cands == nullptr) continue;
    for (const Index t : *cands) {
      const Tet& tet = o.tets[static_cast<std::size_t>(t)];
      if (std::find(tet.begin(), tet.end(), v) != tet.end()) continue;
      Eigen::Vector4d l;
      constexpr double kTol = -1e-12;
      if (!barycentric_in(x, tet, p, l) || !(l.minCoeff() >= kTol)) continue;
      if (!faces) {
        faces.emplace();
        faces->build(o.topology.boundary_faces, x);
      }
      const double d = exact_self_depth(*faces, o.topology, o.node_component, x, v, t);
      if (std::isfinite(d)) deepest = std::max(deepest, d);
    }
  }
  return deepest;
}

std::vector<std::vector<double>> PenetrationProbe::measure(
    std::span<const Eigen::Matrix3Xd* const> positions) {
  const std::size_t k = std::min(positions.size(), objects_.size());
  std::vector<std::vector<double>> out(positions.size());
  std::vector<Box> boxes(k);
  for (std::size_t i = 0; i < positions.size(); ++i) {
    out[i].assign(static_cast<std::size_t>(positions[i]->cols()), 0.0);
    if (i < k)
      for (Eigen::Index n = 0; n < positions[i]->cols(); ++n) boxes[i].grow(positions[i]->col(n));
  }
  for (std::size_t b = 0; b < k; ++b) {
    if (!objects_[b].ready || objects_[b].tets.empty()) continue;  // a shell holds no one
    bool any = false;
    for (std::size_t a = 0; a < k && !any; ++a) any = a != b && boxes[a].overlaps(boxes[b]);
    if (!any) continue;
    TetMesh mesh;
    mesh.positions = *positions[b];
    mesh.tets = objects_[b].tets;
    const auto depth = compute_depth_exact(mesh, objects_[b].topology);
    if (!depth) continue;  // non-finite positions: nothing to measure
    const TetGrid grid(mesh.positions, mesh.tets, boxes[b]);
    for (std::size_t a = 0; a < k; ++a) {
      if (a == b || !boxes[a].overlaps(boxes[b])) continue;
      const Eigen::Matrix3Xd& pa = *positions[a];
      for (Eigen::Index n = 0; n < pa.cols(); ++n) {
        const Eigen::Vector3d p = pa.col(n);
        if (!boxes[b].contains(p)) continue;
        const auto* cands = grid.at(p);
        if (cands == nullptr) continue;
        for (const Index t : *cands) {
          const Tet& tet = mesh.tets[static_cast<std::size_t>(t)];
          Eigen::Matrix3d m;
          for (int c = 0; c < 3; ++c)
            m.col(c) = mesh.positions.col(tet[c + 1]) - mesh.positions.col(tet[0]);
          const Eigen::Vector3d l = m.partialPivLu().solve(p - mesh.positions.col(tet[0]));
          const double l0 = 1.0 - l.sum();
          constexpr double kTol = -1e-12;
          if (!(l0 >= kTol && l[0] >= kTol && l[1] >= kTol && l[2] >= kTol)) continue;
          const auto& d = *depth;
          const double v = l0 * d[static_cast<std::size_t>(tet[0])] +
                           l[0] * d[static_cast<std::size_t>(tet[1])] +
                           l[1] * d[static_cast<std::size_t>(tet[2])] +
                           l[2] * d[static_cast<std::size_t>(tet[3])];
          auto& slot = out[a][static_cast<std::size_t>(n)];
          if (std::isfinite(v)) slot = std::max(slot, v);
          break;
        }
      }
    }
  }
  return out;
}

}  // namespace tc::sim
