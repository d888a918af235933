// Broad phase: which tet pairs of two objects are worth the exact test.
//
// Four interchangeable methods, selected by name (docs/DETECTION.md compares them):
//   grid  the paper's: a uniform voxel grid of tet bounding spheres, cell size = mean
//         sphere diameter, over the overlap box of the two objects
//   hash  spatial hashing of tet boxes (Teschner et al. 2003): unbounded grid, cell size
//         = mean tet box extent, cells hashed into a table
//   sap   sweep and prune of tet boxes on one axis (the axis of largest spread)
//   bvh   AABB tree over the tets of B, built once per topology and refitted per frame
// Every method returns the same kind of list: candidate pairs (a, b), sorted by (a, b),
// without duplicates, whose closed boxes overlap (grid: and whose spheres overlap). A
// pair of tets that overlap by more than 0 is always a candidate.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "core/detect/contacts.hpp"
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
    return (lo.cwiseMax(o.lo).array() <= hi.cwiseMin(o.hi).array()).all();
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
  Index build_node(std::span<Index> items, std::span<const Eigen::Vector3d> centers, Index first);
  void refit_node(Index node, std::span<const Aabb> boxes, int depth);

  std::vector<Node> nodes_;   ///< pre-order
  std::vector<Index> items_;  ///< tet indices, leaf ranges are contiguous
};

/// Finds candidate tet pairs between two objects, keeping its buffers across calls. One
/// instance per thread; the calls themselves run TBB loops.
class BroadPhase {
 public:
  /// Candidate pairs (a, b) with a in `subset_a` and b in `subset_b` whose boxes overlap
  /// inside `clip` (kGrid: whose bounding spheres overlap too). Sorted by (a, b), no
  /// duplicates. With `clip` = the intersection of the two object boxes this is every
  /// pair of overlapping boxes (two boxes of the objects overlap only inside it), and
  /// the spatial structures only see the clipped boxes, which are much smaller where
  /// the objects barely touch.
  ///
  /// @param[in] kind      method
  /// @param[in] a, b      per-tet bounds of the two objects (this frame; kGrid: spheres)
  /// @param[in] subset_a  tets of A to consider, sorted (e.g. those in the overlap box)
  /// @param[in] subset_b  tets of B to consider, sorted (kBvh: ignored, `tree_b` is used)
  /// @param[in] tree_b    the refitted tree of B; required for kBvh, else unused
  /// @param[in] clip      the region pairs must overlap in (metres)
  /// @param[out] out      the candidate pairs (cleared first)
  void find_pairs(BroadPhaseKind kind, const TetBounds& a, std::span<const Index> subset_a,
                  const TetBounds& b, std::span<const Index> subset_b, const AabbTree* tree_b,
                  const Aabb& clip, std::vector<TetPair>& out);

 private:
  void grid_pairs(const TetBounds& a, std::span<const Index> subset_a, const TetBounds& b,
                  std::span<const Index> subset_b, const Aabb& clip);
  void hash_pairs(const TetBounds& a, std::span<const Index> subset_a, const TetBounds& b,
                  std::span<const Index> subset_b, const Aabb& clip);
  void sap_pairs(const TetBounds& a, std::span<const Index> subset_a, const TetBounds& b,
                 std::span<const Index> subset_b, const Aabb& clip);
  void bvh_pairs(const TetBounds& a, std::span<const Index> subset_a, const TetBounds& b,
                 const AabbTree& tree_b, const Aabb& clip);

  // Buffers kept across calls.
  std::vector<std::vector<TetPair>> parts_;           ///< per fixed chunk of subset_a
  std::vector<Index> cell_start_;                     ///< grid/hash: CSR offsets per cell/bucket
  std::vector<Index> cell_items_;                     ///< grid: tet of B; hash: entry index
  std::vector<std::array<std::int32_t, 4>> entries_;  ///< hash: (tet, ix, iy, iz)
  std::vector<std::array<std::int32_t, 3>> low_b_;    ///< grid/hash: first cell of each tet of B
  std::vector<std::pair<double, Index>> sorted_b_;    ///< sap: (min on axis, tet of B)
};

}  // namespace tc
