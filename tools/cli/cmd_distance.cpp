// `tetcollide distance FILE --method exact|cpfm|cffm|fm:N [--targets TETS.txt]
//   [--repeat R] [--out OUT.csv] [--json] [--2d]`: one depth map, timed.
//
// time_ms is the median over R runs of the per-frame computation only (no file I/O, no
// topology work: that is setup_ms). With --targets, the lazy variant runs on those tets.
// OUT.csv has the header `node_id,distance` and one row per node used by a tet (node ids
// as in the file, file order); a node a lazy run did not settle reads `inf`.
// 2D (the paper's Fig. 9/10 meshes): a .msh with triangles and no tets, or --2d.
#include <cstdio>
#include <fstream>

#include "cli_common.hpp"
#include "depth_runner.hpp"

namespace tc::cli {
namespace {

struct DistanceArgs {
  std::string file;
  std::string method = "cpfm";
  std::string targets;
  int repeat = 1;
  std::string out;
  bool json = false;
  bool force_2d = false;
};

int write_csv(const std::string& path, const DepthMesh& mesh, const std::vector<double>& depth) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) return report_error(path + ": cannot open file", kExitFailure);
  std::fputs("node_id,distance\n", f);
  const auto used = mesh.used_nodes();
  for (Index i = 0; i < mesh.num_nodes(); ++i) {
    if (!used[i]) continue;
    std::fprintf(f, "%lld,%.17g\n", static_cast<long long>(mesh.node_id(i)), depth[i]);
  }
  if (std::fclose(f) != 0) return report_error(path + ": write failed", kExitFailure);
  return kExitOk;
}

int run_distance(const DistanceArgs& args) {
  auto method = parse_method(args.method);
  if (!method) return report_error(method.error().message, kExitUsage);
  if (args.repeat < 1) return report_error("--repeat must be at least 1", kExitUsage);
  if (!args.targets.empty() && method->kind == MethodSpec::Kind::kGrid)
    return report_error("--targets needs cpfm, cffm or exact, not " + method->label, kExitUsage);
  auto mesh = load_depth_mesh(args.file, args.force_2d);
  if (!mesh) return report_error(mesh.error());
  std::vector<Index> targets;
  if (!args.targets.empty()) {
    auto read = read_targets(args.targets, mesh->num_elements());
    if (!read) return report_error(read.error());
    targets = std::move(*read);
  }
  auto run = run_depth(*mesh, *method, args.repeat, args.targets.empty() ? nullptr : &targets);
  if (!run) return report_error(run.error());
  if (!args.out.empty())
    if (const int rc = write_csv(args.out, *mesh, run->depth); rc != kExitOk) return rc;
  const double time_ms = median(run->frame_ms);
  if (args.json) {
    print_json({{"method", method->label},
                {"nodes", mesh->num_nodes()},
                {"tets", mesh->num_elements()},
                {"setup_ms", run->setup_ms},
                {"time_ms", time_ms},
                {"settled_nodes", run->settled}});
    return kExitOk;
  }
  double deepest = 0.0;
  for (const double d : run->depth)
    if (std::isfinite(d)) deepest = std::max(deepest, d);
  std::printf("file:          %s (%s)\n", args.file.c_str(), mesh->dim == 3 ? "3D" : "2D");
  std::printf("method:        %s\n", method->label.c_str());
  std::printf("nodes:         %d\n", mesh->num_nodes());
  std::printf("%-14s %d\n", mesh->dim == 3 ? "tets:" : "triangles:", mesh->num_elements());
  std::printf("settled_nodes: %zu\n", run->settled);
  std::printf("setup_ms:      %.3f\n", run->setup_ms);
  std::printf("time_ms:       %.3f (median of %d)\n", time_ms, args.repeat);
  std::printf("max_depth:     %.9g\n", deepest);
  return kExitOk;
}

}  // namespace

void add_distance_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<DistanceArgs>();
  auto* cmd = app.add_subcommand("distance", "Depth map (distance to the boundary) of a mesh");
  cmd->add_option("FILE", args->file, "Mesh file (.msh, .node/.ele)")->required();
  cmd->add_option(
         "--method", args->method,
         "exact | cpfm[:bucket|radix|heap] | cffm[:descent|paper|paper-descent|multi|near] | "
         "fm:N (grid fast marching, N points per axis)")
      ->capture_default_str();
  cmd->add_option("--targets", args->targets,
                  "File of 0-based tet indices: lazy depth map until their nodes are settled");
  cmd->add_option("--repeat", args->repeat, "Runs to time (time_ms is the median)")
      ->capture_default_str();
  cmd->add_option("--out", args->out, "Write node_id,distance CSV");
  cmd->add_flag("--json", args->json,
                "Print {method, nodes, tets, setup_ms, time_ms, settled_nodes}");
  cmd->add_flag("--2d", args->force_2d, "Read the file's triangles as a 2D mesh");
  cmd->callback([&ctx, args] { ctx.exit_code = run_distance(*args); });
}

}  // namespace tc::cli
