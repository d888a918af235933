#include "depth_runner.hpp"

#include <charconv>
#include <chrono>
#include <fstream>
#include <sstream>

#include "cli_common.hpp"
#include "core/depth/boundary_surface.hpp"
#include "core/depth/grid_fast_marching.hpp"
#include "core/mesh/topology.hpp"
#include "core/mesh/validate.hpp"

namespace tc::cli {
namespace {

using Clock = std::chrono::steady_clock;

Error usage_error(const std::string& message) {
  return Error{ErrorCode::kInvalidArgument, message};
}

template <int D, class Mesh, class Topo>
Expected<DepthRun> run_dim(const Mesh& mesh, std::span<const std::array<Index, D + 1>> elements,
                           const MethodSpec& method, int repeat, const std::vector<Index>* targets,
                           Topo (*build)(const Mesh&)) {
  DepthRun run;
  const auto n = static_cast<std::size_t>(mesh.positions.cols());
  if (method.kind == MethodSpec::Kind::kGrid) {
    if (targets != nullptr)
      return usage_error("--targets needs a marching method (cpfm, cffm) or exact, not " +
                         method.label);
    const auto start = Clock::now();
    const Topo topo = build(mesh);
    std::vector<std::array<Index, D>> simplices;
    if constexpr (D == 3) {
      simplices = topo.boundary_faces;
    } else {
      simplices = topo.boundary_segments;
    }
    GridFastMarching<D> fm(std::move(simplices), method.grid);
    std::vector<Index> nodes;
    std::vector<std::uint8_t> used(n, 0);
    for (const auto& e : elements)
      for (const Index v : e) used[v] = 1;
    for (std::size_t v = 0; v < n; ++v)
      if (used[v]) nodes.push_back(static_cast<Index>(v));
    run.setup_ms = elapsed_ms(start);
    run.depth.assign(n, std::numeric_limits<double>::infinity());
    for (int r = 0; r < repeat; ++r) {
      const auto t0 = Clock::now();
      fm.compute(mesh.positions, nodes, run.depth);
      run.frame_ms.push_back(elapsed_ms(t0));
    }
    run.settled = nodes.size();
    return run;
  }
  const auto start = Clock::now();
  const Topo topo = build(mesh);
  BasicDepthSolver<D> solver(elements, topo, method.options);
  run.setup_ms = elapsed_ms(start);
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = Clock::now();
    if (targets != nullptr) {
      auto settled = solver.compute_lazy(mesh.positions, *targets);
      if (!settled) return settled.error();
    } else if (Status st = solver.compute(mesh.positions); !st) {
      return st.error();
    }
    run.frame_ms.push_back(elapsed_ms(t0));
  }
  run.depth.assign(solver.depth().begin(), solver.depth().end());
  run.settled = solver.settled_count();
  return run;
}

Topology build_3d(const TetMesh& m) {
  return build_topology(m.tets, m.num_nodes());
}
Topology2 build_2d(const TriMesh2& m) {
  return build_topology_2d(m.triangles, static_cast<Index>(m.positions.cols()));
}

}  // namespace

Index DepthMesh::num_nodes() const {
  return dim == 3 ? tets.num_nodes() : static_cast<Index>(tris.positions.cols());
}
Index DepthMesh::num_elements() const {
  return dim == 3 ? tets.num_tets() : static_cast<Index>(tris.triangles.size());
}
std::int64_t DepthMesh::node_id(Index i) const {
  return dim == 3 ? tets.node_ids[i] : tris.node_ids[i];
}
std::vector<std::uint8_t> DepthMesh::used_nodes() const {
  std::vector<std::uint8_t> used(static_cast<std::size_t>(num_nodes()), 0);
  if (dim == 3) {
    for (const Tet& t : tets.tets)
      for (const Index v : t) used[v] = 1;
  } else {
    for (const auto& t : tris.triangles)
      for (const Index v : t) used[v] = 1;
  }
  return used;
}

Expected<DepthMesh> load_depth_mesh(const std::filesystem::path& path, bool force_2d) {
  DepthMesh mesh;
  mesh.name = path.filename().string();
  const bool msh = path.extension() == ".msh";
  if (!force_2d) {
    auto tets = read_mesh(path);
    if (!tets) return tets.error();
    if (tets->num_tets() > 0 || !msh) {
      const ValidationReport report = validate_mesh(*tets);
      if (report.structurally_invalid())
        return Error{ErrorCode::kInvalidMesh, path.string() + ": " + report.summary()};
      mesh.tets = std::move(*tets);
      return mesh;
    }
  }
  if (!msh) return Error{ErrorCode::kUnsupported, path.string() + ": --2d needs a Gmsh .msh file"};
  auto tris = read_gmsh_triangles(path);
  if (!tris) return tris.error();
  if (tris->triangles.empty())
    return Error{ErrorCode::kInvalidMesh,
                 path.string() + ": no tetrahedra and no triangles: nothing to measure"};
  for (std::size_t t = 0; t < tris->triangles.size(); ++t) {
    const auto& tri = tris->triangles[t];
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2])
      return Error{ErrorCode::kInvalidMesh,
                   path.string() + ": triangle " + std::to_string(t) + " repeats a node"};
  }
  mesh.dim = 2;
  mesh.tris = std::move(*tris);
  return mesh;
}

Expected<MethodSpec> parse_method(const std::string& text) {
  MethodSpec spec;
  spec.label = text;
  const auto colon = text.find(':');
  const std::string head = text.substr(0, colon);
  const std::string option = colon == std::string::npos ? "" : text.substr(colon + 1);
  const auto bad = [&] {
    return usage_error("unknown method '" + text +
                       "': use exact, cpfm[:bucket|radix|heap], "
                       "cffm[:descent|paper|paper-descent|multi|near] or fm:N (N >= 2)");
  };
  if (head == "exact" && colon == std::string::npos) {
    spec.kind = MethodSpec::Kind::kExact;
    spec.options.method = DepthMethod::kExact;
  } else if (head == "cpfm") {
    spec.kind = MethodSpec::Kind::kCpfm;
    spec.options.method = DepthMethod::kCpfm;
    if (option == "radix") {
      spec.options.queue = QueueKind::kRadix;
    } else if (option == "heap") {
      spec.options.queue = QueueKind::kBinaryHeap;
    } else if (!option.empty() && option != "bucket") {
      return bad();
    }
  } else if (head == "cffm") {
    spec.kind = MethodSpec::Kind::kCffm;
    spec.options.method = DepthMethod::kCffm;
    if (option == "paper") {
      spec.options.cffm = CffmVariant::kPaper;
    } else if (option == "paper-descent") {
      spec.options.cffm = CffmVariant::kPaperDescent;
    } else if (option == "multi") {
      spec.options.cffm = CffmVariant::kMultiStart;
    } else if (option == "near") {
      spec.options.cffm = CffmVariant::kNearStarts;
    } else if (!option.empty() && option != "descent") {
      return bad();
    }
  } else if (head == "fm") {
    spec.kind = MethodSpec::Kind::kGrid;
    int n = 0;
    const auto [end, ec] = std::from_chars(option.data(), option.data() + option.size(), n);
    if (ec != std::errc{} || end != option.data() + option.size() || n < 2 || n > 4096)
      return bad();
    spec.grid = n;
  } else {
    return bad();
  }
  return spec;
}

Expected<DepthRun> run_depth(const DepthMesh& mesh, const MethodSpec& method, int repeat,
                             const std::vector<Index>* targets) {
  repeat = std::max(repeat, 1);
  if (mesh.dim == 3)
    return run_dim<3>(mesh.tets, std::span<const Tet>(mesh.tets.tets), method, repeat, targets,
                      &build_3d);
  return run_dim<2>(mesh.tris, std::span<const std::array<Index, 3>>(mesh.tris.triangles), method,
                    repeat, targets, &build_2d);
}

Expected<std::vector<Index>> read_targets(const std::filesystem::path& path, Index num_elements) {
  std::ifstream in(path);
  if (!in) return Error{ErrorCode::kIo, path.string() + ": cannot open file"};
  std::vector<Index> targets;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream words(line);
    std::string word;
    while (words >> word) {
      long long value = 0;
      const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), value);
      const std::string where = path.string() + ":" + std::to_string(line_no) + ": ";
      if (ec != std::errc{} || end != word.data() + word.size())
        return Error{ErrorCode::kParse, where + "'" + word + "' is not a tet index"};
      if (value < 0 || value >= num_elements)
        return Error{ErrorCode::kInvalidArgument, where + "tet index " + word +
                                                      " is out of range [0, " +
                                                      std::to_string(num_elements) + ")"};
      targets.push_back(static_cast<Index>(value));
    }
  }
  return targets;
}

}  // namespace tc::cli
