#include "core/detect/detect.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "core/common/chunked.hpp"
#include "core/common/cpu_dispatch.hpp"
#include "core/common/target_clones.hpp"
#include "core/detect/edge_hits.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/sorted_index_set.hpp"
#include "core/mesh/spatial_order.hpp"

namespace tc {
namespace detail {

/// Nodes per call of beyond_reach_lanes().
constexpr std::size_t kReachLanes = 8;

/// Bit l set when node l of the kReachLanes nodes at p (3 coordinates each; references
/// at q) is further than r from its reference along an axis, or not finite there or at
/// the reference: CollisionBody::compare_chunk's test of one node, in plain lane loops
/// the compiler vectorises (AVX2 and baseline copies below).
[[gnu::always_inline]] inline unsigned beyond_reach_lanes(const double* p, const double* q,
                                                          double r) {
  constexpr int L = static_cast<int>(kReachLanes);
  double far[3 * L];  // 1 where a coordinate is beyond reach (NaN: beyond)
  for (int k = 0; k < 3 * L; ++k) far[k] = std::abs(p[k] - q[k]) <= r ? 0.0 : 1.0;
  unsigned mask = 0;
  for (int l = 0; l < L; ++l)
    mask |= (far[3 * l] + far[3 * l + 1] + far[3 * l + 2] != 0.0 ? 1u : 0u) << l;
  return mask;
}

/// The two copies of beyond_reach_lanes() (pick_kernel()).
unsigned beyond_reach_baseline(const double* p, const double* q, double r) {
  return beyond_reach_lanes(p, q, r);
}
TC_AVX2_TARGET unsigned beyond_reach_avx2(const double* p, const double* q, double r) {
  return beyond_reach_lanes(p, q, r);
}

}  // namespace detail
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

constexpr std::size_t kNarrowChunk = 256;
constexpr std::size_t kFeatureChunk = 32;
constexpr std::size_t kFilterChunk = 1024;
constexpr std::size_t kParallelSortMin = 16384;
/// Kept pairs tested a chunk (candidates_from_kept()).
constexpr std::size_t kKeptChunk = 2048;
/// Frames a local tree over the same tets is refitted before it is built again.
constexpr int kLocalTreeRefits = 32;

template <typename T>
void sort_values(std::vector<T>& v) {
  if (v.size() >= kParallelSortMin)
    tbb::parallel_sort(v.begin(), v.end());
  else
    std::sort(v.begin(), v.end());
}

template <typename T>
void sort_unique(std::vector<T>& v) {
  sort_values(v);
  v.erase(std::unique(v.begin(), v.end()), v.end());
}

/// Box of the finite points among those `for_each_point` visits (it calls its argument
/// with a pointer to each point's x, y, z): the bits of an Aabb extended with each finite
/// point in turn (lo = std::min(lo, x) and hi = std::max(hi, x), Eigen's cwiseMin /
/// cwiseMax operand for operand, signed zeros included).
///
/// The per-node loops of set_positions and the cluster refit run on it. First pass: every
/// point enters, with no test, in registers (x and y in one two-lane vector), while the
/// sum of x - x over all coordinates (0 for a finite x, NaN otherwise) records whether
/// any was not finite; when none was, that is the box, since it saw the same operations
/// on the same points. Otherwise a second pass takes the finite points only. (An Aabb
/// extended through a reference with three isfinite tests a point cost ~36 instructions
/// a node: it was kept in memory, its stores might alias the positions.)
template <class ForEachPoint>
Aabb box_of_finite_points(const ForEachPoint& for_each_point) {
  using V2 = PointBox::V2;
  PointBox box;
  V2 bad = {0.0, 0.0};
  double bad_z = 0.0;
  for_each_point([&](const double* p) {
    const V2 xy = PointBox::xy_of(p);
    bad += xy - xy;
    bad_z += p[2] - p[2];
    box.add(xy, p[2]);
  });
  if (!((bad[0] + bad[1]) + bad_z == 0.0)) {  // a coordinate was infinite or NaN
    box = PointBox{};
    for_each_point([&](const double* p) {
      const V2 xy = PointBox::xy_of(p), d = xy - xy;
      if ((d[0] + d[1]) + (p[2] - p[2]) == 0.0) box.add(xy, p[2]);
    });
  }
  return {box.lo(), box.hi()};
}

/// CSR of item -> owners from a per-owner list of items.
template <std::size_t K>
Csr invert(const std::vector<std::array<Index, K>>& owned, Index num_items) {
  Csr csr;
  csr.offsets.assign(static_cast<std::size_t>(num_items) + 1, 0);
  for (const auto& row : owned)
    for (const Index i : row) ++csr.offsets[i + 1];
  for (Index i = 0; i < num_items; ++i) csr.offsets[i + 1] += csr.offsets[i];
  csr.indices.resize(static_cast<std::size_t>(csr.offsets.back()));
  std::vector<Index> fill(csr.offsets.begin(), csr.offsets.end() - 1);
  for (std::size_t o = 0; o < owned.size(); ++o)
    for (const Index i : owned[o]) csr.indices[fill[i]++] = static_cast<Index>(o);
  return csr;  // rows sorted: owners are visited in order
}

}  // namespace

// ------------------------------------------------------------------------ CollisionBody

CollisionBody::CollisionBody(std::span<const Tet> tets, const Topology& topology)
    : tets_(tets.begin(), tets.end()), num_nodes_(topology.num_nodes), edges_(topology.edges) {
  if (topology.num_tets != static_cast<Index>(tets.size()))
    throw std::invalid_argument("CollisionBody: topology has " + std::to_string(topology.num_tets) +
                                " tets, mesh has " + std::to_string(tets.size()));
  for (std::size_t t = 0; t < tets_.size(); ++t)
    for (const Index v : tets_[t])
      if (v < 0 || v >= num_nodes_)
        throw std::invalid_argument("CollisionBody: tet " + std::to_string(t) + " uses node " +
                                    std::to_string(v) + " outside [0, " +
                                    std::to_string(num_nodes_) + ")");
  node_tets_ = topology.node_tets;
  if (node_tets_.rows() != num_nodes_) {
    std::vector<std::array<Index, 4>> owned(tets_.begin(), tets_.end());
    node_tets_ = invert(owned, num_nodes_);
  }
  // Edge ids by a binary search within the edges of the smaller node (the edges are
  // sorted, so each node's edges (u, *) are contiguous).
  std::vector<Index> edge_begin(static_cast<std::size_t>(num_nodes_) + 1, 0);
  for (const auto& e : edges_) {
    if (e[0] < 0 || e[0] >= num_nodes_)
      throw std::invalid_argument("CollisionBody: topology edge node " + std::to_string(e[0]) +
                                  " outside [0, " + std::to_string(num_nodes_) + ")");
    ++edge_begin[static_cast<std::size_t>(e[0]) + 1];
  }
  for (std::size_t i = 0; i + 1 < edge_begin.size(); ++i) edge_begin[i + 1] += edge_begin[i];
  tet_edges_.resize(tets_.size());
  bool missing = false;
  std::size_t missing_tet = 0;
  int missing_edge = 0;
  detail::for_chunks(tets_.size(), 8192, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t t = begin; t < end; ++t)
      for (int k = 0; k < 6; ++k) {
        Index u = tets_[t][kTetEdges[k][0]], v = tets_[t][kTetEdges[k][1]];
        if (u > v) std::swap(u, v);
        const auto first = edges_.begin() + edge_begin[u];
        const auto last = edges_.begin() + edge_begin[u + 1];
        const std::array<Index, 2> key{u, v};
        const auto it = std::lower_bound(first, last, key);
        if (it == last || *it != key) {
          tet_edges_[t][k] = -1;
          continue;
        }
        tet_edges_[t][k] = static_cast<Index>(it - edges_.begin());
      }
  });
  for (std::size_t t = 0; t < tets_.size() && !missing; ++t)
    for (int k = 0; k < 6 && !missing; ++k)
      if (tet_edges_[t][k] < 0) {
        missing = true;
        missing_tet = t;
        missing_edge = k;
      }
  if (missing) {
    Index u = tets_[missing_tet][kTetEdges[missing_edge][0]];
    Index v = tets_[missing_tet][kTetEdges[missing_edge][1]];
    if (u > v) std::swap(u, v);
    throw std::invalid_argument("CollisionBody: edge (" + std::to_string(u) + ", " +
                                std::to_string(v) + ") of tet " + std::to_string(missing_tet) +
                                " is not in the topology");
  }
  edge_tets_ = invert(tet_edges_, static_cast<Index>(edges_.size()));
}

namespace {

/// Tets per spatial cluster: small enough that a small contact region touches few
/// clusters, large enough that refitting them costs little next to reading the nodes.
constexpr std::size_t kClusterTets = 64;
/// Clusters per group (1,024 tets): a group reads each of its nodes about once, a
/// cluster's nodes are shared with its neighbours (~2.5 reads a node over all clusters).
constexpr std::size_t kClustersPerGroup = 16;

/// Box of the finite points among `nodes`.
Aabb box_of_nodes(const Positions& positions, std::span<const Index> nodes) {
  const double* xyz = positions.data();
  return box_of_finite_points([&](const auto& visit) {
    for (const Index i : nodes) visit(xyz + 3 * static_cast<std::size_t>(i));
  });
}

/// Nodes per chunk of the passes over every node of a body.
constexpr std::size_t kNodeChunk = 8192;

}  // namespace

void CollisionBody::build_clusters(const Positions& positions) {
  const Eigen::Vector3d lo = box_.empty() ? Eigen::Vector3d::Zero() : box_.lo;
  const double extent = box_.empty() ? 0.0 : (box_.hi - box_.lo).maxCoeff();
  // Tets along a Morton curve of their centroids, cut into runs of kClusterTets.
  const std::vector<Index> order = tets_in_morton_order(positions, tets_, lo, extent);
  const std::size_t m = tets_.size();
  const std::size_t clusters = (m + kClusterTets - 1) / kClusterTets;
  cluster_tets_.offsets.assign(1, 0);
  cluster_tets_.indices.clear();
  cluster_nodes_.offsets.assign(1, 0);
  cluster_nodes_.indices.clear();
  std::vector<Index> row, nodes;
  for (std::size_t c = 0; c < clusters; ++c) {
    const std::size_t begin = c * kClusterTets, end = std::min(m, begin + kClusterTets);
    row.clear();
    for (std::size_t k = begin; k < end; ++k) row.push_back(order[k]);
    std::sort(row.begin(), row.end());
    cluster_tets_.indices.insert(cluster_tets_.indices.end(), row.begin(), row.end());
    cluster_tets_.offsets.push_back(static_cast<Index>(cluster_tets_.indices.size()));
    nodes.clear();
    for (const Index t : row) nodes.insert(nodes.end(), tets_[t].begin(), tets_[t].end());
    std::sort(nodes.begin(), nodes.end());
    nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
    cluster_nodes_.indices.insert(cluster_nodes_.indices.end(), nodes.begin(), nodes.end());
    cluster_nodes_.offsets.push_back(static_cast<Index>(cluster_nodes_.indices.size()));
  }
  tet_boxes_.assign(clusters, Aabb{});
  cluster_frame_.assign(clusters, 0);
  group_nodes_.offsets.assign(1, 0);
  group_nodes_.indices.clear();
  for (std::size_t first = 0; first < clusters; first += kClustersPerGroup) {
    nodes.clear();
    const auto last = static_cast<Index>(std::min(clusters, first + kClustersPerGroup));
    nodes.insert(nodes.end(), cluster_nodes_.indices.begin() + cluster_nodes_.offsets[first],
                 cluster_nodes_.indices.begin() + cluster_nodes_.offsets[last]);
    std::sort(nodes.begin(), nodes.end());
    nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
    group_nodes_.indices.insert(group_nodes_.indices.end(), nodes.begin(), nodes.end());
    group_nodes_.offsets.push_back(static_cast<Index>(group_nodes_.indices.size()));
  }
  const auto groups = static_cast<std::size_t>(group_nodes_.rows());
  group_boxes_.assign(groups, Aabb{});
  std::vector<std::pair<Index, Index>> node_group;
  node_group.reserve(group_nodes_.indices.size());
  for (Index g = 0; g < group_nodes_.rows(); ++g)
    for (const Index v : group_nodes_.row(g)) node_group.emplace_back(v, g);
  node_groups_ = csr_from_pairs(num_nodes_, node_group);
  // How far a node may go from its reference: a quarter of the mean (finite) edge.
  double length = 0.0;
  std::size_t lengths = 0;
  for (const auto& e : edges_) {
    const double l = (positions.col(e[0]) - positions.col(e[1])).norm();
    if (std::isfinite(l)) length += l, ++lengths;
  }
  reach_ = lengths > 0 ? 0.25 * length / static_cast<double>(lengths) : 0.0;
  ref_.resize(3, 0);
  ref_boxes_.assign(groups, Aabb{});
  group_stamp_.assign(groups, 0);
  motion_frame_ = 0;
  box_frame_.assign(m, 0);
  sphere_frame_.assign(m, 0);
}

void CollisionBody::set_positions(const Positions& positions) {
  start_frame(positions, nullptr, nullptr);
}

void CollisionBody::set_positions(const Positions& positions, const Aabb& box) {
  start_frame(positions, &box, nullptr);
}

void CollisionBody::set_positions(const Positions& positions, const MotionBound& bound,
                                  const Aabb* box) {
  start_frame(positions, box, &bound);
}

void CollisionBody::apply_bound(const MotionBound& b) {
  const std::size_t groups = group_boxes_.size();
  if (bound_boxes_.size() != groups) {
    bound_boxes_.assign(groups, Aabb{});
    bound_radius_.assign(groups, 0.0);
    bound_version_.reset();
  }
  const auto radius = [&](Index v) {
    const double r2 = b.radius2[static_cast<std::size_t>(v)];
    return r2 > 0.0 ? std::sqrt(r2) : 0.0;  // -1: always moved, so at its reference
  };
  const auto refit = [&](Index g) {
    bound_boxes_[static_cast<std::size_t>(g)] = box_of_nodes(*b.reference, group_nodes_.row(g));
  };
  bound_frame_ = false;
  // A busy state (every tet checked, the reference not rebuilt): nothing changed in the
  // check, and nothing bounds this state.
  if (!b.bounded) return;
  if (b.rebuilt || bound_version_ != b.version_before) {
    // Every group anew. Usable this frame only when the reference is the state itself:
    // else the radii the state was tested with are gone.
    detail::for_chunks(groups, 16, [&](std::size_t begin, std::size_t end, std::size_t) {
      for (std::size_t g = begin; g < end; ++g) {
        refit(static_cast<Index>(g));
        double r = 0.0;
        for (const Index v : group_nodes_.row(static_cast<Index>(g))) r = std::max(r, radius(v));
        bound_radius_[g] = r;
      }
    });
    bound_frame_ = b.rebuilt;
  } else {
    // The groups of the nodes whose reference changed are refitted; the nodes whose radius
    // changed raise their groups' radius (the old radii bound this state, the new ones the
    // next).
    bound_dirty_.clear();
    for (const Index v : b.moved)
      for (const Index g : node_groups_.row(v)) bound_dirty_.push_back(g);
    sort_unique(bound_dirty_);
    detail::for_chunks(bound_dirty_.size(), 16,
                       [&](std::size_t begin, std::size_t end, std::size_t) {
                         for (std::size_t k = begin; k < end; ++k) refit(bound_dirty_[k]);
                       });
    for (const Index v : b.changed) {
      const double r = radius(v);
      for (const Index g : node_groups_.row(v)) {
        double& gr = bound_radius_[static_cast<std::size_t>(g)];
        gr = std::max(gr, r);
      }
    }
    bound_frame_ = true;
  }
  bound_version_ = b.version_after;
  bound_shift_ = b.shift;
  bound_rotated_ = b.rotated;
  bound_rotation_ = b.rotation;
  bound_pivot_ = b.pivot;
}

void CollisionBody::start_frame(const Positions& positions, const Aabb* box,
                                const MotionBound* bound) {
  if (positions.cols() != num_nodes_)
    throw std::invalid_argument("CollisionBody: " + std::to_string(positions.cols()) +
                                " positions for " + std::to_string(num_nodes_) + " nodes");
  positions_ = &positions;
  bounds_ready_ = false;
  tree_ready_ = false;
  clusters_ready_ = false;
  if (++frame_ == 0) {  // wrapped: forget every stamp
    frame_ = 1;
    std::fill(box_frame_.begin(), box_frame_.end(), 0);
    std::fill(sphere_frame_.begin(), sphere_frame_.end(), 0);
    std::fill(cluster_frame_.begin(), cluster_frame_.end(), 0);
    std::fill(group_stamp_.begin(), group_stamp_.end(), 0);
    motion_frame_ = 0;
  }
  const bool asked = near_asked_;
  decide_groups();
  // (Positions set without a bound leave the chain of the check's versions as it is: the
  // check's references and radii change only in a check, and the next bound says whether
  // one was missed.)
  bound_frame_ = false;
  const bool clustered = !cluster_tets_.offsets.empty();
  if (bound != nullptr && clustered) apply_bound(*bound);
  const std::size_t n = static_cast<std::size_t>(num_nodes_);
  const std::size_t chunks = detail::num_chunks(n, kNodeChunk);
  // A body whose near tets were asked by groups last frame likely is this frame too: its
  // nodes are compared with their references here, while each chunk is in cache (unless
  // the shape check's bound gives the group boxes).
  const bool compare = !bound_frame_ && asked && use_groups_ && ref_.cols() == num_nodes_;
  if (compare) moved_parts_.resize(chunks);
  std::vector<Aabb> part(box == nullptr ? chunks : 0);
  if (box == nullptr || compare)
    detail::for_chunks(n, kNodeChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
      const double* xyz = positions.data();
      if (box == nullptr)
        part[c] = box_of_finite_points([&](const auto& visit) {
          for (std::size_t i = begin; i < end; ++i) visit(xyz + 3 * i);
        });
      if (compare) compare_chunk(xyz, begin, end, c);
    });
  if (compare) motion_frame_ = frame_;
  if (box != nullptr) {
    box_ = *box;
  } else {
    box_ = Aabb{};
    for (const Aabb& b : part) box_.extend(b);
  }
  if (!clustered) {
    build_clusters(positions);
    if (bound != nullptr) apply_bound(*bound);
  }
}

void CollisionBody::reuse_positions() {
  if (positions_ == nullptr)
    throw std::logic_error("CollisionBody::reuse_positions: set_positions() was not called");
  // Nothing else to reset: the frame stamp, the ready flags and what they cover still hold.
  decide_groups();
}

void CollisionBody::decide_groups() {
  if (near_asked_)  // whether last frame's regions met few enough groups for them to pay
    use_groups_ = 2 * groups_met_ < group_boxes_.size();
  near_asked_ = false;
  groups_met_ = 0;
}

void CollisionBody::tets_near(const Aabb& region, std::vector<Index>& out) {
  if (positions_ == nullptr)
    throw std::logic_error("CollisionBody::tets_near: set_positions() was not called");
  const Positions& positions = *positions_;
  const auto clusters = static_cast<std::size_t>(cluster_tets_.rows());
  const auto groups = static_cast<std::size_t>(group_nodes_.rows());
  // Group g's clusters: [first, last).
  const auto first_cluster = [](std::size_t g) { return g * kClustersPerGroup; };
  const auto last_cluster = [&](std::size_t g) {
    return std::min(clusters, (g + 1) * kClustersPerGroup);
  };
  // Refits the listed clusters' boxes from the nodes their tets use, once a frame each.
  const auto refit = [&](std::span<const Index> list) {
    detail::for_chunks(list.size(), 256, [&](std::size_t begin, std::size_t end, std::size_t) {
      for (std::size_t k = begin; k < end; ++k) {
        const auto c = static_cast<std::size_t>(list[k]);
        tet_boxes_[c] = box_of_nodes(positions, cluster_nodes_.row(list[k]));
        cluster_frame_[c] = frame_;
      }
    });
  };
  if (!clusters_ready_) {
    // Once per frame and only for bodies in a pair whose object boxes touch: the group
    // boxes (each node read about once), or, when last frame's contact met most groups,
    // every cluster box directly.
    if (use_groups_ && bound_frame_) {
      // Every node lies within its radius of its reference in the shape check moved by
      // the shift (turned first when bound_rotated_). The check's rounding of that distance
      // and this box's are below 8 eps of the size of the coordinates: 32 eps covers them.
      // After a turn about the pivot p, the turned box's centre R (c - p) + s and
      // half-widths |R| h are sums of three products, each rounded, and so is the check's
      // turned reference: below 16 eps of the size (the pivot's included) each, 64 eps
      // covers them.
      const double shift_size = bound_shift_.cwiseAbs().maxCoeff() +
                                bound_pivot_.cwiseAbs().maxCoeff();  // (pivot 0: no turn)
      const double slack = (bound_rotated_ ? 64.0 : 32.0) * std::numeric_limits<double>::epsilon();
      const Eigen::Matrix3d turn_size = bound_rotation_.cwiseAbs();
      detail::for_chunks(groups, 64, [&](std::size_t begin, std::size_t end, std::size_t) {
        for (std::size_t g = begin; g < end; ++g) {
          const Aabb& q = bound_boxes_[g];
          if (q.empty()) {
            group_boxes_[g] = Aabb{};
            continue;
          }
          const double size =
              q.lo.cwiseAbs().cwiseMax(q.hi.cwiseAbs()).maxCoeff() + shift_size + bound_radius_[g];
          const Eigen::Vector3d grow = Eigen::Vector3d::Constant(bound_radius_[g] + slack * size);
          if (bound_rotated_) {
            const Eigen::Vector3d centre =
                bound_rotation_ * (0.5 * (q.lo + q.hi) - bound_pivot_).eval() + bound_shift_;
            const Eigen::Vector3d half = turn_size * (0.5 * (q.hi - q.lo)).eval() + grow;
            group_boxes_[g] = Aabb{centre - half, centre + half};
          } else {
            group_boxes_[g] = Aabb{q.lo + bound_shift_ - grow, q.hi + bound_shift_ + grow};
          }
        }
      });
    } else if (use_groups_) {
      if (motion_frame_ != frame_ && ref_.cols() == num_nodes_) {  // not compared yet
        const std::size_t n = static_cast<std::size_t>(num_nodes_);
        moved_parts_.resize(detail::num_chunks(n, kNodeChunk));
        detail::for_chunks(n, kNodeChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
          compare_chunk(positions.data(), begin, end, c);
        });
        motion_frame_ = frame_;
      }
      finish_motion(positions);
    } else {
      stale_clusters_.resize(clusters);
      std::iota(stale_clusters_.begin(), stale_clusters_.end(), Index{0});
      refit(stale_clusters_);
      for (std::size_t g = 0; g < groups; ++g) {  // the same boxes, from the clusters'
        Aabb b;
        for (std::size_t c = first_cluster(g); c < last_cluster(g); ++c) b.extend(tet_boxes_[c]);
        group_boxes_[g] = b;
      }
    }
    clusters_ready_ = true;
  }
  near_asked_ = true;
  // The clusters of the groups that meet the region; those not refitted yet this frame
  // are refitted now. A cluster's box lies in its group's.
  const auto group_met = [&](std::size_t g) { return group_boxes_[g].overlaps(region); };
  stale_clusters_.clear();
  for (std::size_t g = 0; g < groups; ++g) {
    if (!group_met(g)) continue;
    ++groups_met_;
    for (std::size_t c = first_cluster(g); c < last_cluster(g); ++c)
      if (cluster_frame_[c] != frame_) stale_clusters_.push_back(static_cast<Index>(c));
  }
  refit(stale_clusters_);
  // The clusters partition the tets: their rows, merged in tet order through a bitmap
  // (a sort of the few thousand tets near a contact cost more than the rest of the cull).
  out.clear();
  detail::SortedIndexSet set(near_bits_, tets_.size());
  for (std::size_t g = 0; g < groups; ++g) {
    if (!group_met(g)) continue;
    for (std::size_t c = first_cluster(g); c < last_cluster(g); ++c)
      if (tet_boxes_[c].overlaps(region))
        for (const Index t : cluster_tets_.row(static_cast<Index>(c))) set.insert(t);
  }
  set.drain(out);
}

void CollisionBody::compare_chunk(const double* xyz, std::size_t begin, std::size_t end,
                                  std::size_t c) {
  std::vector<Index>& moved = moved_parts_[c];
  moved.clear();
  const double* ref = ref_.data();
  const double r = reach_;
  const auto beyond_reach = pick_kernel(detail::beyond_reach_baseline, detail::beyond_reach_avx2);
  std::size_t i = begin;
  for (; i + detail::kReachLanes <= end; i += detail::kReachLanes)  // in order
    for (unsigned m = beyond_reach(xyz + 3 * i, ref + 3 * i, r); m != 0; m &= m - 1)
      moved.push_back(static_cast<Index>(i + static_cast<std::size_t>(std::countr_zero(m))));
  for (; i < end; ++i) {
    const double* p = xyz + 3 * i;
    const double* q = ref + 3 * i;
    // Beyond reach along an axis, or not finite now or at the reference (NaN: false).
    if (!(std::abs(p[0] - q[0]) <= r && std::abs(p[1] - q[1]) <= r && std::abs(p[2] - q[2]) <= r))
      moved.push_back(static_cast<Index>(i));
  }
}

void CollisionBody::finish_motion(const Positions& positions) {
  const std::size_t n = static_cast<std::size_t>(num_nodes_);
  const std::size_t groups = group_boxes_.size();
  std::size_t moved = 0;
  const bool made = ref_.cols() == num_nodes_ && motion_frame_ == frame_;
  if (made)
    for (const auto& part : moved_parts_) moved += part.size();
  dirty_groups_.clear();
  if (!made || 4 * moved > n) {  // first time, or most nodes moved: every group anew
    ref_ = positions;
    dirty_groups_.resize(groups);
    std::iota(dirty_groups_.begin(), dirty_groups_.end(), Index{0});
  } else {
    for (const auto& part : moved_parts_)
      for (const Index v : part) {
        ref_.col(v) = positions.col(v);
        for (const Index g : node_groups_.row(v)) {
          auto& stamp = group_stamp_[static_cast<std::size_t>(g)];
          if (stamp != frame_) stamp = frame_, dirty_groups_.push_back(g);
        }
      }
  }
  for (auto& part : moved_parts_) part.clear();  // moved into the references: not again
  detail::for_chunks(
      dirty_groups_.size(), 16, [&](std::size_t begin, std::size_t end, std::size_t) {
        for (std::size_t k = begin; k < end; ++k) {
          const Index g = dirty_groups_[k];
          ref_boxes_[static_cast<std::size_t>(g)] = box_of_nodes(ref_, group_nodes_.row(g));
        }
      });
  // Every node is within reach_ of its reference along each axis (those beyond were just
  // moved into it): twice that around the reference boxes covers the rounding too.
  const Eigen::Vector3d grow = Eigen::Vector3d::Constant(2.0 * reach_);
  for (std::size_t g = 0; g < groups; ++g)
    group_boxes_[g] = Aabb{ref_boxes_[g].lo - grow, ref_boxes_[g].hi + grow};
}

void CollisionBody::ensure_bounds(std::span<const Index> tets, bool spheres) {
  if (positions_ == nullptr)
    throw std::logic_error("CollisionBody::ensure_bounds: set_positions() was not called");
  if (bounds_ready_ && (!spheres || spheres_ready_)) return;
  stale_.clear();
  for (const Index t : tets)
    if (box_frame_[t] != frame_ || (spheres && sphere_frame_[t] != frame_)) stale_.push_back(t);
  if (stale_.empty()) return;
  bounds_.compute(*positions_, tets_, stale_, spheres);
  for (const Index t : stale_) {
    box_frame_[t] = frame_;
    if (spheres) sphere_frame_[t] = frame_;
  }
}

void CollisionBody::prepare(BroadPhaseKind kind) {
  if (positions_ == nullptr)
    throw std::logic_error("CollisionBody::prepare: set_positions() was not called");
  const bool spheres = kind == BroadPhaseKind::kGrid;
  if (!bounds_ready_ || (spheres && !spheres_ready_)) {
    bounds_.compute(*positions_, tets_, spheres);
    bounds_ready_ = true;
    spheres_ready_ = spheres;
  }
  if (kind == BroadPhaseKind::kBvh && !tree_ready_) {
    if (!tree_built_) {
      tree_.build(bounds_.boxes);  // shape fixed from now on (per topology)
      tree_built_ = true;
    } else {
      tree_.refit(bounds_.boxes);
    }
    tree_ready_ = true;
  }
}

// ----------------------------------------------------------------------------- Detector

/// One thread's TetGeometry of the tets in candidate pairs, [0] for body A's slots and [1]
/// for B's, built when the thread first needs a tet in a detect() call (stamp).
struct Detector::ThreadGeometry {
  struct Copy {
    std::array<std::vector<TetGeometry>, 2> geom;
    std::array<std::vector<std::uint64_t>, 2> built;  ///< per slot: the stamp it was built at
    std::uint64_t all_built = 0;                      ///< the stamp every slot was built at
    std::vector<Index> missing;                       ///< scratch: slots to build

    /// True when slot s of body w (0: A, 1: B) is still to be built in the detect() call
    /// `stamp`; it then counts as built.
    bool claim(std::size_t w, Index s, std::uint64_t stamp) {
      if (all_built == stamp) return false;
      std::uint64_t& b = built[w][static_cast<std::size_t>(s)];
      if (b == stamp) return false;
      b = stamp;
      return true;
    }
  };
  tbb::enumerable_thread_specific<Copy> copies;

  /// This thread's copy, sized for the slots of both bodies.
  Copy& local(std::size_t slots_a, std::size_t slots_b) {
    Copy& copy = copies.local();
    const std::array<std::size_t, 2> slots = {slots_a, slots_b};
    for (std::size_t w = 0; w < 2; ++w) {
      if (copy.geom[w].size() < slots[w]) copy.geom[w].resize(slots[w]);
      if (copy.built[w].size() < slots[w]) copy.built[w].resize(slots[w], 0);
    }
    return copy;
  }
};

namespace {

/// Builds the geometry of the slots slot_at(0), ..., slot_at(count - 1) (slot s: tet tets[s]
/// of the body at positions p) into geom, 4 tets a call (make_tet_geometry4: the bits of
/// make_tet_geometry).
template <typename SlotAt>
void build_slots(const Positions& p, std::span<const Tet> body_tets, std::span<const Index> tets,
                 std::size_t count, const SlotAt& slot_at, std::vector<TetGeometry>& geom) {
  const auto corners_of = [&](std::size_t slot) {
    return tet_corners(p, body_tets[static_cast<std::size_t>(tets[slot])]);
  };
  std::size_t k = 0;
  for (; k + 4 <= count; k += 4) {
    std::array<TetCorners, 4> corners;
    std::array<TetGeometry*, 4> out;
    for (std::size_t j = 0; j < 4; ++j) {
      const std::size_t slot = slot_at(k + j);
      corners[j] = corners_of(slot);
      out[j] = &geom[slot];
    }
    make_tet_geometry4(corners, out);
  }
  for (; k < count; ++k) make_tet_geometry(corners_of(slot_at(k)), geom[slot_at(k)]);
}

}  // namespace

/// The calling thread's geometry of one body's slots, built on first use in this detect()
/// call: what the intrusion scans test points and segments against.
class Detector::GeometryOf {
 public:
  GeometryOf(ThreadGeometry::Copy& copy, int side, std::uint64_t stamp, const Positions& positions,
             std::span<const Tet> body_tets, std::span<const Index> tets)
      : copy_(copy),
        side_(static_cast<std::size_t>(side)),
        stamp_(stamp),
        positions_(positions),
        body_tets_(body_tets),
        tets_(tets) {}

  const TetGeometry& operator()(Index slot) {
    std::vector<TetGeometry>& geom = copy_.geom[side_];
    const auto s = static_cast<std::size_t>(slot);
    if (copy_.claim(side_, slot, stamp_))
      build_slots(
          positions_, body_tets_, tets_, 1, [s](std::size_t) { return s; }, geom);
    return geom[s];
  }
  /// The slot of geometry g: &g - base().
  [[nodiscard]] const TetGeometry* base() const { return copy_.geom[side_].data(); }

 private:
  ThreadGeometry::Copy& copy_;
  std::size_t side_;
  std::uint64_t stamp_;
  const Positions& positions_;
  std::span<const Tet> body_tets_;
  std::span<const Index> tets_;
};

Detector::Detector(DetectOptions options)
    : options_(options), thread_geometry_(std::make_unique<ThreadGeometry>()) {}
Detector::~Detector() = default;
Detector::Detector(Detector&&) noexcept = default;
Detector& Detector::operator=(Detector&&) noexcept = default;

void Detector::index_tets(const CollisionBody& body, Geometry& g) {
  if (g.slot.size() < body.tets_.size()) g.slot.resize(body.tets_.size(), -1);
  g.boxes.resize(g.tets.size());
  for (std::size_t i = 0; i < g.tets.size(); ++i) g.slot[g.tets[i]] = static_cast<Index>(i);
  // The tet boxes the broad phase made this frame for every tet near the contact (every
  // tet in a candidate pair is): the corners' min and max, empty for a non-finite corner,
  // as in make_tet_geometry() (up to the sign of a zero, which no test below can see).
  for (std::size_t i = 0; i < g.tets.size(); ++i) {
    const Aabb& box = body.bounds_.boxes[static_cast<std::size_t>(g.tets[i])];
    g.boxes[i] = box.empty() ? TetBox{box.lo, box.hi, 0.0}
                             : TetBox{box.lo, box.hi, (box.hi - box.lo).maxCoeff()};
  }
  g.reach = TetBox{Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()),
                   Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity()), 0.0};
  for (const TetBox& b : g.boxes) {
    g.reach.lo = g.reach.lo.cwiseMin(b.lo);
    g.reach.hi = g.reach.hi.cwiseMax(b.hi);
    g.reach.scale = std::max(g.reach.scale, b.scale);
  }
}

void Detector::clear_slots(Geometry& g) {
  for (const Index t : g.tets) g.slot[t] = -1;
}

void Detector::gather_near(CollisionBody& body, const Aabb& region,
                           std::vector<Index>& list) const {
  if (options_.cluster_cull) {
    body.tets_near(region, list);
  } else {
    list.resize(body.tets_.size());
    std::iota(list.begin(), list.end(), Index{0});
  }
}

void Detector::filter_tets(const CollisionBody& body, std::span<const Index> near,
                           const Aabb& region, std::vector<Index>& subset,
                           std::vector<Aabb>& boxes) {
  // Each tet whose box meets the region gets the box of its part inside it (exact across
  // the region's thinnest axis): where the objects barely touch, the overlap box is a
  // thin slab and these boxes are much smaller than the tets'.
  const Eigen::Vector3d extent = region.hi - region.lo;
  int slab_axis = 0;
  if (extent.y() < extent[slab_axis]) slab_axis = 1;
  if (extent.z() < extent[slab_axis]) slab_axis = 2;
  const double rel = relative_tolerance();
  const std::size_t m = near.size();
  const std::size_t chunks = detail::num_chunks(m, kFilterChunk);
  detail::reset_parts(index_parts_, chunks);
  detail::reset_parts(box_parts_, chunks);
  const Positions& p = *body.positions_;
  detail::for_chunks(m, kFilterChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
    // The tets whose box meets the region, 4 at a time through clipped_tet_boxes4 (the
    // same boxes as clipped_tet_box), in order.
    std::array<TetCorners, 4> corners;
    std::array<double, 4> pads;
    std::array<Index, 4> tets;
    std::array<Aabb, 4> clipped;
    std::size_t waiting = 0;
    const auto flush = [&] {
      if (waiting == 4) {
        clipped_tet_boxes4(corners, region, slab_axis, pads, clipped);
      } else {
        for (std::size_t j = 0; j < waiting; ++j)
          clipped[j] = clipped_tet_box(corners[j], region, slab_axis, pads[j]);
      }
      for (std::size_t j = 0; j < waiting; ++j) {
        if (clipped[j].empty()) continue;
        index_parts_[c].push_back(tets[j]);
        box_parts_[c].push_back(clipped[j]);
      }
      waiting = 0;
    };
    for (std::size_t i = begin; i < end; ++i) {
      const auto t = static_cast<std::size_t>(near[i]);
      const Aabb& raw = body.bounds_.boxes[t];
      if (!raw.overlaps(region)) continue;
      // Pad: the tolerance scale of this tet, plus rounding of its coordinates.
      pads[waiting] = rel * (raw.hi - raw.lo).maxCoeff() +
                      8.0 * std::numeric_limits<double>::epsilon() *
                          raw.lo.cwiseAbs().cwiseMax(raw.hi.cwiseAbs()).maxCoeff();
      corners[waiting] = tet_corners(p, body.tets_[t]);
      tets[waiting] = static_cast<Index>(t);
      if (++waiting == 4) flush();
    }
    flush();
  });
  detail::concat_parts(index_parts_, chunks, subset);
  detail::concat_parts(box_parts_, chunks, boxes);
}

/// The broad-phase pairs of one object pair, kept across frames: every pair of entries of
/// the two `tets` lists whose `boxes` overlap. Each entry's box is the box of its tet's
/// part inside the overlap box padded by `margin`, itself padded by `margin`. While each
/// tet that the broad phase keeps in a later frame is in these lists and its box then lies
/// inside its box here, every pair whose boxes overlap then is among these pairs (each box
/// lies inside its padded one, so the padded ones overlap too): testing these pairs' boxes
/// of the frame gives the same candidates as a tree would.
struct Detector::KeptPairs {
  const CollisionBody* a = nullptr;
  const CollisionBody* b = nullptr;
  std::array<std::vector<Index>, 2> tets;  ///< A's and B's, sorted
  std::array<std::vector<Aabb>, 2> boxes;  ///< padded, per entry of tets
  std::array<std::vector<Index>, 2> slot;  ///< per tet of the body: entry in tets, or -1
  /// The pairs, each as (A's entry, B's entry) rather than tets (one list made in place),
  /// sorted: the entries follow tet order, so these follow (tet_a, tet_b).
  std::vector<TetPair> pairs;
  /// This call's box of each entry (empty when the broad phase did not keep its tet).
  std::array<std::vector<Aabb>, 2> now;
  /// The margin as a fraction of the mean box extent of the tets near the contact:
  /// halved when a list serves long, doubled when it serves briefly.
  double fraction = 0.02;
  int served = 0;  ///< calls served since made
  /// Calls left before keeping again. A new object pair starts with one: its first call
  /// is served by the tree (a one-off detection, or the first frame of a contact that may
  /// not last, would pay for a list it never uses).
  int pause = 1;
  int pauses = 0;           ///< pauses in a row
  int shorts = 0;           ///< short-lived lists in a row with the widest margin
  std::uint64_t used = 0;   ///< last use (the Detector's count of calls)
  AabbTree tree;            ///< over B's padded boxes, when made
  std::vector<Index> near;  ///< scratch
};

namespace {

/// The margin's fraction of the mean box extent near the contact stays in this range. A
/// list that serves fewer than kKeptShort calls gets a wider margin next time; after two
/// such lists in a row with the widest margin, none is made for kKeptPause calls (contact
/// that moves too fast for kept pairs is not slowed down), and each further pause in a row
/// is twice as long, up to 16 times. A list that serves more than kKeptLong calls gets a
/// narrower margin next time (fewer pairs to test).
constexpr double kKeptMinFraction = 0.005;
constexpr double kKeptMaxFraction = 0.08;
constexpr int kKeptShort = 8;
constexpr int kKeptLong = 64;
constexpr int kKeptPause = 64;
constexpr int kKeptMaxPauseShift = 4;  ///< pauses in a row grow to 16 kKeptPause
/// Object pairs whose kept pairs are held (the least recently used goes first).
constexpr std::size_t kKeptPairsHeld = 16;

}  // namespace

Detector::KeptPairs* Detector::kept_of(const CollisionBody& a, const CollisionBody& b) {
  KeptPairs* k = nullptr;
  for (auto& e : kept_)
    if (e->a == &a && e->b == &b) k = e.get();
  if (k == nullptr) {
    if (kept_.size() >= kKeptPairsHeld)
      kept_.erase(std::min_element(kept_.begin(), kept_.end(),
                                   [](const auto& x, const auto& y) { return x->used < y->used; }));
    kept_.push_back(std::make_unique<KeptPairs>());
    k = kept_.back().get();
    k->a = &a;
    k->b = &b;
  }
  k->used = ++kept_calls_;
  return k;
}

bool Detector::kept_paused(KeptPairs& k) {
  if (k.pause == 0) return false;
  --k.pause;
  return true;
}

bool Detector::candidates_from_kept(KeptPairs* k, CollisionBody& a, CollisionBody& b,
                                    const Aabb& cull, DetectStats& st) {
  const std::array<CollisionBody*, 2> bodies = {&a, &b};
  const std::array<const std::vector<Index>*, 2> subsets = {&subset_a_, &subset_b_};
  const std::array<const std::vector<Aabb>*, 2> boxes_now = {&boxes_a_, &boxes_b_};
  // Whether each tet the broad phase kept is in the lists with its box inside its padded
  // one; on the way, this call's box of each entry.
  const auto covers = [&] {
    for (std::size_t s = 0; s < 2; ++s) {
      const std::vector<Index>& slot = k->slot[s];
      const std::vector<Aabb>& padded = k->boxes[s];
      const std::vector<Index>& tets = *subsets[s];
      const std::vector<Aabb>& boxes = *boxes_now[s];
      std::vector<Aabb>& now = k->now[s];
      if (slot.size() != bodies[s]->tets_.size()) return false;
      now.assign(padded.size(), Aabb{});
      for (std::size_t i = 0; i < tets.size(); ++i) {
        const Index j = slot[static_cast<std::size_t>(tets[i])];
        if (j < 0 || !padded[static_cast<std::size_t>(j)].contains(boxes[i])) return false;
        now[static_cast<std::size_t>(j)] = boxes[i];
      }
    }
    return true;
  };
  if (!covers()) {
    if (!k->tets[0].empty()) {  // a list that served k->served calls: its margin next time
      if (k->served < kKeptShort) {
        // Short-lived: a wider margin next time. Twice in a row with the widest one (a
        // jump of the contact ends one short list, not two), too fast for kept pairs:
        // they sit out, longer each time in a row.
        k->shorts = k->fraction >= kKeptMaxFraction ? k->shorts + 1 : 0;
        if (k->shorts >= 2) {
          k->pause = kKeptPause << std::min(k->pauses++, kKeptMaxPauseShift);
          k->fraction = kKeptMaxFraction / 2;
          k->shorts = 0;
          k->tets[0].clear();
          return false;
        }
        k->fraction = std::min(2 * k->fraction, kKeptMaxFraction);
      } else {
        k->shorts = 0;
        k->pauses = 0;
        if (k->served > kKeptLong) k->fraction = std::max(k->fraction / 2, kKeptMinFraction);
      }
    }
    // Made again, over the tets near the overlap box padded by the margin.
    double extent = 0.0;
    std::size_t count = 0;
    for (std::size_t s = 0; s < 2; ++s)
      for (const Index t : *subsets[s]) {
        const Aabb& raw = bodies[s]->bounds_.boxes[static_cast<std::size_t>(t)];
        extent += (raw.hi - raw.lo).maxCoeff();
        ++count;
      }
    const double margin = count > 0 ? k->fraction * extent / static_cast<double>(count) : 0.0;
    if (!(margin > 0.0) || !std::isfinite(margin)) return false;
    const Eigen::Vector3d pad = Eigen::Vector3d::Constant(margin);
    const Aabb region{cull.lo - pad, cull.hi + pad};
    for (std::size_t s = 0; s < 2; ++s) {
      for (const Index t : k->tets[s]) k->slot[s][static_cast<std::size_t>(t)] = -1;
      CollisionBody& body = *bodies[s];
      gather_near(body, region, k->near);
      body.ensure_bounds(k->near, false);
      filter_tets(body, k->near, region, k->tets[s], k->boxes[s]);
      for (Aabb& box : k->boxes[s]) {
        box.lo -= pad;
        box.hi += pad;
      }
      k->slot[s].resize(body.tets_.size(), -1);
      for (std::size_t i = 0; i < k->tets[s].size(); ++i)
        k->slot[s][static_cast<std::size_t>(k->tets[s][i])] = static_cast<Index>(i);
    }
    k->tree.build(k->boxes[1]);
    BvhSide bvh;
    bvh.tree = &k->tree;
    bvh.tet_boxes = k->boxes[1];
    bvh.over_side = true;
    broad_.find_pairs(BroadPhaseKind::kBvh, {k->tets[0], k->boxes[0], a.bounds_.spheres},
                      {k->tets[1], k->boxes[1], b.bounds_.spheres}, bvh, k->pairs);
    for (TetPair& p : k->pairs)
      p = {k->slot[0][static_cast<std::size_t>(p.tet_a)],
           k->slot[1][static_cast<std::size_t>(p.tet_b)]};
    k->served = 0;
    st.pairs_rebuilt = true;
    if (!covers()) {  // (rounding beyond the margin: not expected)
      k->tets[0].clear();
      return false;
    }
  }
  // This call's candidates: the kept pairs whose boxes of this frame overlap, in order,
  // written without a branch on each.
  const std::vector<TetPair>& pairs = k->pairs;
  const std::size_t chunks = detail::num_chunks(pairs.size(), kKeptChunk);
  detail::reset_parts(pair_parts_, chunks);
  detail::for_chunks(
      pairs.size(), kKeptChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
        std::vector<TetPair>& part = pair_parts_[c];
        part.resize(end - begin);
        std::size_t kept = 0;
        for (std::size_t i = begin; i < end; ++i) {
          const auto ia = static_cast<std::size_t>(pairs[i].tet_a);  // entries (above)
          const auto ib = static_cast<std::size_t>(pairs[i].tet_b);
          part[kept] = {k->tets[0][ia], k->tets[1][ib]};
          kept += k->now[0][ia].overlaps(k->now[1][ib]) ? 1 : 0;
        }
        part.resize(kept);
      });
  detail::concat_parts(pair_parts_, chunks, candidates_);
  ++k->served;
  st.pairs_kept = true;
  return true;
}

void Detector::detect(CollisionBody& a, CollisionBody& b, PairContacts& out, DetectStats* stats,
                      const EdgeNeed& need_edges) {
  const auto start = Clock::now();
  DetectStats st;
  out.overlapping.clear();
  out.marked_a.clear();
  out.marked_b.clear();
  out.nodes_a_in_b.clear();
  out.nodes_b_in_a.clear();
  out.edges_a_in_b.clear();
  out.edges_b_in_a.clear();
  candidates_.clear();
  if (a.positions_ == nullptr || b.positions_ == nullptr)
    throw std::logic_error("Detector::detect: set_positions() was not called");

  st.boxes_overlap = a.box().overlaps(b.box());
  if (!st.boxes_overlap) {
    st.broad_ms = st.total_ms = ms_since(start);
    if (stats != nullptr) *stats = st;
    return;
  }
  const BroadPhaseKind kind = options_.broad_phase;
  // Only the tets of the clusters that meet the overlap box of the two objects get
  // bounds and the filter below: a small tool in a large organ costs what the part of
  // the organ near the tool costs, not the whole organ.
  const Aabb cull = a.box().intersection(b.box());
  gather_near(a, cull, near_a_);
  gather_near(b, cull, near_b_);
  st.tets_a_near = near_a_.size();
  st.tets_b_near = near_b_.size();
  const bool spheres = kind == BroadPhaseKind::kGrid;
  // kBvh: B's persistent tree (refitted over all of B) when most of B is near the
  // overlap, else a tree built over the few tets of B that pass the filter. Both give
  // the same pairs.
  const bool full_tree = kind == BroadPhaseKind::kBvh &&
                         (!options_.cluster_cull || 2 * near_b_.size() > b.tets_.size());
  // Kept pairs need no tree: B's bounds where it is near, as for a local tree.
  KeptPairs* const kept_pairs =
      kind == BroadPhaseKind::kBvh && options_.keep_pairs ? kept_of(a, b) : nullptr;
  const bool keep = kept_pairs != nullptr && !kept_paused(*kept_pairs);
  if (full_tree && !keep)
    b.prepare(kind);
  else
    b.ensure_bounds(near_b_, spheres);
  a.ensure_bounds(near_a_, spheres);
  st.bounds_ms = ms_since(start);

  // Tets whose box meets the overlap box of the two objects: the only ones that can
  // overlap anything of the other object (filter_tets()).
  filter_tets(a, near_a_, cull, subset_a_, boxes_a_);
  filter_tets(b, near_b_, cull, subset_b_, boxes_b_);
  st.tets_a_in_box = subset_a_.size();
  st.tets_b_in_box = subset_b_.size();
  const double rel = relative_tolerance();

  const bool from_kept = keep && candidates_from_kept(kept_pairs, a, b, cull, st);
  if (!from_kept) {
    if (full_tree && keep) b.prepare(kind);  // (its bounds were made near the contact only)
    BvhSide bvh;
    if (full_tree) {
      if (box_slot_.size() < b.tets_.size()) box_slot_.resize(b.tets_.size(), -1);
      for (std::size_t k = 0; k < subset_b_.size(); ++k)
        box_slot_[subset_b_[k]] = static_cast<Index>(k);
      bvh = {&b.tree_, b.bounds_.boxes, box_slot_};
    } else if (kind == BroadPhaseKind::kBvh) {
      // A local tree. Any tree over these boxes answers the same (a refit makes every
      // node box exact); only its shape, and so the query cost, depends on where the
      // boxes were when it was built: rebuilt when the tets change, and every
      // kLocalTreeRefits frames.
      if (local_tree_body_ == &b && local_tree_refits_ < kLocalTreeRefits &&
          local_tree_tets_ == subset_b_) {
        local_tree_.refit(boxes_b_);
        ++local_tree_refits_;
        st.local_tree_refitted = true;
      } else {
        local_tree_.build(boxes_b_);
        local_tree_body_ = &b;
        local_tree_tets_ = subset_b_;
        local_tree_refits_ = 0;
      }
      bvh.tree = &local_tree_;
      bvh.tet_boxes = boxes_b_;
      bvh.over_side = true;
    }
    broad_.find_pairs(kind, {subset_a_, boxes_a_, a.bounds_.spheres},
                      {subset_b_, boxes_b_, b.bounds_.spheres}, bvh, candidates_);
    if (full_tree)
      for (const Index t : subset_b_) box_slot_[t] = -1;
  }
  if (!a.left_out_.empty() || !b.left_out_.empty()) {
    // Tets left out of contact (set_left_out_tets()): no pair with them is tested, so they
    // are never marked and never host an intruding node or edge. The kept pairs keep
    // them: a tet left out this frame may take part in the next.
    const auto out_of = [](const std::vector<Index>& list, Index t) {
      return !list.empty() && std::binary_search(list.begin(), list.end(), t);
    };
    std::erase_if(candidates_, [&](const TetPair& p) {
      return out_of(a.left_out_, p.tet_a) || out_of(b.left_out_, p.tet_b);
    });
  }
  st.candidates = candidates_.size();
  const auto broad_end = Clock::now();
  st.broad_ms = std::chrono::duration<double, std::milli>(broad_end - start).count();

  // Geometry of the tets in candidate pairs, once per tet.
  geom_a_.tets.clear();
  for (const TetPair& p : candidates_)
    if (geom_a_.tets.empty() || geom_a_.tets.back() != p.tet_a) geom_a_.tets.push_back(p.tet_a);
  geom_b_.tets.clear();
  {
    detail::SortedIndexSet set(bits_, b.tets_.size());
    for (const TetPair& p : candidates_) set.insert(p.tet_b);
    set.drain(geom_b_.tets);
  }
  index_tets(a, geom_a_);
  index_tets(b, geom_b_);
  ++geometry_stamp_;
  if (detail::single_thread()) {
    // Every chunk below runs on this thread: all the geometry now, in slot order.
    auto& copy = thread_geometry_->local(geom_a_.tets.size(), geom_b_.tets.size());
    const auto same = [](std::size_t k) { return k; };
    build_slots(*a.positions_, a.tets_, geom_a_.tets, geom_a_.tets.size(), same, copy.geom[0]);
    build_slots(*b.positions_, b.tets_, geom_b_.tets, geom_b_.tets.size(), same, copy.geom[1]);
    copy.all_built = geometry_stamp_;
  }

  // Narrow phase: exact overlap of every candidate, in candidate order.
  {
    const std::size_t chunks = detail::num_chunks(candidates_.size(), kNarrowChunk);
    detail::reset_parts(pair_parts_, chunks);
    detail::for_chunks(
        candidates_.size(), kNarrowChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
          // This thread's geometry of the chunk's tets, built now where it has not yet
          // been in this call (A's tets come in order, B's scattered).
          auto& copy = thread_geometry_->local(geom_a_.tets.size(), geom_b_.tets.size());
          const std::uint64_t stamp = geometry_stamp_;
          const auto gather = [&](std::size_t w, const Geometry& g, auto tet_of) {
            copy.missing.clear();
            if (copy.all_built == stamp) return;  // the calling thread of a one-thread call
            for (std::size_t i = begin; i < end; ++i) {
              const Index slot = g.slot[tet_of(candidates_[i])];
              if (copy.claim(w, slot, stamp)) copy.missing.push_back(slot);
            }
          };
          const auto missing = [&](std::size_t k) {
            return static_cast<std::size_t>(copy.missing[k]);
          };
          gather(0, geom_a_, [](const TetPair& p) { return p.tet_a; });
          build_slots(*a.positions_, a.tets_, geom_a_.tets, copy.missing.size(), missing,
                      copy.geom[0]);
          gather(1, geom_b_, [](const TetPair& p) { return p.tet_b; });
          build_slots(*b.positions_, b.tets_, geom_b_.tets, copy.missing.size(), missing,
                      copy.geom[1]);
          std::array<GeometryPair, kNarrowChunk> pairs;
          std::array<bool, kNarrowChunk> hits;
          const std::size_t n = end - begin;
          for (std::size_t i = 0; i < n; ++i) {
            const TetPair& p = candidates_[begin + i];
            pairs[i] = {&copy.geom[0][static_cast<std::size_t>(geom_a_.slot[p.tet_a])],
                        &copy.geom[1][static_cast<std::size_t>(geom_b_.slot[p.tet_b])]};
          }
          tets_overlap_pairs({pairs.data(), n}, rel, {hits.data(), n});
          // The overlapping ones kept in order, without a branch on each (about half of
          // the candidates overlap, in no pattern a branch predictor could learn).
          std::vector<TetPair>& part = pair_parts_[c];
          std::size_t kept = part.size();
          part.resize(kept + n);
          for (std::size_t i = 0; i < n; ++i) {
            part[kept] = candidates_[begin + i];
            kept += hits[i] ? 1 : 0;
          }
          part.resize(kept);
        });
    detail::concat_parts(pair_parts_, chunks, out.overlapping);
  }
  st.overlapping = out.overlapping.size();

  // Marked tets and, for each, the tets of the other object it overlaps (as geometry
  // slots, which follow tet order).
  // Both lists are written without a branch on "a new tet": each entry goes to the next
  // free place, which only a new tet keeps (whether a pair starts a new tet follows no
  // pattern a branch predictor could learn).
  const std::size_t num_overlapping = out.overlapping.size();
  rows_a_.items.resize(num_overlapping);
  out.marked_a.resize(num_overlapping);
  rows_a_.offsets.resize(num_overlapping + 1);
  {
    std::size_t rows = 0;
    Index previous = -1;  // no tet
    for (std::size_t i = 0; i < num_overlapping; ++i) {
      const TetPair& p = out.overlapping[i];
      out.marked_a[rows] = p.tet_a;
      rows_a_.offsets[rows] = static_cast<Index>(i);
      rows += p.tet_a != previous ? 1 : 0;
      previous = p.tet_a;
      rows_a_.items[i] = geom_b_.slot[p.tet_b];
    }
    out.marked_a.resize(rows);
    rows_a_.offsets.resize(rows);
  }
  rows_a_.offsets.push_back(static_cast<Index>(num_overlapping));

  // B's rows: a counting sort of the pairs on tet_b's slot. The pairs come sorted by
  // (tet_a, tet_b), so each row of B receives its tets of A in increasing order.
  counts_.assign(geom_b_.tets.size(), 0);
  for (const TetPair& p : out.overlapping) ++counts_[geom_b_.slot[p.tet_b]];
  out.marked_b.resize(geom_b_.tets.size());
  rows_b_.offsets.resize(geom_b_.tets.size() + 1);
  Index filled = 0;
  {
    std::size_t rows = 0;
    for (std::size_t s = 0; s < geom_b_.tets.size(); ++s) {
      const Index count = counts_[s];
      out.marked_b[rows] = geom_b_.tets[s];
      rows_b_.offsets[rows] = filled;
      rows += count > 0 ? 1 : 0;
      counts_[s] = filled;
      filled += count;
    }
    out.marked_b.resize(rows);
    rows_b_.offsets.resize(rows);
  }
  rows_b_.offsets.push_back(filled);
  rows_b_.items.resize(num_overlapping);
  for (const TetPair& p : out.overlapping)
    rows_b_.items[counts_[geom_b_.slot[p.tet_b]]++] = geom_a_.slot[p.tet_a];

  const auto intrusion_start = Clock::now();
  std::array<bool, 2> edges = {options_.intruding_edges, options_.intruding_edges};
  if (options_.intruding_edges && need_edges && !out.overlapping.empty()) edges = need_edges(out);
  if (!out.overlapping.empty() && (options_.intruding_nodes || edges[0] || edges[1])) {
    for (int side = 0; side < 2; ++side) {
      const CollisionBody& x = side == 0 ? a : b;
      const CollisionBody& y = side == 0 ? b : a;
      const Geometry& gy = side == 0 ? geom_b_ : geom_a_;
      const std::vector<Index>& marked = side == 0 ? out.marked_a : out.marked_b;
      const Rows& rows = side == 0 ? rows_a_ : rows_b_;
      if (row_of_.size() < x.tets_.size()) row_of_.resize(x.tets_.size(), -1);
      for (std::size_t r = 0; r < marked.size(); ++r) row_of_[marked[r]] = static_cast<Index>(r);
      const int gy_side = 1 - side;
      if (options_.intruding_nodes)
        intruding_nodes(x, marked, rows, y, gy, gy_side,
                        side == 0 ? out.nodes_a_in_b : out.nodes_b_in_a);
      if (edges[static_cast<std::size_t>(side)])
        intruding_edges(x, marked, rows, y, gy, gy_side,
                        side == 0 ? out.edges_a_in_b : out.edges_b_in_a);
      for (const Index t : marked) row_of_[t] = -1;
    }
  }
  clear_slots(geom_a_);
  clear_slots(geom_b_);
  st.intrusion_ms = ms_since(intrusion_start);

  st.narrow_ms = ms_since(broad_end);
  st.total_ms = ms_since(start);
  if (stats != nullptr) *stats = st;
}

void Detector::collect_features(std::span<const Index> marked, const CollisionBody& x, bool edges) {
  // The nodes (or edges) of the marked tets of X, each once, sorted.
  const std::size_t count = edges ? x.edges_.size() : static_cast<std::size_t>(x.num_nodes_);
  detail::SortedIndexSet set(bits_, count);
  for (const Index t : marked) {
    if (edges) {
      for (const Index e : x.tet_edges_[t]) set.insert(e);
    } else {
      for (const Index v : x.tets_[t]) set.insert(v);
    }
  }
  features_.clear();
  set.drain(features_);
}

namespace {

/// Per-thread visit marks over the candidate tets of Y (by slot): a tet reached again
/// through another tet of X around the same node or edge is skipped. Only used for dedup, so
/// the output does not depend on which thread ran what.
struct VisitMarks {
  std::vector<std::uint64_t> mark;
  std::uint64_t now = 0;
  // intruding_edges, one edge at a time, reused: the tets whose box the edge meets (their
  // geometry slot is target.tet - geom) and their clips.
  std::vector<ClipTarget> clip_targets;
  std::vector<SegmentClip> clips;
  std::vector<detail::EdgeHit> hits;
};
thread_local VisitMarks t_marks;

/// The box [slo, shi] meets [lo - tol, hi + tol]: Eigen's (slo <= hi + tol).all() && (shi
/// >= lo - tol).all(), the same six comparisons of the same sums, combined with & and not
/// && (the scans test thousands of boxes a frame, and a chain of six branches that go either
/// way mispredicts more than the comparisons cost).
inline bool meets_padded_box(const Eigen::Vector3d& slo, const Eigen::Vector3d& shi,
                             const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double tol) {
  // As 0/1 integers: & of bools reads as a typo for && to clang (-Wbitwise-instead-of-logical).
  const auto bit = [](bool b) { return static_cast<unsigned>(b); };
  return (bit(slo.x() <= hi.x() + tol) & bit(slo.y() <= hi.y() + tol) &
          bit(slo.z() <= hi.z() + tol) & bit(shi.x() >= lo.x() - tol) &
          bit(shi.y() >= lo.y() - tol) & bit(shi.z() >= lo.z() - tol)) != 0;
}

}  // namespace

void Detector::intruding_nodes(const CollisionBody& x, std::span<const Index> marked,
                               const Rows& rows, const CollisionBody& y, const Geometry& gy,
                               int gy_side, std::vector<IntrudingNode>& out) {
  collect_features(marked, x, false);
  const Positions& px = *x.positions_;
  const double rel = relative_tolerance();
  // The tests below accept p only inside a tet's box padded by rel * its scale, which
  // lies inside this one (IEEE rounding is monotonic): a node outside it (most nodes of
  // the marked tets, on the far side of the contact) skips its rows.
  const double reach_tol = rel * gy.reach.scale;
  const Eigen::Array3d reach_lo = gy.reach.lo.array() - reach_tol;
  const Eigen::Array3d reach_hi = gy.reach.hi.array() + reach_tol;
  const std::size_t chunks = detail::num_chunks(features_.size(), kFeatureChunk);
  detail::reset_parts(node_parts_, chunks);
  detail::for_chunks(
      features_.size(), kFeatureChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
        VisitMarks& marks = t_marks;
        if (marks.mark.size() < gy.tets.size()) marks.mark.resize(gy.tets.size(), 0);
        GeometryOf geometry(thread_geometry_->local(geom_a_.tets.size(), geom_b_.tets.size()),
                            gy_side, geometry_stamp_, *y.positions_, y.tets_, gy.tets);
        for (std::size_t i = begin; i < end; ++i) {
          const Index node = features_[i];
          const Eigen::Vector3d p = px.col(node);
          if (!((p.array() >= reach_lo).all() && (p.array() <= reach_hi).all())) continue;
          // The first tet of Y (in tet order) containing the node, among the tets
          // overlapped by the marked tets around it. Rows repeat tets: a tet
          // already tested for this node (it did not contain it) or not before the
          // best found so far is skipped, so no need to sort them.
          // Slots follow tet order: the smallest slot is the first tet.
          Index best = std::numeric_limits<Index>::max();
          Eigen::Vector4d bary = Eigen::Vector4d::Zero();
          const std::uint64_t now = ++marks.now;
          for (const Index t : x.node_tets_.row(node)) {
            const Index r = row_of_[t];
            if (r < 0) continue;
            for (Index k = rows.offsets[r]; k < rows.offsets[r + 1]; ++k) {
              const Index slot = rows.items[k];
              if (slot >= best) break;  // rows are sorted
              // Not tested yet for this node, and p in its padded box: one branch for
              // both (each goes either way; the box of a repeat was just read, so it is
              // in the L1 cache).
              const bool fresh = marks.mark[slot] != now;
              marks.mark[slot] = now;
              const TetBox& box = gy.boxes[slot];
              const double tol = rel * box.scale;
              const bool in_box = meets_padded_box(p, p, box.lo, box.hi, tol);
              if ((static_cast<unsigned>(fresh) & static_cast<unsigned>(in_box)) == 0) continue;
              const PointInTet hit = point_in_tet(p, geometry(slot), tol);
              if (hit.inside) {
                best = slot;
                bary = hit.bary;
                break;
              }
            }
          }
          if (best != std::numeric_limits<Index>::max())
            node_parts_[c].push_back({node, gy.tets[best], bary});
        }
      });
  detail::concat_parts(node_parts_, chunks, out);
}

void Detector::intruding_edges(const CollisionBody& x, std::span<const Index> marked,
                               const Rows& rows, const CollisionBody& y, const Geometry& gy,
                               int gy_side, std::vector<IntrudingEdge>& out) {
  collect_features(marked, x, true);
  const Positions& px = *x.positions_;
  const double rel = relative_tolerance();
  const std::size_t chunks = detail::num_chunks(features_.size(), kFeatureChunk);
  detail::reset_parts(edge_parts_, chunks);
  detail::for_chunks(
      features_.size(), kFeatureChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
        VisitMarks& marks = t_marks;
        if (marks.mark.size() < gy.tets.size()) marks.mark.resize(gy.tets.size(), 0);
        std::vector<detail::EdgeHit>& hits = marks.hits;
        std::vector<IntrudingEdge>& part = edge_parts_[c];
        const Index* const row_of = row_of_.data();
        const Index* const offsets = rows.offsets.data();
        const Index* const items = rows.items.data();
        const TetBox* const boxes = gy.boxes.data();
        GeometryOf geometry(thread_geometry_->local(geom_a_.tets.size(), geom_b_.tets.size()),
                            gy_side, geometry_stamp_, *y.positions_, y.tets_, gy.tets);
        const TetGeometry* const geom = geometry.base();
        for (std::size_t i = begin; i < end; ++i) {
          const Index edge = features_[i];
          const Eigen::Vector3d p0 = px.col(x.edges_[edge][0]);
          const Eigen::Vector3d p1 = px.col(x.edges_[edge][1]);
          const Eigen::Vector3d lo = p0.cwiseMin(p1), hi = p0.cwiseMax(p1);
          const double length = (p1 - p0).norm();
          {
            // As for the nodes: every box test below passes only inside this one.
            const double tol = rel * std::max(gy.reach.scale, length);
            if (!meets_padded_box(lo, hi, gy.reach.lo, gy.reach.hi, tol)) continue;
          }
          const std::uint64_t now = ++marks.now;
          // Local pointers: a vector's growth is a call, after which the compiler would
          // otherwise reload the marks and rows through the thread-local on every visit.
          std::uint64_t* const mark = marks.mark.data();
          marks.clip_targets.clear();
          // Every tet of Y overlapped by a marked tet of X around the edge, once (an edge has
          // ~15 such visits here for ~9 distinct tets, ~5.5 clipped, ~1.8 hit).
          for (const Index t : x.edge_tets_.row(edge)) {
            const Index r = row_of[t];
            if (r < 0) continue;
            for (const Index *k = items + offsets[r], *kend = items + offsets[r + 1]; k != kend;
                 ++k) {
              const Index slot = *k;
              if (mark[slot] == now) continue;
              mark[slot] = now;
              const TetBox& box = boxes[slot];
              const double tol = rel * std::max(box.scale, length);
              if (!meets_padded_box(lo, hi, box.lo, box.hi, tol)) continue;
              marks.clip_targets.push_back({&geometry(slot), tol});
            }
          }
          const std::size_t n = marks.clip_targets.size();
          if (n == 0) continue;
          if (marks.clips.size() < n) marks.clips.resize(n);
          clip_segment_tets(p0, p1, marks.clip_targets, marks.clips);
          hits.clear();
          for (std::size_t j = 0; j < n; ++j) {
            const SegmentClip& clip = marks.clips[j];
            const ClipTarget& target = marks.clip_targets[j];
            if (clip.hit)
              hits.push_back({{edge, gy.tets[target.tet - geom], clip.lambda_in, clip.lambda_out},
                              target.tolerance / length});
          }
          if (hits.empty()) continue;
          if (hits.size() > 1)
            std::sort(hits.begin(), hits.end(),
                      [](const detail::EdgeHit& u, const detail::EdgeHit& v) {
                        return u.edge.tet < v.edge.tet;
                      });
          detail::append_edge_hits(hits, part);
        }
      });
  detail::concat_parts(edge_parts_, chunks, out);
}

// ---------------------------------------------------------------------------- one-offs

PairContacts detect_pair(const Positions& positions_a, std::span<const Tet> tets_a,
                         const Topology& topology_a, const Positions& positions_b,
                         std::span<const Tet> tets_b, const Topology& topology_b,
                         const DetectOptions& options, DetectStats* stats) {
  CollisionBody a(tets_a, topology_a);
  CollisionBody b(tets_b, topology_b);
  a.set_positions(positions_a);
  b.set_positions(positions_b);
  Detector detector(options);
  PairContacts out;
  detector.detect(a, b, out, stats);
  return out;
}

std::vector<std::pair<Index, Index>> touching_object_pairs(
    std::span<const Aabb> boxes, const std::function<bool(Index, Index)>& enabled) {
  std::vector<std::pair<Index, Index>> pairs;
  const Index k = static_cast<Index>(boxes.size());
  for (Index i = 0; i < k; ++i)
    for (Index j = i + 1; j < k; ++j)
      if (boxes[i].overlaps(boxes[j]) && (!enabled || enabled(i, j))) pairs.emplace_back(i, j);
  return pairs;
}

}  // namespace tc
