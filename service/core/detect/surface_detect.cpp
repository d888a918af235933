#include "core/detect/surface_detect.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/common/chunked.hpp"
#include "core/detect/broad_phase.hpp"
#include "core/detect/edge_hits.hpp"
#include "core/detect/tri_tet_overlap.hpp"

namespace tc {
namespace {

using Eigen::Vector3d;

constexpr double kEps = std::numeric_limits<double>::epsilon();
/// Items per chunk of the deterministic parallel loops (independent of the thread count).
constexpr std::size_t kChunk = 256;

Aabb finite_box(const Positions& p) {
  Aabb box;
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    if (p.col(i).allFinite()) box.extend(Vector3d(p.col(i)));
  return box;
}

TriangleCorners triangle_corners(const Positions& p, const Triangle& t) {
  return {p.col(t[0]), p.col(t[1]), p.col(t[2])};
}

bool finite(const TriangleCorners& t) {
  return t[0].allFinite() && t[1].allFinite() && t[2].allFinite();
}
bool finite(const TetCorners& t) {
  return t[0].allFinite() && t[1].allFinite() && t[2].allFinite() && t[3].allFinite();
}

template <std::size_t N>
Aabb corner_box(const std::array<Vector3d, N>& c) {
  Aabb box;
  for (const Vector3d& x : c) box.extend(x);
  return box;
}

/// The items whose box meets `region` (sorted) and their boxes cut to it. A point common
/// to a triangle and a tet lies in both object boxes, so in both cut boxes: the cut loses
/// no pair, and exact min/max need no padding.
template <typename BoxOf>
void in_region(std::size_t count, const Aabb& region, const BoxOf& box_of,
               std::vector<Index>& items, std::vector<Aabb>& boxes) {
  const std::size_t chunks = detail::num_chunks(count, kChunk);
  std::vector<std::vector<Index>> item_parts(chunks);
  std::vector<std::vector<Aabb>> box_parts(chunks);
  detail::for_chunks(count, kChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
    for (std::size_t i = begin; i < end; ++i) {
      const Aabb box = box_of(i);
      if (box.empty() || !box.overlaps(region)) continue;
      item_parts[c].push_back(static_cast<Index>(i));
      box_parts[c].push_back(box.intersection(region));
    }
  });
  items.clear();
  boxes.clear();
  for (std::size_t c = 0; c < chunks; ++c) {
    items.insert(items.end(), item_parts[c].begin(), item_parts[c].end());
    boxes.insert(boxes.end(), box_parts[c].begin(), box_parts[c].end());
  }
}

/// (key, item) pairs grouped by key: keys ascending, each key's items ascending. Sized
/// by the pairs (the contact), not by the object, so a frame allocates nothing per node.
struct Groups {
  std::vector<Index> keys;
  std::vector<std::size_t> begin;  ///< keys.size() + 1 offsets into items
  std::vector<Index> items;
  [[nodiscard]] std::span<const Index> items_of(std::size_t g) const {
    return {items.data() + begin[g], begin[g + 1] - begin[g]};
  }
};

Groups group_pairs(std::vector<std::pair<Index, Index>>& pairs) {
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  Groups g;
  g.items.reserve(pairs.size());
  for (const auto& [key, item] : pairs) {
    if (g.keys.empty() || g.keys.back() != key) {
      g.keys.push_back(key);
      g.begin.push_back(g.items.size());
    }
    g.items.push_back(item);
  }
  g.begin.push_back(g.items.size());
  return g;
}

}  // namespace

SurfaceContacts detect_surface_tets(const Positions& surface_positions,
                                    std::span<const Triangle> triangles, const SurfaceEdges& edges,
                                    const Positions& tet_positions, std::span<const Tet> tets,
                                    const DetectOptions& options, SurfaceDetectStats* stats,
                                    std::span<const Index> left_out_tets) {
  if (edges.triangle_edges.size() != triangles.size())
    throw std::invalid_argument("detect_surface_tets: edges were built from other triangles");
  SurfaceContacts out;
  SurfaceDetectStats local_stats;
  SurfaceDetectStats& st = stats != nullptr ? *stats : local_stats;
  st = {};
  const double rel = options.relative_tolerance > 0.0 ? options.relative_tolerance : 0.0;
  const Aabb region = finite_box(surface_positions).intersection(finite_box(tet_positions));
  st.boxes_overlap = !region.empty();
  if (!st.boxes_overlap) return out;

  // ---- broad phase: triangle boxes against tet boxes, both cut to the overlap box.
  std::vector<Index> tris_in, tets_in;
  std::vector<Aabb> tri_boxes, tet_boxes;
  in_region(
      triangles.size(), region,
      [&](std::size_t i) {
        const TriangleCorners c = triangle_corners(surface_positions, triangles[i]);
        return finite(c) ? corner_box(c) : Aabb{};
      },
      tris_in, tri_boxes);
  in_region(
      tets.size(), region,
      [&](std::size_t i) {
        if (!left_out_tets.empty() &&
            std::binary_search(left_out_tets.begin(), left_out_tets.end(), static_cast<Index>(i)))
          return Aabb{};  // left out: in no candidate pair
        const TetCorners c = tet_corners(tet_positions, tets[i]);
        return finite(c) ? corner_box(c) : Aabb{};
      },
      tets_in, tet_boxes);
  st.triangles_in_box = tris_in.size();
  st.tets_in_box = tets_in.size();
  if (tris_in.empty() || tets_in.empty()) return out;
  std::vector<BoundingSphere> tri_spheres;
  TetBounds tet_bounds;
  if (options.broad_phase == BroadPhaseKind::kGrid) {
    // The paper's grid rounds elements by spheres: centroid, farthest corner, a hair more.
    tri_spheres.resize(triangles.size());
    for (const Index t : tris_in) {
      const TriangleCorners c = triangle_corners(surface_positions, triangles[t]);
      const Vector3d center = (c[0] + c[1] + c[2]) / 3.0;
      const double r2 =
          std::max(std::max((c[0] - center).squaredNorm(), (c[1] - center).squaredNorm()),
                   (c[2] - center).squaredNorm());
      tri_spheres[static_cast<std::size_t>(t)] = {center, std::sqrt(r2) * (1.0 + 16.0 * kEps)};
    }
    tet_bounds.compute(tet_positions, tets, tets_in, true);
  }
  AabbTree tree;
  BvhSide bvh;
  if (options.broad_phase == BroadPhaseKind::kBvh) {
    tree.build(tet_boxes);
    bvh = {&tree, tet_boxes, {}, true};
  }
  std::vector<TetPair> candidates;
  BroadPhase broad;
  broad.find_pairs(options.broad_phase, {tris_in, tri_boxes, tri_spheres},
                   {tets_in, tet_boxes, tet_bounds.spheres}, bvh, candidates);
  st.candidates = candidates.size();

  // ---- narrow phase: the geometry of each tet in a candidate once, then the exact test.
  std::vector<Index> cand_tets;
  for (const TetPair& p : candidates) cand_tets.push_back(p.tet_b);
  std::sort(cand_tets.begin(), cand_tets.end());
  cand_tets.erase(std::unique(cand_tets.begin(), cand_tets.end()), cand_tets.end());
  std::vector<TetGeometry> geom(cand_tets.size());
  detail::for_chunks(
      cand_tets.size(), kChunk, [&](std::size_t begin, std::size_t end, std::size_t) {
        for (std::size_t i = begin; i < end; ++i)
          make_tet_geometry(
              tet_corners(tet_positions, tets[static_cast<std::size_t>(cand_tets[i])]), geom[i]);
      });
  // Found by binary search in the sorted candidate tets: no per-frame array over all tets.
  const auto geometry_of = [&](Index tet) -> const TetGeometry& {
    const auto it = std::lower_bound(cand_tets.begin(), cand_tets.end(), tet);
    return geom[static_cast<std::size_t>(it - cand_tets.begin())];
  };
  {
    const std::size_t chunks = detail::num_chunks(candidates.size(), kChunk);
    std::vector<std::vector<TriTetPair>> parts(chunks);
    detail::for_chunks(
        candidates.size(), kChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
          for (std::size_t i = begin; i < end; ++i) {
            const TetPair& p = candidates[i];
            const TriangleCorners t =
                triangle_corners(surface_positions, triangles[static_cast<std::size_t>(p.tet_a)]);
            const TetGeometry& g = geometry_of(p.tet_b);
            const double scale = pair_scale(t, g.v);
            if (triangle_tet_overlap(t, g, rel * scale)) parts[c].push_back({p.tet_a, p.tet_b});
          }
        });
    for (const auto& part : parts)
      out.overlapping.insert(out.overlapping.end(), part.begin(), part.end());
  }
  st.overlapping = out.overlapping.size();
  if (out.overlapping.empty()) return out;

  // ---- marked elements; rows: the tets each marked triangle overlaps (sorted), the
  //      overlapping pairs from row_begin[r] to row_begin[r + 1] for marked triangle r.
  std::vector<std::size_t> row_begin;
  for (std::size_t i = 0; i < out.overlapping.size(); ++i) {
    const Index t = out.overlapping[i].triangle;
    if (out.marked_triangles.empty() || out.marked_triangles.back() != t) {
      out.marked_triangles.push_back(t);
      row_begin.push_back(i);
    }
    out.marked_tets.push_back(out.overlapping[i].tet);
  }
  row_begin.push_back(out.overlapping.size());
  std::sort(out.marked_tets.begin(), out.marked_tets.end());
  out.marked_tets.erase(std::unique(out.marked_tets.begin(), out.marked_tets.end()),
                        out.marked_tets.end());
  // `triangle` is a marked one (the tables below list only those).
  const auto row = [&](Index triangle) -> std::span<const TriTetPair> {
    const auto r = static_cast<std::size_t>(
        std::lower_bound(out.marked_triangles.begin(), out.marked_triangles.end(), triangle) -
        out.marked_triangles.begin());
    return {out.overlapping.data() + row_begin[r], row_begin[r + 1] - row_begin[r]};
  };

  // ---- surface nodes inside tets.
  if (options.intruding_nodes) {
    std::vector<std::pair<Index, Index>> pairs;  // (node, marked triangle)
    pairs.reserve(3 * out.marked_triangles.size());
    for (const Index t : out.marked_triangles)
      for (const Index v : triangles[static_cast<std::size_t>(t)]) pairs.emplace_back(v, t);
    const Groups node_tris = group_pairs(pairs);
    const std::vector<Index>& nodes = node_tris.keys;
    const std::size_t chunks = detail::num_chunks(nodes.size(), kChunk);
    std::vector<std::vector<IntrudingNode>> parts(chunks);
    detail::for_chunks(nodes.size(), kChunk,
                       [&](std::size_t begin, std::size_t end, std::size_t c) {
                         for (std::size_t i = begin; i < end; ++i) {
                           const Index node = nodes[i];
                           const Vector3d p = surface_positions.col(node);
                           if (!p.allFinite()) continue;
                           // The first tet in tet order containing the node, among the tets its
                           // marked triangles overlap; rows are sorted, so a row stops at the best
                           // found so far.
                           Index best = std::numeric_limits<Index>::max();
                           Eigen::Vector4d bary = Eigen::Vector4d::Zero();
                           for (const Index t : node_tris.items_of(i))
                             for (const TriTetPair& pair : row(t)) {
                               if (pair.tet >= best) break;
                               const TetGeometry& g = geometry_of(pair.tet);
                               const double tol = rel * g.scale;
                               if (!((p.array() >= g.lo.array() - tol).all() &&
                                     (p.array() <= g.hi.array() + tol).all()))
                                 continue;
                               const PointInTet hit = point_in_tet(p, g, tol);
                               if (hit.inside) {
                                 best = pair.tet;
                                 bary = hit.bary;
                                 break;
                               }
                             }
                           if (best != std::numeric_limits<Index>::max())
                             parts[c].push_back({node, best, bary});
                         }
                       });
    for (const auto& part : parts)
      out.nodes_in_tets.insert(out.nodes_in_tets.end(), part.begin(), part.end());
  }

  // ---- surface edges clipped by tets.
  if (options.intruding_edges) {
    std::vector<std::pair<Index, Index>> pairs;  // (edge, marked triangle)
    pairs.reserve(3 * out.marked_triangles.size());
    for (const Index t : out.marked_triangles)
      for (const Index e : edges.triangle_edges[static_cast<std::size_t>(t)])
        pairs.emplace_back(e, t);
    const Groups edge_tris = group_pairs(pairs);
    const std::vector<Index>& feature_edges = edge_tris.keys;
    const std::size_t chunks = detail::num_chunks(feature_edges.size(), kChunk);
    std::vector<std::vector<IntrudingEdge>> parts(chunks);
    detail::for_chunks(
        feature_edges.size(), kChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
          std::vector<Index> near;
          std::vector<detail::EdgeHit> hits;
          std::vector<IntrudingEdge>& part = parts[c];
          for (std::size_t i = begin; i < end; ++i) {
            const Index edge = feature_edges[i];
            const auto& ends = edges.edges[static_cast<std::size_t>(edge)];
            const Vector3d p0 = surface_positions.col(ends[0]), p1 = surface_positions.col(ends[1]);
            const double length = (p1 - p0).norm();
            if (!std::isfinite(length)) continue;
            const Vector3d lo = p0.cwiseMin(p1), hi = p0.cwiseMax(p1);
            // Every tet overlapped by a marked triangle around the edge, once.
            near.clear();
            for (const Index t : edge_tris.items_of(i))
              for (const TriTetPair& pair : row(t)) near.push_back(pair.tet);
            std::sort(near.begin(), near.end());
            near.erase(std::unique(near.begin(), near.end()), near.end());
            hits.clear();
            for (const Index tet : near) {
              const TetGeometry& g = geometry_of(tet);
              const double tol = rel * std::max(g.scale, length);
              if (!((lo.array() <= g.hi.array() + tol).all() &&
                    (hi.array() >= g.lo.array() - tol).all()))
                continue;
              const SegmentClip clip = clip_segment_tet(p0, p1, g, tol);
              if (clip.hit)
                hits.push_back({{edge, tet, clip.lambda_in, clip.lambda_out}, tol / length});
            }
            detail::append_edge_hits(hits, part);
          }
        });
    for (const auto& part : parts)
      out.edges_in_tets.insert(out.edges_in_tets.end(), part.begin(), part.end());
  }
  return out;
}

PairContacts to_pair_contacts(SurfaceContacts contacts, bool surface_is_a) {
  PairContacts out;
  out.overlapping.reserve(contacts.overlapping.size());
  for (const TriTetPair& p : contacts.overlapping)
    out.overlapping.push_back(surface_is_a ? TetPair{p.triangle, p.tet}
                                           : TetPair{p.tet, p.triangle});
  if (!surface_is_a) std::sort(out.overlapping.begin(), out.overlapping.end());
  (surface_is_a ? out.marked_a : out.marked_b) = std::move(contacts.marked_triangles);
  (surface_is_a ? out.marked_b : out.marked_a) = std::move(contacts.marked_tets);
  (surface_is_a ? out.nodes_a_in_b : out.nodes_b_in_a) = std::move(contacts.nodes_in_tets);
  (surface_is_a ? out.edges_a_in_b : out.edges_b_in_a) = std::move(contacts.edges_in_tets);
  return out;
}

}  // namespace tc
