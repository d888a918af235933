// `tetcollide bench response FILE_A FILE_B [--move-b DX DY DZ] [--direction DX DY DZ]
//  [--depths D1,D2,...] [--repeat R] [--threads N] [--csv OUT] [--plot OUT.svg] [--json]`:
// the paper's Fig. 16 measured here. B is shifted by move-b + depth * direction for each
// depth; each position runs the whole pipeline with the point and with the segment
// response and reports, per response, the median frame and response times against the
// number of colliding points, the total force, and the artefact the point response
// leaves: overlapping tet pairs in which no node of either tet is inside the other tet,
// so only the segment response acts on that overlap (the paper's Fig. 11 case).
#include <tbb/global_control.h>

#include <cstdio>
#include <fstream>
#include <memory>
#include <optional>
#include <unordered_map>

#include "cli_common.hpp"
#include "core/detect/detect.hpp"
#include "core/io/mesh_io.hpp"
#include "core/mesh/topology.hpp"
#include "core/pipeline/pipeline.hpp"
#include "svg_plot.hpp"

namespace tc::cli {
namespace {

struct BenchResponseArgs {
  std::string file_a;
  std::string file_b;
  std::vector<double> move_b{0.0, 0.0, 0.0};
  std::vector<double> direction{0.0, 0.0, 1.0};
  std::vector<double> depths{0.0025, 0.005, 0.01, 0.02, 0.04};
  int repeat = 11;
  int threads = 0;
  double stiffness = 1e4;
  std::string csv;
  std::string plot;
  bool json = false;
};

/// One (depth, response) measurement.
struct Row {
  double depth = 0.0;
  std::string response;
  std::size_t overlapping_pairs = 0;
  std::size_t colliding_points = 0;  ///< nodes of either object inside the other
  std::size_t uncovered_pairs = 0;   ///< overlapping pairs with no node in the other tet
  std::size_t contacts = 0;          ///< contacts that produced a force
  double frame_ms = 0.0;             ///< median whole pipeline frame
  double response_ms = 0.0;          ///< median response stage
  double force_a = 0.0;              ///< |sum of forces on A|, N
  double max_depth = 0.0;
};

/// Overlapping pairs (ta, tb) in which no node of ta lies in tb and no node of tb lies in
/// ta: the point response puts no force on that overlap (the paper's Fig. 11), only the
/// segment response does. Each intruding node is listed with one containing tet.
std::size_t count_uncovered(const PairContacts& c, std::span<const Tet> tets_a,
                            std::span<const Tet> tets_b) {
  std::unordered_map<Index, Index> in_a, in_b;  // node -> the tet of the other object
  for (const IntrudingNode& n : c.nodes_a_in_b) in_a.emplace(n.node, n.tet);
  for (const IntrudingNode& n : c.nodes_b_in_a) in_b.emplace(n.node, n.tet);
  const auto inside = [](const std::unordered_map<Index, Index>& in, Index node, Index tet) {
    const auto it = in.find(node);
    return it != in.end() && it->second == tet;
  };
  std::size_t uncovered = 0;
  for (const TetPair& p : c.overlapping) {
    bool covered = false;
    for (const Index v : tets_a[static_cast<std::size_t>(p.tet_a)])
      covered |= inside(in_a, v, p.tet_b);
    for (const Index v : tets_b[static_cast<std::size_t>(p.tet_b)])
      covered |= inside(in_b, v, p.tet_a);
    if (!covered) ++uncovered;
  }
  return uncovered;
}

Row measure(const TetMesh& a, const TetMesh& b, const Positions& positions_b, ResponseKind kind,
            const BenchResponseArgs& args) {
  ObjectParams params;
  params.stiffness = args.stiffness;
  params.response = kind;
  Pipeline pipeline;
  std::vector<FrameObjectInput> states(2);
  states[0].object = "a";
  states[0].positions = a.positions;
  states[1].object = "b";
  states[1].positions = positions_b;
  if (!pipeline.set_topology("a", 0, a, params) || !pipeline.set_topology("b", 0, b, params))
    throw std::runtime_error("set_topology failed");  // validated by the caller first
  std::vector<double> frame_ms, response_ms;
  FrameOutput out;
  for (int r = 0; r < std::max(1, args.repeat); ++r) {
    out = pipeline.run_frame(r, states);
    frame_ms.push_back(out.stats.total_ms);
    response_ms.push_back(out.stats.response_ms);
  }
  Row row;
  row.response = kind == ResponseKind::kPoint ? "point" : "segment";
  row.contacts = out.stats.contacts;
  row.overlapping_pairs = out.stats.overlapping_pairs;
  row.max_depth = out.stats.max_depth;
  row.frame_ms = median(frame_ms);
  row.response_ms = median(response_ms);
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (const ObjectForces& f : out.forces)
    if (f.object == "a")
      for (const Eigen::Vector3d& v : f.forces) total += v;
  row.force_a = total.norm();
  return row;
}

int write_csv(const std::string& path, const std::vector<Row>& rows) {
  std::ofstream csv(path);
  if (!csv) return report_error("cannot write " + path, kExitFailure);
  csv << "depth,response,overlapping_pairs,colliding_points,uncovered_pairs,contacts,frame_ms,"
         "response_ms,force_a,max_depth\n";
  csv.precision(9);
  for (const Row& r : rows)
    csv << r.depth << ',' << r.response << ',' << r.overlapping_pairs << ',' << r.colliding_points
        << ',' << r.uncovered_pairs << ',' << r.contacts << ',' << r.frame_ms << ','
        << r.response_ms << ',' << r.force_a << ',' << r.max_depth << '\n';
  return csv ? kExitOk : report_error("cannot write " + path, kExitFailure);
}

int write_plot(const std::string& path, const std::vector<Row>& rows) {
  viz::LogLogPlot plot;
  plot.title = "Response time against colliding points (paper Fig. 16)";
  plot.x_label = "colliding points (nodes of one object inside the other)";
  plot.y_label = "time per frame (ms)";
  plot.color_names = {"point response", "segment response"};
  plot.shape_names = {"response stage", "whole frame"};
  int last[2][2] = {{-1, -1}, {-1, -1}};
  for (const Row& r : rows) {
    if (r.colliding_points == 0) continue;
    const int color = r.response == "point" ? 0 : 1;
    for (int shape = 0; shape < 2; ++shape) {
      const double y = shape == 0 ? r.response_ms : r.frame_ms;
      if (!(y > 0.0)) continue;
      const int index = static_cast<int>(plot.points.size());
      plot.points.push_back({static_cast<double>(r.colliding_points), y, color, shape, true});
      if (last[color][shape] >= 0) plot.links.emplace_back(last[color][shape], index);
      last[color][shape] = index;
    }
  }
  std::ofstream out(path);
  if (!out) return report_error("cannot write " + path, kExitFailure);
  out << viz::plot_loglog_svg(plot);
  return out ? kExitOk : report_error("cannot write " + path, kExitFailure);
}

int run_bench_response(const BenchResponseArgs& args) {
  if (args.move_b.size() != 3 || args.direction.size() != 3)
    return report_error("--move-b and --direction take three numbers", kExitUsage);
  if (args.depths.empty()) return report_error("--depths is empty", kExitUsage);
  std::optional<tbb::global_control> limit;
  if (args.threads > 0)
    limit.emplace(tbb::global_control::max_allowed_parallelism,
                  static_cast<std::size_t>(args.threads));
  auto a = read_mesh(args.file_a);
  if (!a) return report_error(a.error());
  auto b = read_mesh(args.file_b);
  if (!b) return report_error(b.error());
  {  // Validate once, with the file names in the message.
    Pipeline check;
    if (Status st = check.set_topology("a", 0, *a, {}); !st)
      return report_error(Error{st.error().code, args.file_a + ": " + st.error().message});
    if (Status st = check.set_topology("b", 0, *b, {}); !st)
      return report_error(Error{st.error().code, args.file_b + ": " + st.error().message});
  }
  const Topology topo_a = build_topology(a->tets, a->num_nodes());
  const Topology topo_b = build_topology(b->tets, b->num_nodes());
  const Eigen::Vector3d base(args.move_b[0], args.move_b[1], args.move_b[2]);
  const Eigen::Vector3d dir(args.direction[0], args.direction[1], args.direction[2]);

  std::vector<Row> rows;
  if (!args.json)
    std::printf("%9s %8s %9s %9s %9s %9s %10s %12s %12s\n", "depth_m", "response", "pairs",
                "points", "uncovered", "contacts", "frame_ms", "response_ms", "|F_a| N");
  for (const double depth : args.depths) {
    Positions pb = b->positions;
    pb.colwise() += base + depth * dir;
    const PairContacts contacts = detect_pair(a->positions, a->tets, topo_a, pb, b->tets, topo_b);
    for (const ResponseKind kind : {ResponseKind::kPoint, ResponseKind::kSegment}) {
      Row row = measure(*a, *b, pb, kind, args);
      row.depth = depth;
      row.colliding_points = contacts.nodes_a_in_b.size() + contacts.nodes_b_in_a.size();
      row.uncovered_pairs = count_uncovered(contacts, a->tets, b->tets);
      if (!args.json)
        std::printf("%9.4f %8s %9zu %9zu %9zu %9zu %10.3f %12.3f %12.4g\n", row.depth,
                    row.response.c_str(), row.overlapping_pairs, row.colliding_points,
                    row.uncovered_pairs, row.contacts, row.frame_ms, row.response_ms, row.force_a);
      rows.push_back(row);
    }
  }
  if (args.json) {
    nlohmann::json list = nlohmann::json::array();
    for (const Row& r : rows)
      list.push_back({{"depth", r.depth},
                      {"response", r.response},
                      {"overlapping_pairs", r.overlapping_pairs},
                      {"colliding_points", r.colliding_points},
                      {"uncovered_pairs", r.uncovered_pairs},
                      {"contacts", r.contacts},
                      {"frame_ms", r.frame_ms},
                      {"response_ms", r.response_ms},
                      {"force_a", r.force_a},
                      {"max_depth", r.max_depth}});
    print_json(list);
  }
  if (!args.csv.empty())
    if (const int rc = write_csv(args.csv, rows); rc != kExitOk) return rc;
  if (!args.plot.empty())
    if (const int rc = write_plot(args.plot, rows); rc != kExitOk) return rc;
  return kExitOk;
}

}  // namespace

void add_bench_response_command(CLI::App& bench, Context& ctx) {
  auto args = std::make_shared<BenchResponseArgs>();
  auto* cmd = bench.add_subcommand(
      "response", "Point against segment response: time, contacts and missed overlaps by depth");
  cmd->add_option("FILE_A", args->file_a, "Mesh of object A")->required();
  cmd->add_option("FILE_B", args->file_b, "Mesh of object B")->required();
  cmd->add_option("--move-b", args->move_b, "Base translation of B (m)")->expected(3);
  cmd->add_option("--direction", args->direction, "Direction B moves by each depth")->expected(3);
  cmd->add_option("--depths", args->depths, "Comma-separated depths (m)")->delimiter(',');
  cmd->add_option("--repeat", args->repeat, "Frames per measurement (time is the median)")
      ->capture_default_str();
  cmd->add_option("--threads", args->threads, "TBB threads (default: all)");
  cmd->add_option("--stiffness", args->stiffness, "Penalty stiffness (N/m^2)")
      ->capture_default_str();
  cmd->add_option("--csv", args->csv, "Write the rows as CSV");
  cmd->add_option("--plot", args->plot, "Write an SVG plot of time against colliding points");
  cmd->add_flag("--json", args->json, "Print the rows as JSON");
  cmd->callback([&ctx, args] { ctx.exit_code = run_bench_response(*args); });
}

}  // namespace tc::cli
