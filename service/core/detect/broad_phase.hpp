// Broad phase: which tet pairs of two objects are worth the exact test.
//
// Four interchangeable methods, selected by name (docs/DETECTION.md compares them):
//   grid  the paper's: a uniform voxel grid of tet bounding spheres, cell size = mean
//         sphere diameter, over the overlap box of the two objects
//   hash  spatial hashing of tet boxes (Teschner et al. 2003): unbounded grid, cell size
//         = mean tet box extent, cells hashed into a table
//   sap   sweep and prune of tet boxes on one axis (the axis of largest spread)
//   bvh   AABB tree over the tets of B, built once per topology and refitted per frame
// Every method returns the same list: candidate pairs (a, b), sorted by (a, b), without
// duplicates, whose closed boxes overlap (grid: and whose spheres overlap). A pair of
// tets that overlap by more than 0 is always a candidate.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "core/common/chunk_buffer.hpp"
#include "core/detect/contacts.hpp"
#include "core/detect/tet_overlap.hpp"
#include "core/mesh/tet_mesh.hpp"

namespace tc {

enum class BroadPhaseKind { kGrid, kHash, kSap, kBvh };

/// Public name of a method: "grid", "hash", "sap", "bvh".
std::string_view broad_phase_name(BroadPhaseKind kind);
/// The method called `name`, or nothing.
std::optional<BroadPhaseKind> parse_broad_phase(std::string_view name);

/// Axis-aligned box, metres. Empty when lo > hi on some axis (e.g. the box of a tet with
/// a non-finite corner): an empty box overlaps nothing.
struct Aabb {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());

  [[nodiscard]] bool empty() const { return !(lo.array() <= hi.array()).all(); }
  /// Closed overlap test (touching boxes overlap): the intersection is not empty. False
  /// when either box is empty.
  [[nodiscard]] bool overlaps(const Aabb& o) const {
    // max(lo) <= min(hi) on each axis, written out: the broad phase runs it millions of
    // times a second and the compiler does not always inline Eigen's .all() there.
    return std::max(lo.x(), o.lo.x()) <= std::min(hi.x(), o.hi.x()) &&
           std::max(lo.y(), o.lo.y()) <= std::min(hi.y(), o.hi.y()) &&
           std::max(lo.z(), o.lo.z()) <= std::min(hi.z(), o.hi.z());
  }
  /// Each bound of `o` lies within this box's (closed test); meant for a non-empty `o`.
  [[nodiscard]] bool contains(const Aabb& o) const {
    return lo.x() <= o.lo.x() && lo.y() <= o.lo.y() && lo.z() <= o.lo.z() && o.hi.x() <= hi.x() &&
           o.hi.y() <= hi.y() && o.hi.z() <= hi.z();
  }
  void extend(const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void extend(const Aabb& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  [[nodiscard]] Aabb intersection(const Aabb& o) const {
    return {lo.cwiseMax(o.lo), hi.cwiseMin(o.hi)};
  }
};

/// Bounding sphere of a tet: centre at the centroid, radius to the farthest corner.
struct BoundingSphere {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double radius = -1.0;  ///< < 0 for a tet with a non-finite corner
};

/// Per-frame bounds of every tet of one object.
struct TetBounds {
  std::vector<Aabb> boxes;              ///< m boxes (empty for non-finite tets)
  std::vector<BoundingSphere> spheres;  ///< m spheres (empty when not computed)

  /// Recomputes the boxes, and the spheres when `spheres` is set (TBB over tets).
  /// @param[in] positions  3 x n node positions, metres.
  /// @param[in] tets       m tets, indices in [0, n).
  void compute(const Positions& positions, std::span<const Tet> tets, bool spheres = true);
  /// The same for the tets listed in `which` only (indices into `tets`); the arrays are
  /// sized for every tet and the other entries are left as they were.
  void compute(const Positions& positions, std::span<const Tet> tets, std::span<const Index> which,
               bool spheres);
};

/// AABB tree over the tets of one object: the shape is built once per topology (median
/// splits of the tet centroids of the positions given to build()), then only the boxes
/// are refitted each frame. Leaves hold up to 4 tets.
class AabbTree {
 public:
  /// Builds the tree over `boxes` (m boxes; empty ones are kept and never found).
  void build(std::span<const Aabb> boxes);
  /// Recomputes every node box bottom-up from new tet boxes (same m). TBB over subtrees.
  void refit(std::span<const Aabb> boxes);
  /// Appends to `out` the tets whose box overlaps `box` (closed test), in tree order.
  void query(const Aabb& box, std::span<const Aabb> boxes, std::vector<Index>& out) const;

  [[nodiscard]] std::size_t num_items() const { return items_.size(); }
  [[nodiscard]] bool built() const { return !nodes_.empty() || items_.empty(); }
  [[nodiscard]] const Aabb& root_box() const { return nodes_.front().box; }

 private:
  struct Node {
    Aabb box;
    Index first = 0;   ///< leaf: first item; inner: unused
    Index count = 0;   ///< leaf: item count (> 0); inner: 0
    Index right = -1;  ///< inner: right child (the left child is the next node)
  };
  /// Nodes of a tree over `items` items.
  static Index nodes_for(std::size_t items);
  void build_node(std::span<Index> items, std::span<const Eigen::Vector3d> centers, Index first,
                  Index node);
  void refit_node(Index node, std::span<const Aabb> boxes, int depth);

  std::vector<Node> nodes_;   ///< pre-order
  std::vector<Index> items_;  ///< tet indices, leaf ranges are contiguous
};

/// Bounding box of the part of tet `t` inside `region`: exact for the slab of `region`
/// along `axis` (the tet's corners in the slab and its edges' crossings of the two slab
/// planes), then intersected with `region` and padded by `pad` (metres) on every side.
/// Empty when the tet misses the slab. Where two objects barely touch, their overlap
/// box is a thin slab and these boxes are far smaller than the tets' own.
Aabb clipped_tet_box(const TetCorners& t, const Aabb& region, int axis, double pad);

/// out[j] = clipped_tet_box(t[j], region, axis, pad[j]) for 4 tets at once (one per vector
/// lane): the same bits, for about a third of the instructions.
void clipped_tet_boxes4(const std::array<TetCorners, 4>& t, const Aabb& region, int axis,
                        const std::array<double, 4>& pad, std::array<Aabb, 4>& out);

/// One object's side of a broad-phase query.
struct BroadPhaseSide {
  /// The tets to consider, sorted.
  std::span<const Index> tets;
  /// One box per entry of `tets`, inside that tet's own bounding box: where the tet can
  /// meet the other object (detection passes clipped_tet_box() of the overlap box).
  std::span<const Aabb> boxes;
  /// kGrid only: bounding spheres indexed by tet (every tet of the object).
  std::span<const BoundingSphere> spheres;
};

/// kBvh only: object B's tree and how its tets map to B's side.
struct BvhSide {
  const AabbTree* tree = nullptr;   ///< tree over every tet of B, or over side b
  std::span<const Aabb> tet_boxes;  ///< per tet of B: the boxes the tree was refitted to
  std::span<const Index> slot;      ///< per tet of B: its index in side b, or -1
  /// Set when the tree was built over side b itself (items are indices into b.tets and
  /// tet_boxes is b.boxes); then `slot` is not used.
  bool over_side = false;
};

/// Finds candidate tet pairs between two objects, keeping its buffers across calls. One
/// instance per thread; the calls themselves run TBB loops.
class BroadPhase {
 public:
  /// Candidate pairs (a.tets[i], b.tets[j]) whose boxes a.boxes[i] and b.boxes[j]
  /// overlap (closed test; kGrid: and whose bounding spheres overlap). Sorted by (a, b),
  /// no duplicates, the same set for every method (kGrid: a subset of it).
  ///
  /// @param[in] kind  method
  /// @param[in] a, b  the two sides (this frame's boxes, metres)
  /// @param[in] bvh   B's tree; required for kBvh, else ignored
  /// @param[out] out  the candidate pairs (cleared first)
  void find_pairs(BroadPhaseKind kind, const BroadPhaseSide& a, const BroadPhaseSide& b,
                  const BvhSide& bvh, std::vector<TetPair>& out);

 private:
  void grid_pairs(const BroadPhaseSide& a, const BroadPhaseSide& b);
  void hash_pairs(const BroadPhaseSide& a, const BroadPhaseSide& b);
  void sap_pairs(const BroadPhaseSide& a, const BroadPhaseSide& b);
  void bvh_pairs(const BroadPhaseSide& a, const BroadPhaseSide& b, const BvhSide& bvh);

  // Buffers kept across calls.
  detail::ChunkBuffers<TetPair> parts_;               ///< per fixed chunk of side a
  std::vector<Index> cell_start_;                     ///< grid/hash: CSR offsets per cell
  std::vector<Index> cell_items_;                     ///< grid: index in b; hash: entry
  std::vector<std::array<std::int32_t, 4>> entries_;  ///< hash: (index in b, ix, iy, iz)
  std::vector<std::array<std::int32_t, 3>> low_b_;    ///< grid/hash: first cell per b
  std::vector<std::pair<double, Index>> sorted_b_;    ///< sap: (min on axis, index in b)
};

}  // namespace tc
