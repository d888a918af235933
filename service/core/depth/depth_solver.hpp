// Depth maps: the distance from every node of an object to the object's boundary,
// computed on the mesh itself (paper Section 4): CPFM, CFFM, the lazy variant, and the
// exact reference. docs/DEPTH_MAPS.md explains the algorithms and the choices made.
//
// Two ways to use it (STYLE habit 4):
//  - one-off free functions, e.g. compute_depth_cpfm(mesh, topo), for scripts and tests;
//  - DepthSolver, built once per topology, keeping its buffers across frames:
//      DepthSolver solver(mesh.tets, topo, {.method = DepthMethod::kCffm});
//      solver.compute(positions);                          // full depth map
//      auto settled = solver.compute_lazy(positions, marked_tets);  // paper 4.4
//      std::span<const double> d = solver.depth();         // n values, metres
//
// Units: positions and depths in metres (any consistent length unit works).
// Nodes used by no element ("orphans") get +infinity and are never settled; so do the
// nodes a lazy run stopped before. Output is never NaN.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/common/result.hpp"
#include "core/depth/boundary_surface.hpp"
#include "core/mesh/mesh2d.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"

namespace tc {

/// How the depth map of an object is computed (docs/DEPTH_MAPS.md): the paper's Closest
/// Point (kCpfm) or Closest Feature (kCffm) Fast Marching, or the exact distance to the
/// boundary (kExact, the reference).
enum class DepthMethod { kCpfm, kCffm, kExact };

/// How CFFM chooses the feature a node keeps (docs/DEPTH_MAPS.md, "CFFM variants", has
/// the measured error and cost of each).
enum class CffmVariant : std::uint8_t {
  /// The paper's rule: a boundary node offers its neighbours all its incident boundary
  /// triangles (segments in 2D); any other node offers the one feature it holds; a
  /// node keeps the offer at the smallest point-to-feature distance.
  kPaper,
  /// Default. A node offers its feature's closest point (an offer costs what a CPFM
  /// offer costs); a node being finalised walks the boundary surface from the feature
  /// it was offered to a local minimum of the distance (to the features around the
  /// closest point's vertex, or across the feature's sides).
  kDescent,
  /// kPaper's offers plus kDescent's walk.
  kPaperDescent,
  /// kDescent, plus walks from the feature of every settled neighbour, keeping the
  /// nearest: escapes the local minima of a faceted surface, about 10x kDescent's cost.
  kMultiStart,
  /// kMultiStart's extra walks, only from the neighbours' features whose distance is
  /// within 5% of the best so far: kMultiStart's accuracy on the measured meshes at
  /// about a third of its cost (still 2-3x kDescent's).
  kNearStarts,
};

/// Priority queue of the march (measured in docs/DEPTH_MAPS.md).
enum class QueueKind : std::uint8_t {
  kBucket,      ///< FIFO buckets of width bucket_width x first-layer distance (default)
  kRadix,       ///< radix heap on float keys: exact Dijkstra order
  kBinaryHeap,  ///< std::push_heap / pop_heap: exact Dijkstra order, the textbook choice
};

/// Where a lazy run (compute_lazy) marches.
enum class LazyRegion : std::uint8_t {
  /// Default: a region around the marked elements' nodes, seeded by the boundary nodes
  /// in it (docs/DEPTH_MAPS.md, "Local lazy runs"). Its cost follows the contact, not
  /// the object. Every depth is still the distance to a boundary node (CPFM) or point
  /// on a boundary feature (CFFM), so never below the exact depth, and the region holds
  /// every boundary node nearer to a marked node than the depth it got; the values may
  /// differ from a whole run's where the march's paths would have left the region.
  kLocal,
  /// The paper's 4.4: the whole boundary seeds the march, which stops when the marked
  /// nodes are settled; the settled values are bit-identical to compute()'s.
  kWholeBoundary,
};

/// What the last compute_lazy() did (LazyRegion::kLocal).
struct LazyStats {
  int rounds = 0;                ///< regions marched (each larger than the one before)
  std::size_t region_nodes = 0;  ///< nodes in the last region (all used nodes if whole)
  double cell_side = 0.0;        ///< the last region's cell side, metres
  bool whole = false;            ///< the last round marched the whole object
};

struct DepthSolverOptions {
  DepthMethod method = DepthMethod::kCpfm;  ///< kCpfm, kCffm or kExact
  CffmVariant cffm = CffmVariant::kDescent;
  QueueKind queue = QueueKind::kBucket;
  /// kBucket only: bucket width as a fraction of the mean distance of the nodes next
  /// to the boundary (about one edge length).
  float bucket_width = 0.25f;
  LazyRegion lazy_region = LazyRegion::kLocal;  ///< compute_lazy() only
};

/// Topology type of a D-dimensional mesh: Topology (tets) or Topology2 (triangles).
template <int D>
using TopologyOf = std::conditional_t<D == 3, Topology, Topology2>;

/// Depth-map solver for one topology of a D-dimensional mesh (D = 3: tets; D = 2: the
/// paper's triangle meshes). Construction does all topology work; compute() and
/// compute_lazy() touch positions only and reuse the solver's buffers. Not thread-safe:
/// use one solver per object (solvers of different objects may run concurrently).
template <int D>
class BasicDepthSolver {
 public:
  using Element = std::array<Index, D + 1>;
  using Points = Eigen::Matrix<double, D, Eigen::Dynamic>;

  /// @param[in] elements  m elements (tets or triangles), 0-based node indices in [0, n).
  /// @param[in] topo      the topology built from the same elements (n = topo.num_nodes).
  /// @param[in] options   method, CFFM variant, queue.
  BasicDepthSolver(std::span<const Element> elements, const TopologyOf<D>& topo,
                   DepthSolverOptions options = {});
  ~BasicDepthSolver();
  BasicDepthSolver(BasicDepthSolver&&) noexcept;
  BasicDepthSolver& operator=(BasicDepthSolver&&) noexcept;
  BasicDepthSolver(const BasicDepthSolver&) = delete;
  BasicDepthSolver& operator=(const BasicDepthSolver&) = delete;

  /// Full depth map: every node used by an element gets its depth and is settled.
  ///
  /// @param[in] positions  D x n node positions, metres.
  /// @return kInvalidArgument when positions has the wrong size or a used node has a
  ///         non-finite coordinate (the message names the node); depth() is then all
  ///         +infinity.
  Status compute(const Points& positions);

  /// Lazy depth map (paper 4.4): marches only until every node of every marked element
  /// is settled; other nodes read +infinity. LazyRegion::kLocal (default) marches in a
  /// region around the marked nodes and reads only the positions of that region (and of
  /// the boundary features a CFFM walk visits); kWholeBoundary seeds from the whole
  /// boundary and its settled values are bit-identical to compute()'s. For kExact, only
  /// the marked elements' nodes are computed.
  ///
  /// @param[in] positions     D x n node positions, metres.
  /// @param[in] marked        element indices (0-based, file order; any order, repeats
  ///                          allowed), e.g. the tets detection found overlapping.
  /// @return the number of settled nodes, or kInvalidArgument (bad size, element index
  ///         out of range, non-finite coordinate of a node the run reads; the message
  ///         names it). A local run checks only the coordinates it reads: validate the
  ///         positions first where every node must be finite (the pipeline does).
  Expected<std::size_t> compute_lazy(const Points& positions, std::span<const Index> marked);

  /// n depths (metres) from the last compute: >= 0 for settled nodes, +infinity else.
  [[nodiscard]] std::span<const double> depth() const;
  /// n anchors from the last compute: for a settled node, a boundary node at the feature
  /// its depth was measured to (CPFM: the closest boundary node found; CFFM and exact:
  /// the corner of the closest boundary triangle, segment in 2D, nearest the node; a
  /// boundary node: itself); -1 for nodes not settled. The response measures the depth
  /// of a point inside a tet against the boundary faces around its four nodes' anchors
  /// (docs/RESPONSE.md, "Nearest-face depth").
  [[nodiscard]] std::span<const Index> anchor() const;
  /// True when node i got its final value in the last compute.
  [[nodiscard]] bool settled(Index i) const;
  /// Number of settled nodes in the last compute.
  [[nodiscard]] std::size_t settled_count() const;
  /// n.
  [[nodiscard]] Index num_nodes() const;
  [[nodiscard]] const DepthSolverOptions& options() const;
  /// What the last compute_lazy() did: rounds, region size.
  [[nodiscard]] const LazyStats& lazy_stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

extern template class BasicDepthSolver<2>;
extern template class BasicDepthSolver<3>;

/// The solver for tetrahedral meshes.
using DepthSolver = BasicDepthSolver<3>;
/// The solver for the paper's 2D triangle meshes.
using DepthSolver2 = BasicDepthSolver<2>;

// One-off functions: n depths (metres, +infinity for orphan nodes) of a mesh with
// indices in range, `topo` built from it; an error (kInvalidArgument) names the first
// node with a non-finite coordinate.

/// Closest Point Fast Marching (paper 4.2, "CPFM").
Expected<std::vector<double>> compute_depth_cpfm(const TetMesh& mesh, const Topology& topo);
/// Closest Feature Fast Marching ("CFFM"), with the given variant.
Expected<std::vector<double>> compute_depth_cffm(const TetMesh& mesh, const Topology& topo,
                                                 CffmVariant variant = CffmVariant::kDescent);
/// Exact distance to the boundary surface (BVH over the boundary triangles, TBB over
/// nodes). For reports and tests.
Expected<std::vector<double>> compute_depth_exact(const TetMesh& mesh, const Topology& topo);

/// 2D counterparts on a triangle mesh (the paper's Fig. 9 and 10).
Expected<std::vector<double>> compute_depth_cpfm(const TriMesh2& mesh, const Topology2& topo);
Expected<std::vector<double>> compute_depth_cffm(const TriMesh2& mesh, const Topology2& topo,
                                                 CffmVariant variant = CffmVariant::kDescent);
Expected<std::vector<double>> compute_depth_exact(const TriMesh2& mesh, const Topology2& topo);

/// Short name of a method ("cpfm", "cffm", "exact").
const char* depth_method_name(DepthMethod method);
/// The method of a short name (depth_method_name's inverse); nullopt for any other text.
std::optional<DepthMethod> parse_depth_method(std::string_view name);

}  // namespace tc
