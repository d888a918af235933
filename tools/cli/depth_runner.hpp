// Shared by `tetcollide distance` and `tetcollide bench distance`: loading a 3D or 2D
// mesh, parsing a method name, running it with timings, reading a targets file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/common/result.hpp"
#include "core/depth/depth_solver.hpp"
#include "core/io/mesh_io.hpp"
#include "core/mesh/tet_mesh.hpp"

namespace tc::cli {

/// A mesh for the depth maps: tets (dim 3) or, for the paper's 2D case, triangles
/// (dim 2). A `.msh` file with no tets but triangles is read as 2D.
struct DepthMesh {
  std::string name;  ///< file name without directories
  int dim = 3;
  TetMesh tets;
  TriMesh2 tris;
  [[nodiscard]] Index num_nodes() const;
  [[nodiscard]] Index num_elements() const;
  [[nodiscard]] std::int64_t node_id(Index i) const;
  /// n flags: node used by an element (the nodes a depth is reported for).
  [[nodiscard]] std::vector<std::uint8_t> used_nodes() const;
};

/// Reads FILE; `force_2d` reads its triangles even when it has tets. Errors (exit 3):
/// unreadable file, structurally invalid mesh, a file with neither tets nor triangles.
Expected<DepthMesh> load_depth_mesh(const std::filesystem::path& path, bool force_2d);

/// A depth-map method as named on the command line:
///   exact | cpfm[:bucket|radix|heap] | cffm[:descent|paper|paper-descent|multi|near] | fm:N
struct MethodSpec {
  enum class Kind { kExact, kCpfm, kCffm, kGrid } kind = Kind::kCpfm;
  std::string label;  ///< the name as given, e.g. "fm:64"
  DepthSolverOptions options;
  int grid = 0;  ///< kGrid: N points per axis
};

/// Parses a method name; an error (usage) names it and lists the valid forms.
Expected<MethodSpec> parse_method(const std::string& text);

/// Timings and result of one method on one mesh.
struct DepthRun {
  std::vector<double> depth;     ///< n values, metres; +infinity where not settled
  double setup_ms = 0.0;         ///< topology + solver construction
  std::vector<double> frame_ms;  ///< one per repetition: the per-frame computation only
  std::size_t settled = 0;
};

/// Runs a method `repeat` times (>= 1) on the mesh's positions; with `targets`, the lazy
/// variant on those elements (not for fm:N).
Expected<DepthRun> run_depth(const DepthMesh& mesh, const MethodSpec& method, int repeat,
                             const std::vector<Index>* targets);

/// Reads element indices (0-based, file order) separated by whitespace or newlines,
/// `#` starting a comment. An error (exit 3) names the file, the line and the entry
/// that is not an integer or not in [0, num_elements).
Expected<std::vector<Index>> read_targets(const std::filesystem::path& path, Index num_elements);

}  // namespace tc::cli
