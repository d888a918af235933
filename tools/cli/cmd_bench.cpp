// `tetcollide bench <what>`: benchmark reports. Subcommands:
//   distance FILE... [--methods LIST] [--repeat R] [--csv OUT] [--plot OUT.svg] [--2d]
//            [--threads T]
//     per mesh and method: median time per frame, and the max / mean / median error
//     against the exact depth map, absolute (metres) and relative to the object's
//     largest depth; a table on stdout, a CSV, and an SVG log-log plot of error
//     (mean and max) against time. 2D meshes (.msh with triangles and no tets, or
//     --2d) run the same algorithms in 2D (the paper's Fig. 9 and 10).
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>

#include "cli_common.hpp"
#include "depth_runner.hpp"
#include "svg_plot.hpp"

namespace tc::cli {
namespace {

constexpr const char* kDefault3d = "exact,cpfm,cffm,fm:32,fm:64,fm:128";
constexpr const char* kDefault2d = "exact,cpfm,cffm,fm:20,fm:100";

struct BenchDistanceArgs {
  std::vector<std::string> files;
  std::string methods;
  int repeat = 5;
  std::string csv;
  std::string plot;
  bool force_2d = false;
  int threads = 0;
};

struct Row {
  std::string mesh;
  int dim = 3;
  Index nodes = 0;
  Index elements = 0;
  std::string method;
  bool exact = false;
  double setup_ms = 0.0;
  double time_ms = 0.0;
  double max_err = 0.0, mean_err = 0.0, median_err = 0.0;  // metres
  double deepest = 0.0;                                    // metres
};

std::vector<std::string> split_list(const std::string& list) {
  std::vector<std::string> out;
  std::stringstream ss(list);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

// max / mean / median of |approx - exact| over the nodes with a finite exact depth.
void fill_errors(Row& row, const std::vector<double>& approx, const std::vector<double>& exact) {
  std::vector<double> errors;
  errors.reserve(exact.size());
  double sum = 0.0;
  for (std::size_t i = 0; i < exact.size(); ++i) {
    if (!std::isfinite(exact[i])) continue;
    const double e = std::abs(approx[i] - exact[i]);
    errors.push_back(e);
    sum += e;
    row.max_err = std::max(row.max_err, e);
  }
  row.mean_err = errors.empty() ? 0.0 : sum / static_cast<double>(errors.size());
  row.median_err = errors.empty() ? 0.0 : median(errors);
}

double rel(double err, double deepest) {
  return deepest > 0.0 ? 100.0 * err / deepest : 0.0;
}

void print_mesh_table(const std::vector<Row>& rows, std::size_t first, int repeat, int threads) {
  const Row& r0 = rows[first];
  std::printf(
      "\n%s: %dD, %d nodes, %d %s, largest depth %.6g m; median of %d runs, %d TBB "
      "threads\n",
      r0.mesh.c_str(), r0.dim, r0.nodes, r0.elements, r0.dim == 3 ? "tets" : "triangles",
      r0.deepest, repeat, threads);
  std::printf("  %-18s %10s %10s %11s %11s %11s %9s %9s %9s\n", "method", "time_ms", "setup_ms",
              "max_err_m", "mean_err_m", "median_m", "max_%", "mean_%", "median_%");
  for (std::size_t i = first; i < rows.size(); ++i) {
    const Row& r = rows[i];
    std::printf("  %-18s %10.3f %10.3f %11.3e %11.3e %11.3e %9.4f %9.5f %9.5f\n", r.method.c_str(),
                r.time_ms, r.setup_ms, r.max_err, r.mean_err, r.median_err,
                rel(r.max_err, r.deepest), rel(r.mean_err, r.deepest),
                rel(r.median_err, r.deepest));
  }
}

int write_csv(const std::string& path, const std::vector<Row>& rows) {
  std::ofstream out(path);
  if (!out) return report_error(path + ": cannot open file", kExitFailure);
  out << "mesh,dim,nodes,elements,method,setup_ms,time_ms,max_error,mean_error,median_error,"
         "max_rel,mean_rel,median_rel,largest_depth\n";
  char buf[512];
  for (const Row& r : rows) {
    std::snprintf(buf, sizeof buf, "%s,%d,%d,%d,%s,%.6g,%.6g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n",
                  r.mesh.c_str(), r.dim, r.nodes, r.elements, r.method.c_str(), r.setup_ms,
                  r.time_ms, r.max_err, r.mean_err, r.median_err, r.max_err / r.deepest,
                  r.mean_err / r.deepest, r.median_err / r.deepest, r.deepest);
    out << buf;
  }
  out.close();
  if (!out) return report_error(path + ": write failed", kExitFailure);
  return kExitOk;
}

int write_plot(const std::string& path, const std::vector<Row>& rows) {
  viz::LogLogPlot plot;
  plot.title = "Depth maps: error against run time";
  plot.x_label = "time per frame (ms, log scale)";
  plot.y_label = "error, % of the object's largest depth (log scale)";
  std::vector<std::string> meshes;
  for (const Row& r : rows) {
    if (std::find(meshes.begin(), meshes.end(), r.mesh) == meshes.end()) meshes.push_back(r.mesh);
    if (!r.exact && std::find(plot.color_names.begin(), plot.color_names.end(), r.method) ==
                        plot.color_names.end())
      plot.color_names.push_back(r.method);
  }
  plot.shape_names = meshes;
  // Errors below kPlotFloor percent (zero, or rounding: the marches run in float) have
  // no place on a log axis: they are drawn at the floor.
  constexpr double kPlotFloor = 1e-5;
  double smallest = 1e300;
  for (const Row& r : rows)
    if (!r.exact)
      for (const double e : {r.max_err, r.mean_err})
        if (rel(e, r.deepest) >= kPlotFloor) smallest = std::min(smallest, rel(e, r.deepest));
  const double floor = smallest < 1e300 ? std::max(kPlotFloor, smallest / 3.0) : kPlotFloor;
  bool clamped = false;
  for (const Row& r : rows) {
    if (r.exact) continue;
    const int color =
        static_cast<int>(std::find(plot.color_names.begin(), plot.color_names.end(), r.method) -
                         plot.color_names.begin());
    const int shape =
        static_cast<int>(std::find(meshes.begin(), meshes.end(), r.mesh) - meshes.begin());
    const auto y = [&](double e) {
      const double v = rel(e, r.deepest);
      clamped = clamped || v < floor;
      return std::max(v, floor);
    };
    const double t = std::max(r.time_ms, 1e-4);
    plot.points.push_back({t, y(r.mean_err), color, shape, true});
    plot.points.push_back({t, y(r.max_err), color, shape, false});
    plot.links.emplace_back(static_cast<int>(plot.points.size()) - 2,
                            static_cast<int>(plot.points.size()) - 1);
  }
  plot.notes.push_back("filled: mean error");
  plot.notes.push_back("hollow: max error");
  if (clamped) {
    char note[96];
    std::snprintf(note, sizeof note, "error < %.2g %%: at the bottom", floor);
    plot.notes.push_back(note);
  }
  for (const Row& r : rows) {
    if (!r.exact) continue;
    char buf[160];
    std::snprintf(buf, sizeof buf, "exact, %s: %.3g ms", r.mesh.c_str(), r.time_ms);
    plot.notes.push_back(buf);
  }
  std::ofstream out(path);
  if (!out) return report_error(path + ": cannot open file", kExitFailure);
  out << viz::plot_loglog_svg(plot);
  out.close();
  if (!out) return report_error(path + ": write failed", kExitFailure);
  return kExitOk;
}

int run_bench_distance(const BenchDistanceArgs& args) {
  if (args.repeat < 1) return report_error("--repeat must be at least 1", kExitUsage);
  std::optional<tbb::global_control> limit;
  if (args.threads > 0)
    limit.emplace(tbb::global_control::max_allowed_parallelism,
                  static_cast<std::size_t>(args.threads));
  const int threads = static_cast<int>(
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  // Parse the method list once up front so a typo fails before any work.
  if (!args.methods.empty())
    for (const std::string& m : split_list(args.methods))
      if (auto spec = parse_method(m); !spec) return report_error(spec.error().message, kExitUsage);

  std::vector<Row> rows;
  for (const std::string& file : args.files) {
    auto mesh = load_depth_mesh(file, args.force_2d);
    if (!mesh) return report_error(mesh.error());
    const auto names = split_list(args.methods.empty() ? (mesh->dim == 3 ? kDefault3d : kDefault2d)
                                                       : args.methods);
    if (names.empty()) return report_error("--methods is empty", kExitUsage);
    // The reference: exact, timed when it is in the list.
    const bool exact_listed = std::find(names.begin(), names.end(), "exact") != names.end();
    auto exact = run_depth(*mesh, *parse_method("exact"), exact_listed ? args.repeat : 1, nullptr);
    if (!exact) return report_error(exact.error());
    double deepest = 0.0;
    for (const double d : exact->depth)
      if (std::isfinite(d)) deepest = std::max(deepest, d);
    const std::size_t first = rows.size();
    for (const std::string& name : names) {
      const MethodSpec spec = *parse_method(name);
      Row row;
      row.mesh = mesh->name;
      row.dim = mesh->dim;
      row.nodes = mesh->num_nodes();
      row.elements = mesh->num_elements();
      row.method = name;
      row.deepest = deepest;
      if (spec.kind == MethodSpec::Kind::kExact) {
        row.exact = true;
        row.setup_ms = exact->setup_ms;
        row.time_ms = median(exact->frame_ms);
      } else {
        auto run = run_depth(*mesh, spec, args.repeat, nullptr);
        if (!run) return report_error(run.error());
        row.setup_ms = run->setup_ms;
        row.time_ms = median(run->frame_ms);
        fill_errors(row, run->depth, exact->depth);
      }
      rows.push_back(row);
    }
    print_mesh_table(rows, first, args.repeat, threads);
  }
  if (!args.csv.empty())
    if (const int rc = write_csv(args.csv, rows); rc != kExitOk) return rc;
  if (!args.plot.empty())
    if (const int rc = write_plot(args.plot, rows); rc != kExitOk) return rc;
  return kExitOk;
}

}  // namespace

void add_bench_command(CLI::App& app, Context& ctx) {
  auto* bench = app.add_subcommand("bench", "Benchmark reports");
  bench->require_subcommand(1);

  auto args = std::make_shared<BenchDistanceArgs>();
  auto* distance = bench->add_subcommand(
      "distance", "Depth maps: time and error against the exact distance, per mesh and method");
  distance->add_option("FILE", args->files, "Mesh files (.msh, .node/.ele; 2D .msh allowed)")
      ->required();
  distance->add_option(
      "--methods", args->methods,
      std::string("Comma-separated methods (default ") + kDefault3d + "; 2D meshes: " + kDefault2d +
          "); also cpfm:radix, cpfm:heap, cffm:paper, cffm:paper-descent, cffm:multi, cffm:near");
  distance->add_option("--repeat", args->repeat, "Runs per method (time is the median)")
      ->capture_default_str();
  distance->add_option("--csv", args->csv, "Write the results as CSV");
  distance->add_option("--plot", args->plot, "Write an SVG log-log plot of error against time");
  distance->add_flag("--2d", args->force_2d, "Read the files' triangles as 2D meshes");
  distance
      ->add_option("--threads", args->threads,
                   "TBB threads (the exact reference is parallel; 0 = all cores)")
      ->capture_default_str();
  distance->callback([&ctx, args] { ctx.exit_code = run_bench_distance(*args); });
  add_bench_response_command(*bench, ctx);
}

}  // namespace tc::cli
