// CollisionBody (detect.hpp): one object's topology tables, built once, and per frame its
// object box, spatial clusters and group boxes (tets_near()), tet bounds and AABB tree.
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/common/chunked.hpp"
#include "core/common/cpu_dispatch.hpp"
#include "core/common/target_clones.hpp"
#include "core/detect/detect.hpp"
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

constexpr std::size_t kParallelSortMin = 16384;

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
Csr invert(std::span<const std::array<Index, K>> owned, Index num_items) {
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
    : tets_(tets), num_nodes_(topology.num_nodes), edges_(topology.edges) {
  if (topology.num_tets != static_cast<Index>(tets.size()))
    throw std::invalid_argument("CollisionBody: topology has " + std::to_string(topology.num_tets) +
                                " tets, mesh has " + std::to_string(tets.size()));
  for (std::size_t t = 0; t < tets_.size(); ++t)
    for (const Index v : tets_[t])
      if (v < 0 || v >= num_nodes_)
        throw std::invalid_argument("CollisionBody: tet " + std::to_string(t) + " uses node " +
                                    std::to_string(v) + " outside [0, " +
                                    std::to_string(num_nodes_) + ")");
  if (topology.node_tets.rows() == num_nodes_) {
    topology_node_tets_ = &topology.node_tets;
  } else {
    owned_node_tets_ = invert(tets_, num_nodes_);
  }
  for (const auto& e : edges_)
    if (e[0] < 0 || e[0] >= num_nodes_)
      throw std::invalid_argument("CollisionBody: topology edge node " + std::to_string(e[0]) +
                                  " outside [0, " + std::to_string(num_nodes_) + ")");
  // Every edge of every tet must be in the topology: checked now, the tables made on the
  // first edge scan (prepare_edges()).
  std::vector<std::array<Index, 6>> tet_edges;
  if (const std::optional<std::size_t> missing = find_tet_edges(tet_edges)) {
    const std::size_t t = *missing / 6;
    const int k = static_cast<int>(*missing % 6);
    Index u = tets_[t][kTetEdges[k][0]];
    Index v = tets_[t][kTetEdges[k][1]];
    if (u > v) std::swap(u, v);
    throw std::invalid_argument("CollisionBody: edge (" + std::to_string(u) + ", " +
                                std::to_string(v) + ") of tet " + std::to_string(t) +
                                " is not in the topology");
  }
}

std::optional<std::size_t> CollisionBody::find_tet_edges(
    std::vector<std::array<Index, 6>>& tet_edges) const {
  // Edge ids by a binary search within the edges of the smaller node (the edges are
  // sorted, so each node's edges (u, *) are contiguous).
  std::vector<Index> edge_begin(static_cast<std::size_t>(num_nodes_) + 1, 0);
  for (const auto& e : edges_) ++edge_begin[static_cast<std::size_t>(e[0]) + 1];
  for (std::size_t i = 0; i + 1 < edge_begin.size(); ++i) edge_begin[i + 1] += edge_begin[i];
  tet_edges.resize(tets_.size());
  detail::for_chunks(tets_.size(), 8192, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t t = begin; t < end; ++t)
      for (int k = 0; k < 6; ++k) {
        Index u = tets_[t][kTetEdges[k][0]], v = tets_[t][kTetEdges[k][1]];
        if (u > v) std::swap(u, v);
        const auto first = edges_.begin() + edge_begin[u];
        const auto last = edges_.begin() + edge_begin[u + 1];
        const std::array<Index, 2> key{u, v};
        const auto it = std::lower_bound(first, last, key);
        tet_edges[t][k] = it == last || *it != key ? -1 : static_cast<Index>(it - edges_.begin());
      }
  });
  for (std::size_t t = 0; t < tets_.size(); ++t)
    for (std::size_t k = 0; k < 6; ++k)
      if (tet_edges[t][k] < 0) return 6 * t + k;
  return std::nullopt;
}

void CollisionBody::prepare_edges() {
  if (edges_ready_) return;
  (void)find_tet_edges(tet_edges_);  // the constructor found every edge
  edge_tets_ =
      invert(std::span<const std::array<Index, 6>>(tet_edges_), static_cast<Index>(edges_.size()));
  edges_ready_ = true;
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

}  // namespace tc
