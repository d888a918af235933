// `tetcollide mesh info FILE [--json]` and `tetcollide mesh convert IN OUT`.
// `mesh info` reports a tet mesh or, for .stl, .obj and a .msh with triangles and no
// tets, a triangle surface (docs/SURFACES.md). `mesh convert` writes the format OUT's
// extension names (case-insensitive): `.vtu` (VTK XML for ParaView, with the fields
// `boundary` and `quality`), `.node` or `.ele` (a TetGen pair: both OUT's stem.node and
// stem.ele, numbered from 0 when the ids are 0..n-1, else from 1), `.msh` (Gmsh 4.1
// ASCII, node ids as tags). Positions are written so that they read back bit for bit.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>

#include "cli_common.hpp"
#include "core/io/mesh_io.hpp"
#include "core/io/surface_io.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/mesh_stats.hpp"
#include "core/mesh/surface_mesh.hpp"
#include "core/mesh/topology.hpp"
#include "core/mesh/validate.hpp"

namespace tc::cli {
namespace {

struct MeshInfoArgs {
  std::string file;
  bool json = false;
};

struct MeshConvertArgs {
  std::string input;
  std::string output;
};

int surface_info(const MeshInfoArgs& args, const SurfaceMesh& mesh) {
  const SurfaceValidationReport report = validate_surface(mesh);
  if (report.structurally_invalid())
    return report_error(require_valid_surface(report, args.file).error());
  const SurfaceStats s = compute_surface_stats(mesh, build_surface_edges(mesh.triangles), report);
  const double diagonal = (s.bbox_hi - s.bbox_lo).norm();
  if (args.json) {
    nlohmann::json out = {{"kind", "surface"},
                          {"nodes", s.nodes},
                          {"triangles", s.triangles},
                          {"edges", s.edges},
                          {"boundary_edges", s.boundary_edges},
                          {"nonmanifold_edges", s.nonmanifold_edges},
                          {"misoriented_edges", s.misoriented_edges},
                          {"components", s.components},
                          {"unused_nodes", s.unused_nodes},
                          {"degenerate_triangles", s.degenerate_triangles},
                          {"closed", s.closed},
                          {"consistently_oriented", s.misoriented_edges == 0},
                          {"area", s.area},
                          {"bbox_min", {s.bbox_lo.x(), s.bbox_lo.y(), s.bbox_lo.z()}},
                          {"bbox_max", {s.bbox_hi.x(), s.bbox_hi.y(), s.bbox_hi.z()}},
                          {"bbox_diagonal", diagonal},
                          {"min_quality", s.min_quality}};
    if (s.oriented) {
      out["enclosed_volume"] = s.enclosed_volume;
      out["normals"] = s.outward ? "outward" : "inward";
    }
    print_json(out);
    return kExitOk;
  }
  std::printf("file:                 %s\n", args.file.c_str());
  std::printf("kind:                 surface\n");
  std::printf("nodes:                %d\n", s.nodes);
  std::printf("triangles:            %d\n", s.triangles);
  std::printf("edges:                %d\n", s.edges);
  std::printf("boundary_edges:       %d\n", s.boundary_edges);
  std::printf("nonmanifold_edges:    %d\n", s.nonmanifold_edges);
  std::printf("misoriented_edges:    %d\n", s.misoriented_edges);
  std::printf("components:           %d\n", s.components);
  std::printf("unused_nodes:         %d\n", s.unused_nodes);
  std::printf("degenerate_triangles: %zu\n", s.degenerate_triangles);
  std::printf("min_quality:          %.6g\n", s.min_quality);
  std::printf("closed:               %s\n",
              s.closed ? (s.oriented ? "yes" : "yes, but inconsistently oriented") : "no (open)");
  std::printf("area:                 %.9g\n", s.area);
  if (s.oriented)
    std::printf("enclosed_volume:      %.9g (normals %s)\n", s.enclosed_volume,
                s.outward ? "outward" : "inward");
  std::printf("bbox:                 [%.9g, %.9g, %.9g] - [%.9g, %.9g, %.9g]\n", s.bbox_lo.x(),
              s.bbox_lo.y(), s.bbox_lo.z(), s.bbox_hi.x(), s.bbox_hi.y(), s.bbox_hi.z());
  std::printf("bbox_diagonal:        %.9g\n", diagonal);
  if (!report.clean()) std::printf("warning:              %s\n", report.summary().c_str());
  return kExitOk;
}

int run_info(const MeshInfoArgs& args) {
  auto object = read_object_mesh(args.file);
  if (!object) return report_error(object.error());
  if (const auto* surface = std::get_if<SurfaceMesh>(&*object)) return surface_info(args, *surface);
  // A file with neither tets nor triangles gets the tet report (0 tets).
  const TetMesh* mesh = &std::get<TetMesh>(*object);
  const ValidationReport report = validate_mesh(*mesh);
  if (report.structurally_invalid())
    return report_error(Error{ErrorCode::kInvalidMesh, args.file + ": " + report.summary()});
  const Topology topo = build_topology(mesh->tets, mesh->num_nodes());
  const MeshStats s = compute_mesh_stats(*mesh, topo, report);
  if (args.json) {
    print_json({{"kind", "tets"},
                {"nodes", s.nodes},
                {"tets", s.tets},
                {"boundary_faces", s.boundary_faces},
                {"boundary_edges", s.boundary_edges},
                {"boundary_nodes", s.boundary_nodes},
                {"components", s.components},
                {"orphan_nodes", s.orphan_nodes},
                {"degenerate_tets", s.degenerate_tets},
                {"inverted_tets", s.inverted_tets},
                {"volume", s.volume},
                {"bbox_diagonal", s.bbox_diagonal},
                {"mean_edge_length", s.mean_edge_length}});
    return kExitOk;
  }
  std::printf("file:             %s\n", args.file.c_str());
  std::printf("nodes:            %d\n", s.nodes);
  std::printf("tets:             %d\n", s.tets);
  std::printf("boundary_faces:   %d\n", s.boundary_faces);
  std::printf("boundary_edges:   %d\n", s.boundary_edges);
  std::printf("boundary_nodes:   %d\n", s.boundary_nodes);
  std::printf("components:       %d\n", s.components);
  std::printf("orphan_nodes:     %d\n", s.orphan_nodes);
  std::printf("degenerate_tets:  %zu\n", s.degenerate_tets);
  std::printf("inverted_tets:    %zu\n", s.inverted_tets);
  std::printf("sliver_tets:      %zu\n", s.sliver_tets);
  std::printf("min_quality:      %.6g\n", s.min_quality);
  std::printf("volume:           %.9g\n", s.volume);
  std::printf("bbox_diagonal:    %.9g\n", s.bbox_diagonal);
  std::printf("mean_edge_length: %.9g\n", s.mean_edge_length);
  if (!report.clean()) std::printf("warning:          %s\n", report.summary().c_str());
  return kExitOk;
}

/// What `mesh convert` writes, from OUT's extension.
enum class ConvertFormat { kVtu, kTetGen, kGmsh };

/// The format OUT's extension (case-insensitive) names, or nullopt.
std::optional<ConvertFormat> convert_format(const std::string& output) {
  std::string ext = std::filesystem::path(output).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".vtu") return ConvertFormat::kVtu;
  if (ext == ".node" || ext == ".ele") return ConvertFormat::kTetGen;
  if (ext == ".msh") return ConvertFormat::kGmsh;
  return std::nullopt;
}

/// Writes the mesh as VTK XML with a per-node `boundary` flag and a per-tet `quality`.
Status write_convert_vtu(const std::string& output, const TetMesh& mesh) {
  std::vector<VtuField> cells(1);
  cells[0].name = "quality";
  const Topology topo = build_topology(mesh.tets, mesh.num_nodes());
  std::vector<VtuField> points(1);
  points[0].name = "boundary";
  for (const auto flag : topo.is_boundary_node) points[0].values.push_back(flag);
  for (const Tet& t : mesh.tets) cells[0].values.push_back(tet_quality(mesh.positions, t));
  return write_vtu(output, mesh, points, cells);
}

/// Writes Gmsh 4.1 ASCII. Gmsh tags are positive: ids that are not all positive (a
/// 0-based TetGen file, a Gmsh file using the reserved tag 0) become 1..n in node order,
/// with a note on stderr.
Status write_convert_gmsh(const std::string& output, const TetMesh& mesh) {
  if (std::all_of(mesh.node_ids.begin(), mesh.node_ids.end(),
                  [](std::int64_t id) { return id > 0; }))
    return write_gmsh(output, mesh, GmshFormat::kMsh41Ascii);
  TetMesh renumbered = mesh;
  for (std::size_t i = 0; i < renumbered.node_ids.size(); ++i)
    renumbered.node_ids[i] = static_cast<std::int64_t>(i) + 1;
  std::fprintf(stderr, "note: node ids renumbered 1..%d in %s (Gmsh node tags are positive)\n",
               mesh.num_nodes(), output.c_str());
  return write_gmsh(output, renumbered, GmshFormat::kMsh41Ascii);
}

/// True when the node ids are 1..n in node order (TetGen's 1-based numbering).
bool ids_from_one(const TetMesh& mesh) {
  for (std::size_t i = 0; i < mesh.node_ids.size(); ++i)
    if (mesh.node_ids[i] != static_cast<std::int64_t>(i) + 1) return false;
  return true;
}

int run_convert(const MeshConvertArgs& args) {
  const std::optional<ConvertFormat> format = convert_format(args.output);
  if (!format)
    return report_error(args.output +
                            ": unknown output extension (expected .vtu, .node or .ele for a "
                            "TetGen pair, or .msh)",
                        kExitUsage);
  auto mesh = read_mesh(args.input);
  if (!mesh) return report_error(mesh.error());
  const ValidationReport report = validate_mesh(*mesh);
  if (report.structurally_invalid())
    return report_error(Error{ErrorCode::kInvalidMesh, args.input + ": " + report.summary()});
  std::string written = args.output;
  Status st;
  switch (*format) {
    case ConvertFormat::kVtu:
      st = write_convert_vtu(args.output, *mesh);
      break;
    case ConvertFormat::kTetGen: {
      const std::string stem = tetgen_stem(args.output).string();
      written = stem + ".node and " + stem + ".ele";
      if (tetgen_base(*mesh) == 1 && !ids_from_one(*mesh))
        std::fprintf(stderr,
                     "note: node ids renumbered 1..%d (TetGen numbers points "
                     "consecutively)\n",
                     mesh->num_nodes());
      st = write_tetgen(args.output, *mesh);
      break;
    }
    case ConvertFormat::kGmsh:
      st = write_convert_gmsh(args.output, *mesh);
      break;
  }
  if (!st) return report_error(st.error().message, kExitFailure);
  std::fprintf(stderr, "wrote %s (%d nodes, %d tets)\n", written.c_str(), mesh->num_nodes(),
               mesh->num_tets());
  return kExitOk;
}

}  // namespace

void add_mesh_command(CLI::App& app, Context& ctx) {
  auto* mesh = app.add_subcommand("mesh", "Inspect and convert tetrahedral meshes and surfaces");
  mesh->require_subcommand(1);

  auto info_args = std::make_shared<MeshInfoArgs>();
  auto* info = mesh->add_subcommand(
      "info",
      "Counts, boundary, components and quality of a tet mesh or a triangle surface (closed or "
      "open, area, enclosed volume)");
  info->add_option("FILE", info_args->file,
                   "Mesh file (.msh, .node/.ele) or surface file (.stl, .obj, .msh with triangles "
                   "and no tets)")
      ->required();
  info->add_flag("--json", info_args->json, "Print one JSON object");
  info->callback([&ctx, info_args] { ctx.exit_code = run_info(*info_args); });

  auto convert_args = std::make_shared<MeshConvertArgs>();
  auto* convert = mesh->add_subcommand(
      "convert",
      "Write a mesh in the format OUT's extension names: VTK XML (.vtu) for ParaView, a TetGen "
      "pair (.node or .ele: writes both), Gmsh 4.1 ASCII (.msh)");
  convert->add_option("IN", convert_args->input, "Mesh file (.msh, .node/.ele)")->required();
  convert
      ->add_option("OUT", convert_args->output,
                   "Output file: .vtu, .node or .ele (OUT's stem .node and .ele), .msh")
      ->required();
  convert->callback([&ctx, convert_args] { ctx.exit_code = run_convert(*convert_args); });
}

}  // namespace tc::cli
