#include "core/mesh/surface_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

namespace tc {
namespace {

/// Root of `i` in a union-find forest, halving paths on the way.
Index find_root(std::vector<Index>& parent, Index i) {
  while (parent[static_cast<std::size_t>(i)] != i) {
    auto& p = parent[static_cast<std::size_t>(i)];
    p = parent[static_cast<std::size_t>(p)];
    i = p;
  }
  return i;
}

}  // namespace

double triangle_quality(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                        const Eigen::Vector3d& x2) {
  const Eigen::Vector3d e01 = x1 - x0, e02 = x2 - x0, e12 = x2 - x1;
  const double l2 = e01.squaredNorm() + e02.squaredNorm() + e12.squaredNorm();
  if (!(l2 > 0.0)) return 0.0;
  const double area = 0.5 * e01.cross(e02).norm();
  return 4.0 * std::sqrt(3.0) * area / l2;
}

std::string SurfaceValidationReport::summary() const {
  std::ostringstream out;
  if (too_many_nodes) out << nodes << " nodes, more than the limit";
  if (too_many_triangles) {
    if (out.tellp() > 0) out << "; ";
    out << triangles << " triangles, more than the limit";
  }
  append_defects(out, index_out_of_range, "triangles with a node index out of range");
  append_defects(out, repeated_node, "triangles with a repeated node");
  append_defects(out, nonfinite_node, "nodes with non-finite coordinates");
  append_defects(out, degenerate, "degenerate (zero-area) triangles");
  return out.str();
}

SurfaceValidationReport validate_surface(const SurfaceMesh& mesh,
                                         const SurfaceValidationOptions& options) {
  return validate_surface(mesh.positions, mesh.triangles, options);
}

SurfaceValidationReport validate_surface(const Positions& p, std::span<const Triangle> triangles,
                                         const SurfaceValidationOptions& options) {
  SurfaceValidationReport report;
  report.nodes = p.cols();
  report.triangles = static_cast<std::int64_t>(triangles.size());
  report.too_many_nodes = report.nodes > options.max_nodes;
  report.too_many_triangles = report.triangles > options.max_triangles;
  if (report.oversized()) return report;
  const auto n = static_cast<Index>(p.cols());
  for (Index i = 0; i < n; ++i)
    if (!p.col(i).allFinite()) report.nonfinite_node.add(i, options.max_listed);
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const Triangle& tri = triangles[t];
    const auto ti = static_cast<Index>(t);
    if (!std::all_of(tri.begin(), tri.end(), [n](Index v) { return v >= 0 && v < n; })) {
      report.index_out_of_range.add(ti, options.max_listed);
      continue;
    }
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) {
      report.repeated_node.add(ti, options.max_listed);
      continue;
    }
    if (!(p.col(tri[0]).allFinite() && p.col(tri[1]).allFinite() && p.col(tri[2]).allFinite()))
      continue;
    const double q = triangle_quality(p.col(tri[0]), p.col(tri[1]), p.col(tri[2]));
    report.min_quality = std::min(report.min_quality, q);
    if (!(q >= options.degenerate_quality)) report.degenerate.add(ti, options.max_listed);
  }
  return report;
}

Status require_valid_surface(const SurfaceValidationReport& report, const std::string& what) {
  if (report.clean()) return {};
  return Error{report.oversized() ? ErrorCode::kOversized : ErrorCode::kInvalidMesh,
               what + ": " + report.summary()};
}

SurfaceEdges build_surface_edges(std::span<const Triangle> triangles) {
  // (min node, max node, triangle * 3 + local edge), sorted: equal edges are adjacent.
  struct Half {
    Index a, b;
    std::int64_t slot;
    bool forward;
  };
  std::vector<Half> halves;
  halves.reserve(3 * triangles.size());
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Index u = triangles[t][static_cast<std::size_t>(k)];
      const Index v = triangles[t][static_cast<std::size_t>((k + 1) % 3)];
      halves.push_back(
          {std::min(u, v), std::max(u, v), static_cast<std::int64_t>(3 * t) + k, u < v});
    }
  std::sort(halves.begin(), halves.end(), [](const Half& x, const Half& y) {
    return x.a != y.a ? x.a < y.a : (x.b != y.b ? x.b < y.b : x.slot < y.slot);
  });
  SurfaceEdges out;
  out.triangle_edges.resize(triangles.size());
  for (std::size_t i = 0; i < halves.size(); ++i) {
    const Half& h = halves[i];
    if (i == 0 || h.a != halves[i - 1].a || h.b != halves[i - 1].b) {
      out.edges.push_back({h.a, h.b});
      out.triangle_count.push_back(0);
      out.forward_count.push_back(0);
    }
    const auto e = static_cast<Index>(out.edges.size() - 1);
    ++out.triangle_count.back();
    if (h.forward) ++out.forward_count.back();
    out.triangle_edges[static_cast<std::size_t>(h.slot / 3)][static_cast<std::size_t>(h.slot % 3)] =
        e;
  }
  return out;
}

SurfaceStats compute_surface_stats(const SurfaceMesh& mesh, const SurfaceEdges& edges,
                                   const SurfaceValidationReport& report) {
  SurfaceStats s;
  const Positions& p = mesh.positions;
  s.nodes = mesh.num_nodes();
  s.triangles = mesh.num_triangles();
  s.edges = static_cast<Index>(edges.edges.size());
  s.degenerate_triangles = report.degenerate.count;
  s.min_quality = mesh.triangles.empty() ? 0.0 : report.min_quality;
  for (std::size_t e = 0; e < edges.edges.size(); ++e) {
    const Index count = edges.triangle_count[e];
    if (count == 1) ++s.boundary_edges;
    if (count > 2) ++s.nonmanifold_edges;
    if (count == 2 && edges.forward_count[e] != 1) ++s.misoriented_edges;
  }
  std::vector<std::uint8_t> used(static_cast<std::size_t>(s.nodes), 0);
  for (const Triangle& t : mesh.triangles)
    for (const Index v : t) used[static_cast<std::size_t>(v)] = 1;
  bool any = false;
  for (Index i = 0; i < s.nodes; ++i) {
    if (!used[static_cast<std::size_t>(i)]) {
      ++s.unused_nodes;
      continue;
    }
    if (!any) s.bbox_lo = s.bbox_hi = p.col(i);
    any = true;
    s.bbox_lo = s.bbox_lo.cwiseMin(p.col(i));
    s.bbox_hi = s.bbox_hi.cwiseMax(p.col(i));
  }
  // Components: triangles joined through shared edges (union-find over triangles).
  std::vector<Index> parent(mesh.triangles.size());
  std::iota(parent.begin(), parent.end(), Index{0});
  std::vector<Index> first_of_edge(edges.edges.size(), -1);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (const Index e : edges.triangle_edges[t]) {
      Index& f = first_of_edge[static_cast<std::size_t>(e)];
      if (f < 0) {
        f = static_cast<Index>(t);
        continue;
      }
      const Index ra = find_root(parent, f), rb = find_root(parent, static_cast<Index>(t));
      if (ra != rb) parent[static_cast<std::size_t>(std::max(ra, rb))] = std::min(ra, rb);
    }
  for (std::size_t t = 0; t < parent.size(); ++t)
    if (find_root(parent, static_cast<Index>(t)) == static_cast<Index>(t)) ++s.components;
  // Area, and the signed volume relative to the box centre (small differences, small
  // rounding, whatever the offset of the object).
  const Eigen::Vector3d c = 0.5 * (s.bbox_lo + s.bbox_hi);
  double signed6 = 0.0;
  for (const Triangle& t : mesh.triangles) {
    const Eigen::Vector3d a = p.col(t[0]) - c, b = p.col(t[1]) - c, d = p.col(t[2]) - c;
    s.area += 0.5 * (b - a).cross(d - a).norm();
    signed6 += a.dot(b.cross(d));
  }
  s.closed = !mesh.triangles.empty() && s.boundary_edges == 0 && s.nonmanifold_edges == 0;
  s.oriented = s.closed && s.misoriented_edges == 0;
  if (s.oriented) {
    s.enclosed_volume = std::abs(signed6) / 6.0;
    s.outward = signed6 > 0.0;
  }
  return s;
}

}  // namespace tc
