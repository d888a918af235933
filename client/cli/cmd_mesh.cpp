// `tetcollide mesh info FILE [--json]` and `tetcollide mesh convert IN OUT.vtu`.
#include <cstdio>
#include <iostream>

#include "cli_common.hpp"
#include "core/io/mesh_io.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/mesh_stats.hpp"
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

int run_info(const MeshInfoArgs& args) {
  auto mesh = read_mesh(args.file);
  if (!mesh) return report_error(mesh.error());
  const ValidationReport report = validate_mesh(*mesh);
  if (report.structurally_invalid())
    return report_error(Error{ErrorCode::kInvalidMesh, args.file + ": " + report.summary()});
  const Topology topo = build_topology(mesh->tets, mesh->num_nodes());
  const MeshStats s = compute_mesh_stats(*mesh, topo, report);
  if (args.json) {
    print_json({{"nodes", s.nodes},
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

int run_convert(const MeshConvertArgs& args) {
  auto mesh = read_mesh(args.input);
  if (!mesh) return report_error(mesh.error());
  const ValidationReport report = validate_mesh(*mesh);
  if (report.structurally_invalid())
    return report_error(Error{ErrorCode::kInvalidMesh, args.input + ": " + report.summary()});
  std::vector<VtuField> cells(1);
  cells[0].name = "quality";
  const Topology topo = build_topology(mesh->tets, mesh->num_nodes());
  std::vector<VtuField> points(1);
  points[0].name = "boundary";
  for (const auto flag : topo.is_boundary_node) points[0].values.push_back(flag);
  for (const Tet& t : mesh->tets) cells[0].values.push_back(tet_quality(mesh->positions, t));
  const Status st = write_vtu(args.output, *mesh, points, cells);
  if (!st) return report_error(st.error().message, kExitFailure);
  std::fprintf(stderr, "wrote %s (%d nodes, %d tets)\n", args.output.c_str(), mesh->num_nodes(),
               mesh->num_tets());
  return kExitOk;
}

}  // namespace

void add_mesh_command(CLI::App& app, Context& ctx) {
  auto* mesh = app.add_subcommand("mesh", "Inspect and convert tetrahedral meshes");
  mesh->require_subcommand(1);

  auto info_args = std::make_shared<MeshInfoArgs>();
  auto* info = mesh->add_subcommand("info", "Counts, boundary, components and quality of a mesh");
  info->add_option("FILE", info_args->file, "Mesh file (.msh, .node/.ele)")->required();
  info->add_flag("--json", info_args->json, "Print one JSON object");
  info->callback([&ctx, info_args] { ctx.exit_code = run_info(*info_args); });

  auto convert_args = std::make_shared<MeshConvertArgs>();
  auto* convert = mesh->add_subcommand("convert", "Write a mesh as VTK XML (.vtu) for ParaView");
  convert->add_option("IN", convert_args->input, "Mesh file (.msh, .node/.ele)")->required();
  convert->add_option("OUT", convert_args->output, "Output .vtu file")->required();
  convert->callback([&ctx, convert_args] { ctx.exit_code = run_convert(*convert_args); });
}

}  // namespace tc::cli
