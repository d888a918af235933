// Mesh validation: what is wrong, how often, and where first.
#pragma once

#include <iosfwd>
#include <span>
#include <string>
#include <vector>

#include "core/common/result.hpp"
#include "core/mesh/tet_mesh.hpp"

namespace tc {

struct ValidationOptions {
  /// |quality| below this is a zero-volume (degenerate) tet. Quality is the scale-free
  /// 6*sqrt(2)*V / l_rms^3 of tet_quality(): 1 for a regular tet, so the tolerance is
  /// relative to the tet's own size and holds at any scale or offset.
  double degenerate_quality = 1e-6;
  /// Quality in [degenerate_quality, sliver_quality) is a sliver: valid, but flagged.
  double sliver_quality = 1e-2;
  /// How many offending indices each list keeps.
  std::size_t max_listed = 8;
  /// false: ValidationReport::min_quality is not computed (it is NaN), and the tets that
  /// are surely not slivers skip the square root and the division of tet_quality(). The
  /// defect lists are the same either way. The per-frame check of the pipeline sets it.
  bool compute_min_quality = true;
};

/// One class of defect: how many, and the first few indices (tets or nodes).
struct DefectList {
  std::size_t count = 0;
  std::vector<Index> first;
  void add(Index i, std::size_t max_listed) {
    if (first.size() < max_listed) first.push_back(i);
    ++count;
  }
};

/// Appends "N what (first: i, j)" to `out`, after "; " when `out` is not empty; nothing
/// for an empty list. The one line format of every validation summary.
void append_defects(std::ostringstream& out, const DefectList& list, const char* what);

struct ValidationReport {
  DefectList index_out_of_range;  ///< tets with a node index outside [0, n)
  DefectList repeated_node;       ///< tets using one node twice
  DefectList nonfinite_node;      ///< nodes with a NaN or infinite coordinate
  DefectList degenerate;          ///< tets with |quality| < degenerate_quality, or not
                                  ///< finite (edges beyond ~6e102 m or below ~3e-109 m)
  DefectList inverted;            ///< tets with quality <= -degenerate_quality
  DefectList sliver;              ///< tets with quality in [degenerate, sliver)
  /// Over the tets with valid indices and coordinates; NaN when
  /// ValidationOptions::compute_min_quality is false.
  double min_quality = 1.0;

  /// True when the mesh cannot be used at all (bad indices, repeated nodes, NaN).
  [[nodiscard]] bool structurally_invalid() const {
    return index_out_of_range.count + repeated_node.count + nonfinite_node.count > 0;
  }
  /// True when nothing but slivers was found.
  [[nodiscard]] bool clean() const {
    return !structurally_invalid() && degenerate.count == 0 && inverted.count == 0;
  }
  /// One line per defect class found, e.g. "2 inverted tets (first: 5, 17)".
  [[nodiscard]] std::string summary() const;
};

/// Checks indices, coordinates and tet shapes. Never throws, never flips a tet.
ValidationReport validate_mesh(const TetMesh& mesh, const ValidationOptions& options = {});

/// Checks only what the positions decide (finite coordinates, degenerate and inverted
/// tets) for a mesh whose indices are known good: the per-frame check.
ValidationReport validate_positions(const Positions& positions, const std::vector<Tet>& tets,
                                    const ValidationOptions& options = {});

/// A mesh's tets stored in a spatial order for the per-frame check: tets[k] is the mesh's
/// tet index[k]. A mesher's element order can scatter each tet's nodes over the whole node
/// array (a 300k-tet Gmsh pawn: over half of it); along a Morton curve consecutive tets
/// share nodes and the positions are read with far fewer cache misses.
struct TetCheckOrder {
  std::vector<Tet> tets;
  std::vector<Index> index;
};

/// The tets along a Morton curve of their centroids at `positions` (tets_in_morton_order).
TetCheckOrder make_tet_check_order(const Positions& positions, const std::vector<Tet>& tets);

/// validate_positions() over the tets of `order`: the same report (indices are the mesh's,
/// the lists hold the smallest ones) for any order. Throws std::invalid_argument when
/// `order.index` and `order.tets` differ in size.
ValidationReport validate_positions(const Positions& positions, const TetCheckOrder& order,
                                    const ValidationOptions& options = {});

namespace detail {

/// The shape part of validate_positions() over some tets only: tets[k] is the mesh's tet
/// index[k]. Adds to the degenerate, inverted and sliver lists of `report` (and to
/// min_quality, or sets it NaN without compute_min_quality); coordinates are not checked.
/// Lists keep the smallest indices whatever the order of `tets` and the thread count.
void check_tet_shapes(const Positions& positions, std::span<const Tet> tets,
                      std::span<const Index> index, const ValidationOptions& options,
                      ValidationReport& report);

}  // namespace detail

/// Error (kInvalidMesh) naming the first defect when the report is not clean, with
/// `what` (a file or object name) as the message prefix; ok otherwise. Slivers pass.
Status require_valid(const ValidationReport& report, const std::string& what);

}  // namespace tc
