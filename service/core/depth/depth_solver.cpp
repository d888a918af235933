// Depth-map solver. Layout and queue were chosen by measurement (docs/DEPTH_MAPS.md,
// "Performance"): on a 55k-node mesh the march is bound by memory latency, so
//  - nodes are renumbered once per topology in breadth-first order from the boundary
//    (boundary nodes first, then layer after layer): the front of the march and the
//    closest points it carries stay in a compact range of memory (depth_layout.cpp
//    builds that layout; this file holds the per-frame march and reads it);
//  - the march reads one 16-byte record per node {x, y, z, key} in float, coordinates
//    relative to a node of the object (so offsets of 1e6 cost no precision); the sign
//    bit of `key` marks a final node, so "is the neighbour final?" costs nothing;
//  - the default queue is a FIFO bucket queue, whose pop order follows push order;
//  - final depths are recomputed in double from the original positions after the
//    march: a CPFM/CFFM depth is exactly the distance to a true boundary point.
#include "core/depth/depth_solver.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>

#include "core/depth/boundary_bvh.hpp"
#include "core/depth/depth_layout.hpp"
#include "core/depth/point_simplex_distance.hpp"
#include "core/depth/priority_queues.hpp"

namespace tc {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr float kInfF = std::numeric_limits<float>::infinity();
/// Upper bound on the steps of one CFFM descent (each step strictly lowers the
/// distance; in practice 0 to 3 steps are taken).
constexpr int kMaxDescentSteps = 32;
/// kNearStarts: a settled neighbour's feature is walked from when its distance is at
/// most this fraction above the best so far (measured: 0 leaves the torus at 0.83% max
/// error, 0.05 reaches kMultiStart's 0.47%; docs/DEPTH_MAPS.md).
constexpr float kNearStartSlack = 0.05f;
/// How many pops ahead the bucket queue's nodes are prefetched (measured).
constexpr std::size_t kPrefetchFar = 12;
constexpr std::size_t kPrefetchMid = 8;
constexpr std::size_t kPrefetchNear = 4;
/// Local lazy runs: the first cell side, in units of the largest marked element's box
/// extent; the growth of the side when a round cannot certify its depths; the rounds
/// tried before the whole object is marched (docs/DEPTH_MAPS.md, "Local lazy runs").
constexpr double kLocalStartFactor = 2.0;
constexpr double kLocalGrowth = 1.5;
/// A region whose deepest marked node was d is marched again with side this times d.
constexpr double kLocalRepeatFactor = 1.05;
constexpr int kMaxLocalRounds = 6;
/// A region of more than 1/kWholeFraction of the nodes is not finished: the whole run
/// costs less (a region node costs about twice a whole run's node; bench_distance
/// lazy/large/cpfm/bottom_10pct: 12.4 ms for a 51% region, 11.6 ms whole).
constexpr std::size_t kWholeFraction = 3;
/// A region has at least this many nodes per marked node (measured: 5.4 on the pawn's
/// press, 4.6-8 on the slab tests), so more marked nodes than 1/(3 x 4) of the nodes go
/// straight to the whole run.
constexpr std::size_t kRegionPerMarked = 4;
/// Most grid cells a local run's region may use (its cells grow beyond this).
constexpr std::size_t kMaxRegionCells = std::size_t{1} << 18;
/// How many nodes ahead the region's flood prefetches (measured on the pawn).
constexpr std::size_t kRegionPrefetchFar = 8;
constexpr std::size_t kRegionPrefetchNear = 3;

template <int D>
using Vecf = Eigen::Matrix<float, D, 1>;
template <int D>
using Vecd = Eigen::Matrix<double, D, 1>;

/// Per-node record of the march: position (float, relative to a reference node) and
/// key = tentative squared distance; a final node stores -key (sign bit set).
template <int D>
struct Rec {
  float x[D];
  float key;
};

template <int D>
inline Vecf<D> pos_of(const Rec<D>& r) {
  return Eigen::Map<const Vecf<D>>(r.x);
}

inline bool is_final(float key) {
  return std::signbit(key);
}

/// Distance from p to a simplex (triangle for D = 3, segment for D = 2).
template <int D, typename Scalar>
inline BasicFeatureDistance<Scalar> simplex_distance(const Eigen::Matrix<Scalar, D, 1>& p,
                                                     const Eigen::Matrix<Scalar, D, 1>* c) {
  if constexpr (D == 3) {
    return point_triangle_distance(p, c[0], c[1], c[2]);
  } else {
    return point_segment_distance(p, c[0], c[1]);
  }
}

/// Closest point of a simplex to p.
template <int D, typename Scalar>
inline ClosestPoint<Eigen::Matrix<Scalar, D, 1>> simplex_closest_point(
    const Eigen::Matrix<Scalar, D, 1>& p, const Eigen::Matrix<Scalar, D, 1>* c) {
  if constexpr (D == 3) {
    return closest_point_triangle(p, c[0], c[1], c[2]);
  } else {
    return closest_point_segment(p, c[0], c[1]);
  }
}

/// What a march propagates (docs/DEPTH_MAPS.md):
enum class Mode {
  kPoint,                ///< CPFM: the closest boundary node
  kFeaturePaper,         ///< CFFM as in the paper: a feature, ring seeding
  kFeaturePaperDescent,  ///< the same plus the descent when a node is finalised
  kFeatureDescent,       ///< a feature and its closest point; descent when finalised
  kFeatureMultiStart,    ///< kFeatureDescent, plus descents from every settled
                         ///< neighbour's feature
  kFeatureNearStarts,    ///< kFeatureDescent, plus descents from the settled
                         ///< neighbours' features nearly as near as the best
};

/// True for the modes that carry a closest point per node.
constexpr bool carries_point(Mode m) {
  return m == Mode::kFeatureDescent || m == Mode::kFeatureMultiStart ||
         m == Mode::kFeatureNearStarts;
}

using QueueVariant = std::variant<detail::BucketQueue, detail::RadixHeap, detail::BinaryHeapQueue>;

QueueVariant make_queue(const DepthSolverOptions& options) {
  switch (options.queue) {
    case QueueKind::kRadix:
      return detail::RadixHeap{};
    case QueueKind::kBinaryHeap:
      return detail::BinaryHeapQueue{};
    case QueueKind::kBucket:
      break;
  }
  return detail::BucketQueue{options.bucket_width};
}

}  // namespace

template <int D>
struct BasicDepthSolver<D>::Impl {
  DepthSolverOptions options;
  /// The topology's numbering and features, built once (depth_layout.hpp).
  const detail::DepthLayout<D> layout;

  // Per-frame buffers.
  std::vector<Rec<D>> rec;     ///< internal
  std::vector<Index> feature;  ///< internal: CPFM closest boundary node, CFFM simplex
  std::vector<Vecf<D>> point;  ///< internal, kFeatureDescent: closest point on `feature`
  /// CFFM, per feature and frame: corners, a normal of its plane (line in 2D), and the
  /// far node of the feature across each side j (so the features across its sides are
  /// evaluated from this one record: they share side j's nodes).
  struct FeatureFrame {
    Vecf<D> c[D];
    Vecf<D> far[D];
    Vecf<D> normal;
  };
  std::vector<FeatureFrame> frames;
  /// A node with a non-finite coordinate met by a local run's feature records, or -1.
  Index bad_node = -1;
  /// The positions of the run (D x n, original order): lazily filled feature records
  /// and the final depths read them.
  const Points* cur = nullptr;
  Vecd<D> ref = Vecd<D>::Zero();  ///< the origin of the float records (node perm[0])
  /// CFFM feature records filled this run: frame_mark[t] == frame_stamp (a local run
  /// fills only the features it reads).
  std::vector<std::uint32_t> frame_mark;
  std::uint32_t frame_stamp = 0;
  // Local lazy runs (LazyRegion::kLocal): the region is the nodes reached from the
  // marked nodes by edges without leaving the cells (of side `margin`) next to a cell
  // holding a marked node.
  std::vector<std::uint32_t> region_mark;  ///< internal: == region_stamp inside the region
  std::vector<std::uint32_t> tested_mark;  ///< internal: == region_stamp once looked at
  std::uint32_t region_stamp = 0;
  bool local_run = false;          ///< the march runs on the region only
  std::vector<Index> region;       ///< internal, in the order the flood reached them
  std::vector<Index> seeds;        ///< the region's boundary nodes, sorted
  std::vector<std::uint8_t> grid;  ///< the region's cells (build_region)
  std::vector<Index> written;      ///< original nodes whose depth or anchor the last run wrote
  double last_deepest = 0.0;       ///< deepest marked node of the last certified local run
  LazyStats lazy_stats;
  std::vector<Index> settled_list;
  std::vector<detail::QueueEntry> stage;
  std::vector<double> depth;        ///< original order
  std::vector<Index> anchor;        ///< original order: see BasicDepthSolver::anchor()
  std::vector<std::uint32_t> mark;  ///< internal
  std::uint32_t stamp = 0;
  std::vector<Index> marked;
  std::size_t settled = 0;
  QueueVariant queue;
  BoundaryBvh<D> bvh;

  // The layout of the topology, then the per-frame buffers sized for it.
  Impl(std::span<const Element> elems, const TopologyOf<D>& topo, DepthSolverOptions opts)
      : options(opts), layout(elems, topo) {
    const auto nn = static_cast<std::size_t>(layout.n);
    rec.assign(nn, Rec<D>{});
    for (auto& r : rec) r.key = kInfF;
    feature.assign(nn, -1);
    if (options.method == DepthMethod::kCffm &&
        (options.cffm == CffmVariant::kDescent || options.cffm == CffmVariant::kMultiStart ||
         options.cffm == CffmVariant::kNearStarts))
      point.assign(nn, Vecf<D>::Zero());
    depth.assign(nn, kInf);
    anchor.assign(nn, -1);
    if (options.method == DepthMethod::kCffm) {  // CPFM reads no feature records
      frame_mark.assign(layout.surface.simplices.size(), 0);
      frames.resize(layout.surface.simplices.size());
    }
    region_mark.assign(nn, 0);
    tested_mark.assign(nn, 0);
    mark.assign(nn, 0);
    settled_list.reserve(nn);
    queue = make_queue(options);
  }

  Status check_size(const Points& positions) const {
    if (positions.cols() != layout.n)
      return Error{ErrorCode::kInvalidArgument,
                   "positions have " + std::to_string(positions.cols()) +
                       " columns, the topology has " + std::to_string(layout.n) + " nodes"};
    return {};
  }

  static Error non_finite(Index node) {
    return Error{ErrorCode::kInvalidArgument,
                 "node " + std::to_string(node) + " has a non-finite coordinate"};
  }

  // Starts a run on `p`: checks its size, takes the origin of the float records (node
  // perm[0]) and forgets the feature records of the previous run.
  Status begin_run(const Points& p) {
    if (Status st = check_size(p); !st) return st;
    cur = &p;
    if (++frame_stamp == 0) {  // wrapped: forget the old marks
      std::fill(frame_mark.begin(), frame_mark.end(), 0u);
      frame_stamp = 1;
    }
    if (layout.num_used == 0) return {};
    ref = p.col(layout.perm[0]);
    if (!ref.allFinite()) return non_finite(layout.perm[0]);
    return {};
  }

  // Position of internal node i relative to the origin, in float (what the march reads).
  Vecf<D> float_pos(Index i) const {
    return (cur->col(layout.perm[i]) - ref).template cast<float>();
  }

  // Node i's record: position x (metres) relative to the origin, key +infinity.
  void store_rec(Index i, const Vecd<D>& x) {
    Rec<D>& r = rec[i];
    for (int k = 0; k < D; ++k) r.x[k] = static_cast<float>(x[k] - ref[k]);
    r.key = kInfF;
  }

  // Loads node i's record; false when a coordinate is not finite.
  bool load_rec(Index i) {
    const Vecd<D> x = cur->col(layout.perm[i]);
    if (!x.allFinite()) return false;
    store_rec(i, x);
    return true;
  }

  // Loads every used node's record (a whole run).
  Status gather(const Points& p) {
    if (Status st = begin_run(p); !st) return st;
    for (Index i = 0; i < layout.num_used; ++i)
      if (!load_rec(i)) return non_finite(layout.perm[i]);
    return {};
  }

  Status check_finite(const Points& positions) const {
    if (Status st = check_size(positions); !st) return st;
    for (const Index v : layout.used_original)
      if (!positions.col(v).allFinite()) return non_finite(v);
    return {};
  }

  // CFFM: the compact record of feature t, filled on its first use in a run (a local
  // run reads few features; a whole run fills them all first, in gather_frames). The
  // values are those of the nodes' float records, whether those were loaded or not.
  const FeatureFrame& frame(Index t) {
    FeatureFrame& f = frames[t];
    if (frame_mark[t] == frame_stamp) return f;
    frame_mark[t] = frame_stamp;
    for (int k = 0; k < D; ++k) f.c[k] = float_pos(layout.simplices_int[t][k]);
    for (int j = 0; j < D; ++j)
      f.far[j] = layout.across_far[t][j] >= 0 ? float_pos(layout.across_far[t][j]) : f.c[j];
    if constexpr (D == 3) {
      f.normal = (f.c[1] - f.c[0]).cross(f.c[2] - f.c[0]);
    } else {
      f.normal = Vecf<D>(f.c[0].y() - f.c[1].y(), f.c[1].x() - f.c[0].x());
    }
    // A local run reads features beyond its region, whose nodes were not checked.
    bool finite = f.normal.allFinite();
    for (int j = 0; j < D; ++j) finite = finite && f.far[j].allFinite();
    if (!finite && bad_node < 0) bad_node = layout.perm[layout.simplices_int[t][0]];
    return f;
  }

  void load_corners(Index s, Vecf<D>* c) {
    const FeatureFrame& f = frame(s);
    for (int k = 0; k < D; ++k) c[k] = f.c[k];
  }

  // CFFM, a whole run: every feature's record.
  void gather_frames() {
    for (std::size_t t = 0; t < layout.simplices_int.size(); ++t) frame(static_cast<Index>(t));
  }

  // Offers what u holds to its neighbours (the paper's update rule: a node takes it
  // when that makes it nearer than what the node holds). Final nodes have key <= -0,
  // so `d < key` is false for them.
  template <Mode kMode, bool kLocal, class Push>
  void relax(Index u, Push&& push) {
    const Index f = feature[u];
    const Index* it = layout.adjacency.indices.data() + layout.adjacency.offsets[u];
    const Index* const end = layout.adjacency.indices.data() + layout.adjacency.offsets[u + 1];
    if constexpr (kMode == Mode::kPoint || carries_point(kMode)) {
      // Point propagation: CPFM's boundary node, or CFFM's closest point on the feature.
      const Vecf<D> xf = kMode == Mode::kPoint ? pos_of<D>(rec[f]) : point[u];
      for (; it != end; ++it) {
        if constexpr (kLocal)
          if (!inside(*it)) continue;
        Rec<D>& r = rec[*it];
        const float d = (pos_of<D>(r) - xf).squaredNorm();
        if (d < r.key) {
          r.key = d;
          feature[*it] = f;
          if constexpr (kMode != Mode::kPoint) point[*it] = xf;
          push(d, *it);
        }
      }
    } else {
      Vecf<D> c[D];
      load_corners(f, c);
      for (; it != end; ++it) {
        if constexpr (kLocal)
          if (!inside(*it)) continue;
        Rec<D>& r = rec[*it];
        if (is_final(r.key)) continue;
        const float d = simplex_distance<D, float>(pos_of<D>(r), c).sq_dist;
        if (d < r.key) {
          r.key = d;
          feature[*it] = f;
          push(d, *it);
        }
      }
    }
  }

  // The paper's CFFM seeding: boundary node b offers every boundary feature around it.
  template <bool kLocal, class Push>
  void relax_ring(Index b, Push&& push) {
    const auto ring = layout.vertex_simplices_int.row(b);
    for (Index k = layout.adjacency.offsets[b]; k < layout.adjacency.offsets[b + 1]; ++k) {
      const Index v = layout.adjacency.indices[k];
      if constexpr (kLocal)
        if (!inside(v)) continue;
      Rec<D>& r = rec[v];
      if (is_final(r.key)) continue;
      const Vecf<D> x = pos_of<D>(r);
      for (const Index s : ring) {
        Vecf<D> c[D];
        load_corners(s, c);
        const float d = simplex_distance<D, float>(x, c).sq_dist;
        if (d < r.key) {
          r.key = d;
          feature[v] = s;
          push(d, v);
        }
      }
    }
  }

  // Local descent on the boundary surface: move u's feature to a neighbouring feature
  // while that is strictly nearer. The neighbours looked at are those around the
  // closest point: the features at its vertex, or across its edge; a closest point
  // inside a face (inside a segment in 2D) is a local minimum of the distance over the
  // surface and ends the walk.
  template <Mode kMode>
  void descend(Index u) {
    const Vecf<D> x = pos_of<D>(rec[u]);
    Index s = feature[u];
    Vecf<D> c[D];
    load_corners(s, c);
    ClosestPoint<Vecf<D>> q = simplex_closest_point<D, float>(x, c);
    float qd = (x - q.point).squaredNorm();
    Index prev = -1;
    for (int step = 0; step < kMaxDescentSteps; ++step) {
      Index best = s;
      bool best_known = true;  // q holds best's closest point
      const auto consider = [&](std::span<const Index> candidates) {
        for (const Index cand : candidates) {
          if (cand == s || cand == prev) continue;
          load_corners(cand, c);
          const ClosestPoint<Vecf<D>> cq = simplex_closest_point<D, float>(x, c);
          const float cd = (x - cq.point).squaredNorm();
          if (cd < qd) {
            best = cand;
            q = cq;
            qd = cd;
            best_known = true;
          }
        }
      };
      const int loc = static_cast<int>(q.loc);
      const bool interior = loc == (D == 3 ? static_cast<int>(FeatureLoc::kInterior)
                                           : static_cast<int>(FeatureLoc::kE01));
      if (loc < D) {
        // At a vertex: the features around it.
        consider(layout.vertex_simplices_int.row(layout.simplices_int[s][loc]));
      } else {
        // On an edge or inside the feature: the features across its sides. Inside is a
        // local minimum, and so is an edge point when the face across it is not nearer,
        // but seen from inside a curved object a faceted surface has many such minima
        // and the features across the sides are often nearer (docs/DEPTH_MAPS.md, "CFFM
        // variants"). With the closest point inside, a neighbour whose far node is not on
        // x's side of the plane (a convex or flat side) lies beyond the plane, no nearer
        // than the plane distance: it is skipped, which changes no result.
        const FeatureFrame& fr = frame(s);
        const float side = fr.normal.dot(x - fr.c[0]);
        for (int j = 0; j < D; ++j) {
          const Index t = layout.across[s][j];
          if (t < 0) {
            consider(layout.across_side(s, j));
            continue;
          }
          if (t == prev) continue;
          if (interior && side * fr.normal.dot(fr.far[j] - fr.c[0]) <= 0.0f) continue;
          // The feature across side j, from this record: side j's nodes and the far node.
          Vecf<D> tc[D];
          if constexpr (D == 3) {
            tc[0] = fr.c[j];
            tc[1] = fr.c[(j + 1) % 3];
            tc[2] = fr.far[j];
          } else {
            tc[0] = fr.c[j];
            tc[1] = fr.far[j];
          }
          const float cd = (x - simplex_closest_point<D, float>(x, tc).point).squaredNorm();
          if (cd < qd) {
            best = t;
            qd = cd;
            best_known = false;  // its closest point's place is in another vertex order
          }
        }
      }
      if (best == s) break;
      if (!best_known) {
        load_corners(best, c);
        q = simplex_closest_point<D, float>(x, c);
        qd = (x - q.point).squaredNorm();
      }
      prev = s;
      s = best;
    }
    feature[u] = s;
    if constexpr (carries_point(kMode)) point[u] = q.point;
    rec[u].key = qd;
  }

  // kFeatureMultiStart: after the descent from u's own feature, descend also from the
  // feature of every settled neighbour (each distinct feature once) and keep the
  // nearest result. Escapes the local minima a single walk stops in, at a price.
  // kFeatureNearStarts: the same extra walks, only from the settled neighbours'
  // features that are already nearly as near as the best result so far (distance at
  // most kNearStartSlack above it); the others almost never lead to a nearer minimum
  // (docs/DEPTH_MAPS.md, "CFFM variants", has the counts). Each distinct feature is
  // evaluated once (one point-to-feature distance) and walked from at most once.
  template <Mode kMode>
  void extra_starts(Index u) {
    static_assert(kMode == Mode::kFeatureMultiStart || kMode == Mode::kFeatureNearStarts);
    Index best_f = feature[u];
    float best_key = rec[u].key;
    Vecf<D> best_point = point[u];
    [[maybe_unused]] const Vecf<D> x = pos_of<D>(rec[u]);
    constexpr int kMaxStarts = 64;
    Index tried[kMaxStarts];
    int count = 0;
    tried[count++] = best_f;
    for (Index k = layout.adjacency.offsets[u];
         k < layout.adjacency.offsets[u + 1] && count < kMaxStarts; ++k) {
      const Index v = layout.adjacency.indices[k];
      if (!settled_now(v)) continue;
      const Index f = feature[v];
      if (std::find(tried, tried + count, f) != tried + count) continue;
      tried[count++] = f;
      if constexpr (kMode == Mode::kFeatureNearStarts) {
        constexpr float kSlack2 = (1.0f + kNearStartSlack) * (1.0f + kNearStartSlack);
        Vecf<D> c[D];
        load_corners(f, c);
        if (simplex_distance<D, float>(x, c).sq_dist >= best_key * kSlack2) continue;
      }
      feature[u] = f;
      descend<kMode>(u);
      if (rec[u].key < best_key) {
        best_key = rec[u].key;
        best_f = feature[u];
        best_point = point[u];
      }
    }
    feature[u] = best_f;
    rec[u].key = best_key;
    point[u] = best_point;
  }

  // True when node v is final in this run (a local run's records outside its region are
  // another run's).
  bool settled_now(Index v) const {
    return is_final(rec[v].key) && (!local_run || region_mark[v] == region_stamp);
  }

  // The march. The seeds (boundary nodes) are final at 0; then nodes are finalised in
  // queue order. A node is final when popped and never changes afterwards, so a lazy
  // run (which stops after some pop) is a prefix of the full run with the same seeds.
  // kLocal: only the region's nodes are offered anything. Returns how many of the
  // `remaining` marked nodes were not reached (lazy runs; 0 otherwise).
  template <Mode kMode, bool kLocal, class Queue>
  std::size_t march(Queue& q, std::span<const Index> seed_nodes, bool lazy, std::size_t remaining) {
    q.clear();
    stage.clear();
    settled_list.clear();
    for (const Index b : seed_nodes) {
      rec[b].key = -0.0f;
      feature[b] = kMode == Mode::kPoint ? b : layout.seed_simplex[b];
      if constexpr (carries_point(kMode)) point[b] = pos_of<D>(rec[b]);
      settled_list.push_back(b);
      if (lazy && mark[b] == stamp) --remaining;
    }
    if (lazy && remaining == 0) return 0;
    const auto to_stage = [this](float d, Index v) { stage.push_back({d, v}); };
    for (const Index b : seed_nodes) {
      if constexpr (kMode == Mode::kFeaturePaper || kMode == Mode::kFeaturePaperDescent) {
        relax_ring<kLocal>(b, to_stage);
      } else {
        relax<kMode, kLocal>(b, to_stage);
      }
    }
    q.start(stage);
    const auto to_queue = [&q](float d, Index v) { q.push(d, v); };
    while (!q.empty()) {
      const Index u = q.pop();
      if constexpr (std::is_same_v<Queue, detail::BucketQueue>) {
        // The march is bound by memory latency: fetch what the next pops will read.
        if (const Index a = q.peek(kPrefetchFar); a >= 0) {
          __builtin_prefetch(&rec[a]);
          __builtin_prefetch(&layout.adjacency.offsets[a]);
          if constexpr (kMode != Mode::kPoint) __builtin_prefetch(&feature[a]);
        }
        if constexpr (kMode != Mode::kPoint) {
          if (const Index a = q.peek(kPrefetchMid); a >= 0) {
            const char* f = reinterpret_cast<const char*>(&frames[feature[a]]);
            __builtin_prefetch(f);
            __builtin_prefetch(f + sizeof(FeatureFrame) - 1);
            __builtin_prefetch(&layout.across[feature[a]]);
          }
        }
        if (const Index a = q.peek(kPrefetchNear); a >= 0)
          __builtin_prefetch(layout.adjacency.indices.data() + layout.adjacency.offsets[a]);
      }
      if (is_final(rec[u].key)) continue;
      if constexpr (kMode != Mode::kPoint && kMode != Mode::kFeaturePaper) descend<kMode>(u);
      if constexpr (kMode == Mode::kFeatureMultiStart || kMode == Mode::kFeatureNearStarts)
        extra_starts<kMode>(u);
      rec[u].key = -rec[u].key;
      settled_list.push_back(u);
      if (lazy && mark[u] == stamp && --remaining == 0) break;
      relax<kMode, kLocal>(u, to_queue);
    }
    return lazy ? remaining : 0;
  }

  // Depths of the settled nodes, in double from the original positions.
  void finish(const Points& positions) {
    const bool cffm = options.method == DepthMethod::kCffm;
    const std::size_t count = settled_list.size();
    const Index* list = settled_list.data();
    for (std::size_t j = 0; j < count; ++j) {
      // Two-stage prefetch: the original index, then the original position.
      if (j + 16 < count) __builtin_prefetch(&layout.perm[list[j + 16]]);
      if (j + 8 < count)
        __builtin_prefetch(positions.data() + std::size_t{D} * layout.perm[list[j + 8]]);
      const Index i = list[j];
      const Index o = layout.perm[i];
      written.push_back(o);
      if (i < layout.num_boundary) {
        depth[o] = 0.0;
        anchor[o] = o;
        continue;
      }
      const Vecd<D> x = positions.col(o);
      if (cffm) {
        Vecd<D> c[D];
        for (int k = 0; k < D; ++k)
          c[k] = positions.col(layout.perm[layout.simplices_int[feature[i]][k]]);
        depth[o] = std::sqrt(simplex_distance<D, double>(x, c).sq_dist);
        int near = 0;  // the feature's corner nearest the node
        for (int k = 1; k < D; ++k)
          if ((x - c[k]).squaredNorm() < (x - c[near]).squaredNorm()) near = k;
        anchor[o] = layout.perm[layout.simplices_int[feature[i]][near]];
      } else {
        depth[o] = (x - positions.col(layout.perm[feature[i]])).norm();
        anchor[o] = layout.perm[feature[i]];
      }
    }
    settled = count;
  }

  template <Mode kMode, class Queue>
  std::size_t march_in(Queue& q, std::span<const Index> seed_nodes, bool lazy,
                       std::size_t remaining) {
    return local_run ? march<kMode, true>(q, seed_nodes, lazy, remaining)
                     : march<kMode, false>(q, seed_nodes, lazy, remaining);
  }

  // The march of the configured method from `seed_nodes`, then the final depths.
  // Returns how many marked nodes were not reached (lazy runs).
  std::size_t run_march(const Points& positions, std::span<const Index> seed_nodes, bool lazy,
                        std::size_t remaining) {
    std::size_t left = 0;
    std::visit(
        [&](auto& q) {
          if (options.method == DepthMethod::kCpfm) {
            left = march_in<Mode::kPoint>(q, seed_nodes, lazy, remaining);
            return;
          }
          switch (options.cffm) {
            case CffmVariant::kPaper:
              left = march_in<Mode::kFeaturePaper>(q, seed_nodes, lazy, remaining);
              return;
            case CffmVariant::kPaperDescent:
              left = march_in<Mode::kFeaturePaperDescent>(q, seed_nodes, lazy, remaining);
              return;
            case CffmVariant::kMultiStart:
              left = march_in<Mode::kFeatureMultiStart>(q, seed_nodes, lazy, remaining);
              return;
            case CffmVariant::kNearStarts:
              left = march_in<Mode::kFeatureNearStarts>(q, seed_nodes, lazy, remaining);
              return;
            case CffmVariant::kDescent:
              break;
          }
          left = march_in<Mode::kFeatureDescent>(q, seed_nodes, lazy, remaining);
        },
        queue);
    finish(positions);
    return left;
  }

  // The region of a local run: the nodes the marked ones reach by edges without leaving
  // the grid cells within `side` (in every coordinate) of a cell holding a marked node;
  // so it holds the ball of radius `side` around every marked node, and reaches at most
  // side + one cell beyond them. Cells are side / 2 (coarser when the marked nodes span
  // more than kMaxRegionCells such cells). The seeds are the region's boundary nodes.
  // Loads the region's records; sets bad_node for a non-finite coordinate. Returns false
  // as soon as the region holds more than `limit` nodes (then the whole run is cheaper).
  bool build_region(double side, std::size_t limit) {
    if (++region_stamp == 0) {  // wrapped: forget the old marks
      std::fill(region_mark.begin(), region_mark.end(), 0u);
      std::fill(tested_mark.begin(), tested_mark.end(), 0u);
      region_stamp = 1;
    }
    region.clear();
    seeds.clear();
    Vecd<D> lo = Vecd<D>::Constant(kInf), hi = Vecd<D>::Constant(-kInf);
    for (const Index u : marked) {
      const Vecd<D> x = cur->col(layout.perm[u]);
      if (!x.allFinite()) {
        bad_node = layout.perm[u];
        return false;
      }
      lo = lo.cwiseMin(x);
      hi = hi.cwiseMax(x);
    }
    // The grid: cell c, `reach` cells of dilation (reach * c >= side), origin lo - reach c.
    double cell = 0.5 * side;
    const Vecd<D> extent = hi - lo;
    const auto cells_for = [&](double c) {
      double total = 1.0;
      for (int k = 0; k < D; ++k)
        total *= std::floor(extent[k] / c) + 1.0 + 2.0 * std::ceil(side / c);
      return total;
    };
    while (cells_for(cell) > static_cast<double>(kMaxRegionCells)) cell *= 2.0;
    const int reach = static_cast<int>(std::ceil(side / cell));
    const double inv_cell = 1.0 / cell;
    Eigen::Matrix<std::int64_t, D, 1> dims;
    for (int k = 0; k < D; ++k)
      dims[k] = static_cast<std::int64_t>(std::floor(extent[k] * inv_cell)) + 1 + 2 * reach;
    const Vecd<D> origin = lo - Vecd<D>::Constant(reach * cell);
    grid.assign(static_cast<std::size_t>(dims.prod()), 0);
    // Cell index of x, or -1 outside the grid.
    const auto cell_of = [&](const Vecd<D>& x) -> std::int64_t {
      std::int64_t index = 0;
      for (int k = D - 1; k >= 0; --k) {
        // In the grid c >= 0, where truncation is floor (std::floor is a library call
        // without SSE4.1, and this runs for every node the flood looks at).
        const double c = (x[k] - origin[k]) * inv_cell;
        if (!(c >= 0.0 && c < static_cast<double>(dims[k]))) return -1;
        index = index * dims[k] + static_cast<std::int64_t>(c);
      }
      return index;
    };
    // Mark the cells of the marked nodes, then dilate by `reach` along each axis in turn.
    for (const Index u : marked)
      grid[static_cast<std::size_t>(cell_of(cur->col(layout.perm[u])))] = 1;
    std::int64_t stride = 1;
    for (int k = 0; k < D; ++k) {
      for (int pass = 0; pass < reach; ++pass) {
        // One cell of growth along axis k: a cell is set when it or a neighbour along k is.
        for (std::int64_t i = 0; i < static_cast<std::int64_t>(grid.size()); ++i) {
          const std::int64_t c = (i / stride) % dims[k];
          if (grid[i] & 1) continue;
          const bool up = c + 1 < dims[k] && (grid[i + stride] & 1);
          const bool down = c > 0 && (grid[i - stride] & 1);
          if (up || down) grid[i] = 2;  // set after this pass, not during it
        }
        for (auto& g : grid) g = g != 0 ? 1 : 0;
      }
      stride *= dims[k];
    }
    for (const Index u : marked) {
      if (tested_mark[u] == region_stamp) continue;
      tested_mark[u] = region_mark[u] = region_stamp;
      region.push_back(u);
      store_rec(u, cur->col(layout.perm[u]));
    }
    if (region.size() > limit) return false;
    for (std::size_t head = 0; head < region.size(); ++head) {
      // The flood is bound by memory latency: fetch the marks and indices of the
      // neighbours of a node a few places ahead, and their positions nearer.
      if (head + kRegionPrefetchFar < region.size())
        for (const Index w : layout.adjacency.row(region[head + kRegionPrefetchFar])) {
          __builtin_prefetch(&tested_mark[w]);
          __builtin_prefetch(&layout.perm[w]);
        }
      if (head + kRegionPrefetchNear < region.size())
        for (const Index w : layout.adjacency.row(region[head + kRegionPrefetchNear]))
          __builtin_prefetch(cur->data() + std::size_t{D} * layout.perm[w]);
      for (const Index v : layout.adjacency.row(region[head])) {
        if (tested_mark[v] == region_stamp) continue;
        tested_mark[v] = region_stamp;
        const Vecd<D> x = cur->col(layout.perm[v]);
        if (!x.allFinite()) {
          bad_node = layout.perm[v];
          return false;
        }
        const std::int64_t c = cell_of(x);
        if (c < 0 || !grid[static_cast<std::size_t>(c)]) continue;
        region_mark[v] = region_stamp;
        region.push_back(v);
        store_rec(v, x);
        if (region.size() > limit) return false;
      }
    }
    for (const Index v : region)
      if (v < layout.num_boundary) seeds.push_back(v);
    std::sort(seeds.begin(), seeds.end());
    return true;
  }

  bool inside(Index v) const { return region_mark[v] == region_stamp; }

  // Lazy run on regions around the marked nodes (LazyRegion::kLocal): the cell side
  // starts at twice the largest marked element and grows until every marked node is
  // reached and its depth is at most the side (so every boundary node nearer to it than
  // its depth lies in the region's cells), or the region is the whole object; then the
  // run is a whole one. Fails on a non-finite coordinate of a node it reads.
  Status run_local(const Points& positions, std::span<const Index> marked_elements) {
    double side = 0.0;
    for (const Index e : marked_elements) {
      Vecd<D> lo = positions.col(layout.elements[e][0]), hi = lo;
      for (const Index v : layout.elements[e]) {
        lo = lo.cwiseMin(positions.col(v));
        hi = hi.cwiseMax(positions.col(v));
      }
      side = std::max(side, (hi - lo).maxCoeff());
    }
    // The last certified run's deepest marked node is the best first guess of this one's
    // (contact moves little from frame to frame); the certificate below decides anyway.
    side = std::max(side * kLocalStartFactor, kLocalRepeatFactor * last_deepest);
    lazy_stats = {};
    // A region holds the marked nodes and a ring of cells at least two elements wide
    // around them: several times as many nodes. Where that alone passes the limit below,
    // the flood would be wasted.
    const std::size_t limit = static_cast<std::size_t>(layout.num_used) / kWholeFraction;
    local_run = side > 0.0 && std::isfinite(side) && marked.size() * kRegionPerMarked <= limit;
    for (int round = 0; local_run && round < kMaxLocalRounds; ++round) {
      const bool small = build_region(side, limit);
      if (bad_node >= 0) return non_finite(bad_node);
      if (!small) break;
      ++lazy_stats.rounds;
      lazy_stats.region_nodes = region.size();
      lazy_stats.cell_side = side;
      const std::size_t left = run_march(positions, seeds, true, marked.size());
      if (bad_node >= 0) return non_finite(bad_node);
      double deepest = 0.0;
      for (const Index u : marked) deepest = std::max(deepest, depth[layout.perm[u]]);
      if (left == 0 && deepest <= side) {
        last_deepest = deepest;
        return {};
      }
      clear_written();
      side = std::max(kLocalGrowth * side, left == 0 ? kLocalRepeatFactor * deepest : 0.0);
    }
    // The whole object: every boundary node seeds, as in the paper.
    last_deepest = 0.0;
    local_run = false;
    ++lazy_stats.rounds;
    lazy_stats.region_nodes = static_cast<std::size_t>(layout.num_used);
    lazy_stats.whole = true;
    if (Status st = gather(positions); !st) return st;
    if (options.method == DepthMethod::kCffm) gather_frames();
    run_march(positions, layout.all_boundary, true, marked.size());
    return {};
  }

  void run_exact(const Points& positions, std::span<const Index> nodes) {
    bvh.build(layout.surface.simplices, positions);
    written.assign(nodes.begin(), nodes.end());
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, nodes.size(), 512),
        [&](const tbb::blocked_range<std::size_t>& r) {
          for (std::size_t i = r.begin(); i != r.end(); ++i) {
            const Index v = nodes[i];
            if (layout.is_boundary[v]) {
              depth[v] = 0.0;
              anchor[v] = v;
              continue;
            }
            const Vecd<D> x = positions.col(v);
            const auto hit = bvh.nearest(x);
            depth[v] = std::sqrt(hit.sq_dist);
            if (hit.simplex < 0) continue;
            const auto& f = layout.surface.simplices[static_cast<std::size_t>(hit.simplex)];
            Index best = f[0];
            for (int k = 1; k < D; ++k)
              if ((x - positions.col(f[k])).squaredNorm() < (x - positions.col(best)).squaredNorm())
                best = f[k];
            anchor[v] = best;
          }
        });
    settled = nodes.size();
  }

  // Forgets the depths and anchors the last run wrote (only those: a local run costs
  // what its region costs, not what the object costs).
  void clear_written() {
    for (const Index o : written) {
      depth[o] = kInf;
      anchor[o] = -1;
    }
    written.clear();
    settled = 0;
  }

  void reset() {
    clear_written();
    bad_node = -1;
    local_run = false;
    lazy_stats = {};
  }
};

template <int D>
BasicDepthSolver<D>::BasicDepthSolver(std::span<const Element> elements, const TopologyOf<D>& topo,
                                      DepthSolverOptions options)
    : impl_(std::make_unique<Impl>(elements, topo, options)) {}

template <int D>
BasicDepthSolver<D>::~BasicDepthSolver() = default;
template <int D>
BasicDepthSolver<D>::BasicDepthSolver(BasicDepthSolver&&) noexcept = default;
template <int D>
BasicDepthSolver<D>& BasicDepthSolver<D>::operator=(BasicDepthSolver&&) noexcept = default;

template <int D>
Status BasicDepthSolver<D>::compute(const Points& positions) {
  Impl& s = *impl_;
  s.reset();
  if (s.options.method == DepthMethod::kExact) {
    if (Status st = s.check_finite(positions); !st) return st;
    s.run_exact(positions, s.layout.used_original);
    return {};
  }
  if (Status st = s.gather(positions); !st) return st;
  if (s.options.method == DepthMethod::kCffm) s.gather_frames();
  s.run_march(positions, s.layout.all_boundary, false, 0);
  return {};
}

template <int D>
Expected<std::size_t> BasicDepthSolver<D>::compute_lazy(const Points& positions,
                                                        std::span<const Index> marked) {
  Impl& s = *impl_;
  s.reset();
  const auto m = static_cast<Index>(s.layout.elements.size());
  for (std::size_t i = 0; i < marked.size(); ++i)
    if (marked[i] < 0 || marked[i] >= m)
      return Error{ErrorCode::kInvalidArgument,
                   "marked element #" + std::to_string(i) + " = " + std::to_string(marked[i]) +
                       " is out of range [0, " + std::to_string(m) + ")"};
  const bool exact = s.options.method == DepthMethod::kExact;
  const bool local = !exact && s.options.lazy_region == LazyRegion::kLocal;
  if (Status st = exact   ? s.check_finite(positions)
                  : local ? s.begin_run(positions)
                          : s.gather(positions);
      !st)
    return st.error();
  if (++s.stamp == 0) {  // wrapped: forget the old marks
    std::fill(s.mark.begin(), s.mark.end(), 0u);
    s.stamp = 1;
  }
  s.marked.clear();
  for (const Index e : marked)
    for (const Index o : s.layout.elements[e]) {
      const Index key = exact ? o : s.layout.inv[o];
      if (s.mark[key] != s.stamp) {
        s.mark[key] = s.stamp;
        s.marked.push_back(key);
      }
    }
  if (s.marked.empty()) return std::size_t{0};
  if (exact) {
    std::sort(s.marked.begin(), s.marked.end());
    s.run_exact(positions, s.marked);
  } else if (local) {
    if (Status st = s.run_local(positions, marked); !st) {
      s.reset();
      return st.error();
    }
  } else {
    if (s.options.method == DepthMethod::kCffm) s.gather_frames();
    s.run_march(positions, s.layout.all_boundary, true, s.marked.size());
  }
  return s.settled;
}

template <int D>
const LazyStats& BasicDepthSolver<D>::lazy_stats() const {
  return impl_->lazy_stats;
}

template <int D>
std::span<const double> BasicDepthSolver<D>::depth() const {
  return impl_->depth;
}
template <int D>
std::span<const Index> BasicDepthSolver<D>::anchor() const {
  return impl_->anchor;
}
template <int D>
bool BasicDepthSolver<D>::settled(Index i) const {
  return std::isfinite(impl_->depth[i]);
}
template <int D>
std::size_t BasicDepthSolver<D>::settled_count() const {
  return impl_->settled;
}
template <int D>
Index BasicDepthSolver<D>::num_nodes() const {
  return impl_->layout.n;
}
template <int D>
const DepthSolverOptions& BasicDepthSolver<D>::options() const {
  return impl_->options;
}

template class BasicDepthSolver<2>;
template class BasicDepthSolver<3>;

namespace {

template <int D, class Mesh, class Topo>
Expected<std::vector<double>> one_off(const Mesh& mesh,
                                      std::span<const std::array<Index, D + 1>> elements,
                                      const Topo& topo, DepthSolverOptions options) {
  BasicDepthSolver<D> solver(elements, topo, options);
  if (Status st = solver.compute(mesh.positions); !st) return st.error();
  return std::vector<double>(solver.depth().begin(), solver.depth().end());
}

}  // namespace

Expected<std::vector<double>> compute_depth_cpfm(const TetMesh& mesh, const Topology& topo) {
  return one_off<3>(mesh, std::span<const Tet>(mesh.tets), topo, {.method = DepthMethod::kCpfm});
}
Expected<std::vector<double>> compute_depth_cffm(const TetMesh& mesh, const Topology& topo,
                                                 CffmVariant variant) {
  return one_off<3>(mesh, std::span<const Tet>(mesh.tets), topo,
                    {.method = DepthMethod::kCffm, .cffm = variant});
}
Expected<std::vector<double>> compute_depth_exact(const TetMesh& mesh, const Topology& topo) {
  return one_off<3>(mesh, std::span<const Tet>(mesh.tets), topo, {.method = DepthMethod::kExact});
}
Expected<std::vector<double>> compute_depth_cpfm(const TriMesh2& mesh, const Topology2& topo) {
  return one_off<2>(mesh, std::span<const std::array<Index, 3>>(mesh.triangles), topo,
                    {.method = DepthMethod::kCpfm});
}
Expected<std::vector<double>> compute_depth_cffm(const TriMesh2& mesh, const Topology2& topo,
                                                 CffmVariant variant) {
  return one_off<2>(mesh, std::span<const std::array<Index, 3>>(mesh.triangles), topo,
                    {.method = DepthMethod::kCffm, .cffm = variant});
}
Expected<std::vector<double>> compute_depth_exact(const TriMesh2& mesh, const Topology2& topo) {
  return one_off<2>(mesh, std::span<const std::array<Index, 3>>(mesh.triangles), topo,
                    {.method = DepthMethod::kExact});
}

const char* depth_method_name(DepthMethod method) {
  switch (method) {
    case DepthMethod::kCpfm:
      return "cpfm";
    case DepthMethod::kCffm:
      return "cffm";
    case DepthMethod::kExact:
      return "exact";
  }
  return "unknown";
}

std::optional<DepthMethod> parse_depth_method(std::string_view name) {
  for (const DepthMethod m : {DepthMethod::kCpfm, DepthMethod::kCffm, DepthMethod::kExact})
    if (name == depth_method_name(m)) return m;
  return std::nullopt;
}

}  // namespace tc
