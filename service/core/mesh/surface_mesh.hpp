// Triangle surfaces in 3D (paper Fig. 14): instruments from STL files, shells, cloth.
// A surface object has nodes and triangles and no tets; its vertices and edges are what
// detection tests against the tets of a tetrahedral object. Not to be confused with
// TriMesh2 (core/mesh/mesh2d.hpp), the planar triangle mesh of the 2D depth maps.
//
// Validation follows core/mesh/validate.hpp: defects are found, counted, listed by
// index, never fixed; require_valid_surface() turns a report into an error that names
// the object, the defect and the first indices.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "core/common/result.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/validate.hpp"

namespace tc {

/// Node indices of one triangle, 0-based into SurfaceMesh::positions. The right-hand
/// normal (x1 - x0) x (x2 - x0) is the triangle's front; nothing requires a consistent
/// orientation (open shells have no inside), surface_stats() reports whether it is.
using Triangle = std::array<Index, 3>;

/// A triangle surface in 3D, closed or open, as read from a file.
struct SurfaceMesh {
  /// n node ids as in the file (Gmsh node tags; 1..n for STL and OBJ, in order of first
  /// appearance / of the `v` lines). Used for output only.
  std::vector<std::int64_t> node_ids;
  /// n node positions (3 x n), metres.
  Positions positions;
  /// k triangles, 0-based indices into positions.
  std::vector<Triangle> triangles;

  [[nodiscard]] Index num_nodes() const { return static_cast<Index>(positions.cols()); }
  [[nodiscard]] Index num_triangles() const { return static_cast<Index>(triangles.size()); }
};

/// What an object is made of: tets, or a triangle surface.
using ObjectMesh = std::variant<TetMesh, SurfaceMesh>;

/// Scale-free shape quality of a triangle, 4 sqrt(3) A / (l01^2 + l12^2 + l20^2): 1 for
/// the equilateral triangle, 0 for a collinear one (and when every edge has length 0).
/// Never negative: a triangle has no orientation to be inverted against.
double triangle_quality(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                        const Eigen::Vector3d& x2);

struct SurfaceValidationOptions {
  /// Quality (triangle_quality()) below this is a degenerate, zero-area triangle: the
  /// tolerance is relative to the triangle's own size, as for tets (ValidationOptions).
  double degenerate_quality = 1e-6;
  /// Counts above these are oversized (kOversized). Defaults: the daemon's default
  /// limits.max_nodes and limits.max_tets (the IDL bounds of a tet topology).
  std::int64_t max_nodes = 1'000'000;
  std::int64_t max_triangles = 6'000'000;
  /// How many offending indices each list keeps.
  std::size_t max_listed = 8;
};

struct SurfaceValidationReport {
  std::int64_t nodes = 0;       ///< count checked against max_nodes
  std::int64_t triangles = 0;   ///< count checked against max_triangles
  bool too_many_nodes = false;  ///< nodes > max_nodes (nothing else was checked)
  bool too_many_triangles = false;
  DefectList index_out_of_range;  ///< triangles with a node index outside [0, n)
  DefectList repeated_node;       ///< triangles using one node twice
  DefectList nonfinite_node;      ///< nodes with a NaN or infinite coordinate
  DefectList degenerate;          ///< triangles with quality < degenerate_quality
  double min_quality = 1.0;       ///< over the triangles with valid indices and coordinates

  [[nodiscard]] bool oversized() const { return too_many_nodes || too_many_triangles; }
  /// True when the surface cannot be used at all (oversized, bad indices, repeated nodes,
  /// NaN).
  [[nodiscard]] bool structurally_invalid() const {
    return oversized() || index_out_of_range.count + repeated_node.count + nonfinite_node.count > 0;
  }
  /// True when nothing is wrong (degenerate triangles are wrong).
  [[nodiscard]] bool clean() const { return !structurally_invalid() && degenerate.count == 0; }
  /// One clause per defect class found, e.g. "2 degenerate (zero-area) triangles (first:
  /// 5, 17)", or the oversize.
  [[nodiscard]] std::string summary() const;
};

/// Checks counts, indices, coordinates and triangle shapes. Never throws, never fixes.
/// When a count is over its limit nothing else is checked (the report says so).
SurfaceValidationReport validate_surface(const SurfaceMesh& mesh,
                                         const SurfaceValidationOptions& options = {});

/// The same checks on positions (3 x n, metres) and triangles (k, 0-based) held apart:
/// a frame's new positions against the registered triangles.
SurfaceValidationReport validate_surface(const Positions& positions,
                                         std::span<const Triangle> triangles,
                                         const SurfaceValidationOptions& options = {});

/// Ok when the report is clean; else kOversized (counts) or kInvalidMesh (the defects),
/// the message prefixed with `what` (a file or object name).
Status require_valid_surface(const SurfaceValidationReport& report, const std::string& what);

/// Edges of a triangle surface, derived from its triangles alone (once per topology).
struct SurfaceEdges {
  /// Unique edges (a, b), a < b, sorted.
  std::vector<std::array<Index, 2>> edges;
  /// Per edge: how many triangles use it (1: boundary, 2: manifold, more: non-manifold).
  std::vector<Index> triangle_count;
  /// Per edge: how many of its triangles run it from edges[e][0] to edges[e][1]. On a
  /// consistently oriented manifold edge, one of its two triangles does.
  std::vector<Index> forward_count;
  /// Per triangle: the edge ids of (x0, x1), (x1, x2), (x2, x0).
  std::vector<std::array<Index, 3>> triangle_edges;
};

/// Builds the edges of k triangles.
/// @param[in] triangles  k triangles, indices in [0, n) without repeats (validate first)
SurfaceEdges build_surface_edges(std::span<const Triangle> triangles);

/// Summary numbers of a surface, as printed by `tetcollide mesh info`.
struct SurfaceStats {
  Index nodes = 0;  ///< all nodes, unused ones included
  Index triangles = 0;
  Index edges = 0;              ///< unique edges
  Index boundary_edges = 0;     ///< used by one triangle
  Index nonmanifold_edges = 0;  ///< used by three or more triangles
  Index unused_nodes = 0;       ///< in no triangle
  Index components = 0;         ///< edge-connected components of triangles
  /// Manifold edges whose two triangles run them the same way (orientation flips).
  Index misoriented_edges = 0;
  std::size_t degenerate_triangles = 0;
  /// No boundary and no non-manifold edge (and at least one triangle): a surface that
  /// encloses a volume.
  bool closed = false;
  /// Closed and every manifold edge consistently oriented: the enclosed volume is known.
  bool oriented = false;
  double area = 0.0;  ///< sum of triangle areas, m^2
  /// When `oriented`: the volume enclosed, m^3 (|sum of signed tet volumes to a point|);
  /// else 0.
  double enclosed_volume = 0.0;
  /// When `oriented`: true when the triangles' right-hand normals point outward.
  bool outward = false;
  Eigen::Vector3d bbox_lo = Eigen::Vector3d::Zero();  ///< of the used nodes, m
  Eigen::Vector3d bbox_hi = Eigen::Vector3d::Zero();
  double min_quality = 0.0;  ///< smallest triangle_quality()
};

/// Statistics of a surface whose indices are in range and coordinates finite
/// (!report.structurally_invalid()).
SurfaceStats compute_surface_stats(const SurfaceMesh& mesh, const SurfaceEdges& edges,
                                   const SurfaceValidationReport& report);

}  // namespace tc
