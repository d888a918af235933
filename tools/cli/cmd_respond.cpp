// `tetcollide respond FILE_A FILE_B [--scale-a SX SY SZ] [--scale-b SX SY SZ]
//  [--turn-b AX AY AZ DEG] [--spin-b DEG] [--move-b DX DY DZ] --response point|segment|auto
//  [--depth cpfm|cffm|exact] [--evaluation nearest-face|interpolate] [--lazy local|whole]
//  [--stiffness K] [--friction MU [--friction-velocity EPS]] [--velocity-b VX VY VZ]
//  [--repeat R] [--jitter M]
//  [--forces OUT.csv] [--contacts OUT.csv] [--exact-check] [--json]`:
// one frame of the whole pipeline (detection, lazy depth map, penalty response) on two
// meshes, B optionally turned about its box's centre (after --scale-b) and translated.
// --spin-b turns B a further DEG degrees a frame about the same axis (z without --turn-b)
// and its box's centre, so that the frames time an object that turns; the forces and
// contacts reported are those of the last frame. Either file may be a triangle surface (.stl, .obj,
// or a .msh with triangles and no tets; docs/SURFACES.md), not both. --contacts lists the point
// contacts with the depth and direction their forces used; --exact-check compares those depths with
// the exact distance of each node to the other object's boundary (docs/RESPONSE.md).
// --velocity-b moves every node of B at that velocity (A at rest): the contact damping and,
// with --friction, Coulomb friction read it; friction is in the totals and --forces.
// --jitter M moves every node of both objects by a seeded random offset in [-M, M] per
// axis in each frame (outside the frame's time), so that --repeat times deforming frames.
// `tetcollide respond FILE_A --self [...]`: one tet object and its self-contact (a fold,
// fragments; docs/RESPONSE.md "Self-contact"), named `a` in every output, with the same JSON
// keys (b's are zero; "kinds" names b "none"); the options that move b do not apply.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <variant>

#include "cli_common.hpp"
#include "core/io/surface_io.hpp"
#include "core/pipeline/pipeline.hpp"

namespace tc::cli {
namespace {

struct RespondArgs {
  std::string file_a;
  std::string file_b;
  std::vector<double> move_b;
  std::vector<double> turn_b;
  double spin_b = 0.0;
  std::vector<double> scale_a;
  std::vector<double> scale_b;
  std::string response = "auto";
  std::string depth = "cpfm";
  std::string broad;
  double stiffness = 1e4;
  double friction = 0.0;
  double friction_velocity = 0.0;
  std::vector<double> velocity_b;
  int repeat = 20;
  double jitter = 0.0;
  std::string forces_csv;
  std::string contacts_csv;
  std::string evaluation = "nearest-face";
  std::string lazy = "local";
  bool exact_check = false;
  bool json = false;
  bool self = false;
  bool response_given = false;
};

/// How the contact depths compare with the exact ones (--exact-check).
struct DepthAudit {
  std::size_t contacts = 0;
  std::size_t within = 0;      ///< |depth - exact| <= 10% exact + 1e-3 bbox diagonal
  std::size_t beyond_1_5 = 0;  ///< depth > 1.5 exact + tol, or < exact / 1.5 - tol
  std::size_t zero = 0;        ///< depth 0 where exact > tol
  double max_ratio = 0.0;      ///< max depth / exact over contacts with exact > tol
  double min_ratio = 0.0;      ///< min of the same
};

double bbox_diagonal(const Positions& x) {
  if (x.cols() == 0) return 0.0;
  return (x.rowwise().maxCoeff() - x.rowwise().minCoeff()).norm();
}

Positions& positions_of(ObjectMesh& m) {
  return std::visit([](auto& mesh) -> Positions& { return mesh.positions; }, m);
}

const std::vector<std::int64_t>& node_ids_of(const ObjectMesh& m) {
  return std::visit(
      [](const auto& mesh) -> const auto& { return mesh.node_ids; }, m);
}

const char* kind_of(const ObjectMesh& m) {
  return std::holds_alternative<SurfaceMesh>(m) ? "surface" : "tets";
}

/// Registers a tet mesh or a surface; errors are prefixed with the file.
Status register_object(Pipeline& pipeline, const std::string& name, ObjectMesh mesh,
                       const ObjectParams& params, const std::string& file) {
  Status st = std::holds_alternative<SurfaceMesh>(mesh)
                  ? pipeline.set_surface(name, 0, std::get<SurfaceMesh>(std::move(mesh)), params)
                  : pipeline.set_topology(name, 0, std::get<TetMesh>(std::move(mesh)), params);
  if (!st) return Error{st.error().code, file + ": " + st.error().message};
  return {};
}

/// The timed frames of a run: per-frame times and the last frame's output.
struct RespondRun {
  FrameOutput output;
  std::vector<double> times, detect_ms, depth_ms, response_ms;
  void add(FrameOutput out) {
    times.push_back(out.stats.total_ms);
    detect_ms.push_back(out.stats.broad_ms + out.stats.narrow_ms);
    depth_ms.push_back(out.stats.depth_ms);
    response_ms.push_back(out.stats.response_ms);
    output = std::move(out);
  }
};

int report(const RespondArgs& args, const Pipeline& pipeline, const RespondRun& run,
           const std::array<std::string, 2>& kinds,
           const std::array<std::vector<std::int64_t>, 2>& ids, const std::array<double, 2>& diags);

/// The usage errors of the two forms (FILE_A FILE_B, or FILE_A --self), or "".
std::string usage_problem(const RespondArgs& args) {
  if (!args.self) {
    if (args.file_b.empty()) return "FILE_B is required (or --self for one object's self-contact)";
    if (!args.response_given) return "--response is required";
    return "";
  }
  if (!args.file_b.empty())
    return "--self takes one mesh: FILE_B (" + args.file_b + ") is not used with it";
  const std::pair<bool, const char*> b_only[] = {
      {!args.move_b.empty(), "--move-b"},         {!args.turn_b.empty(), "--turn-b"},
      {args.spin_b != 0.0, "--spin-b"},           {!args.scale_b.empty(), "--scale-b"},
      {!args.velocity_b.empty(), "--velocity-b"}, {!args.broad.empty(), "--broad"}};
  for (const auto& [given, name] : b_only)
    if (given) return std::string(name) + " does not apply to --self (one object, no b)";
  return "";
}

/// The objects' parameters the flags ask for. (--response and --depth are checked by
/// CLI11, IsMember: both names parse.)
ObjectParams object_params(const RespondArgs& args) {
  ObjectParams params;
  params.stiffness = args.stiffness;
  params.friction = args.friction;
  params.friction_velocity = args.friction_velocity;
  params.response = parse_response_kind(args.response).value_or(ResponseKind::kAuto);
  params.depth = parse_depth_method(args.depth).value_or(DepthMethod::kCpfm);
  return params;
}

PipelineConfig pipeline_config(const RespondArgs& args) {
  PipelineConfig config;
  config.broad_phase = args.broad;
  config.record_contacts = !args.contacts_csv.empty() || args.exact_check;
  config.evaluation = args.evaluation == "interpolate" ? DepthEvaluation::kInterpolate
                                                       : DepthEvaluation::kNearestFace;
  config.lazy_region = args.lazy == "whole" ? LazyRegion::kWholeBoundary : LazyRegion::kLocal;
  return config;
}

/// `respond FILE_A --self`: one tet object and its self-contact, reported as `a`.
int run_self(const RespondArgs& args) {
  auto read = read_object_mesh(args.file_a);
  if (!read) return report_error(read.error());
  if (!std::holds_alternative<TetMesh>(*read))
    return report_error(Error{ErrorCode::kInvalidArgument,
                              args.file_a + " is a surface: self-contact needs a tet mesh (a "
                                            "depth map to push its nodes out of)"});
  TetMesh mesh = std::get<TetMesh>(std::move(*read));
  if (args.scale_a.size() == 3)
    mesh.positions =
        Eigen::Vector3d(args.scale_a[0], args.scale_a[1], args.scale_a[2]).asDiagonal() *
        mesh.positions;
  ObjectParams params = object_params(args);
  params.self_contact = true;
  const PipelineConfig config = pipeline_config(args);
  const double diag = bbox_diagonal(mesh.positions);
  const std::vector<std::int64_t> ids = mesh.node_ids;
  const Positions rest = mesh.positions;
  Pipeline pipeline(config);
  if (Status st = pipeline.set_topology("a", 0, std::move(mesh), params); !st)
    return report_error(Error{st.error().code, args.file_a + ": " + st.error().message});
  RespondRun run;
  std::vector<FrameObjectInput> states(1);
  states[0].object = "a";
  for (int r = 0; r < std::max(1, args.repeat); ++r) {
    jitter_positions(rest, args.jitter, r, 0, states[0].positions);
    run.add(pipeline.run_frame_taking(r, states));
  }
  return report(args, pipeline, run, {"tets", "none"}, {ids, {}}, {diag, 0.0});
}

int run_respond(const RespondArgs& args) {
  if (const std::string problem = usage_problem(args); !problem.empty())
    return report_error(problem, kExitUsage);
  if (args.self) return run_self(args);
  auto a = read_object_mesh(args.file_a);
  if (!a) return report_error(a.error());
  auto b = read_object_mesh(args.file_b);
  if (!b) return report_error(b.error());
  if (std::holds_alternative<SurfaceMesh>(*a) && std::holds_alternative<SurfaceMesh>(*b))
    return report_error(Error{ErrorCode::kInvalidArgument,
                              args.file_a + " and " + args.file_b +
                                  " are both surfaces: a surface has no depth map, so two "
                                  "surfaces are never tested against each other"});
  const auto scale = [](Positions& x, const std::vector<double>& s) {
    if (s.size() == 3) x = Eigen::Vector3d(s[0], s[1], s[2]).asDiagonal() * x;
  };
  scale(positions_of(*a), args.scale_a);
  scale(positions_of(*b), args.scale_b);
  if (!args.turn_b.empty())
    if (Status st = turn_about_centre(positions_of(*b), args.turn_b); !st)
      return report_error(st.error().message, kExitUsage);
  if (!std::isfinite(args.spin_b))
    return report_error("--spin-b: the angle must be finite", kExitUsage);
  if (args.move_b.size() == 3) {
    const Eigen::Vector3d shift(args.move_b[0], args.move_b[1], args.move_b[2]);
    positions_of(*b).colwise() += shift;
  }
  const std::string kind_a = kind_of(*a), kind_b = kind_of(*b);
  const ObjectParams params = object_params(args);
  const PipelineConfig config = pipeline_config(args);
  const double diag_a = bbox_diagonal(positions_of(*a)), diag_b = bbox_diagonal(positions_of(*b));
  Pipeline pipeline(config);
  std::vector<FrameObjectInput> states(2);
  states[0].object = "a";
  states[0].positions = positions_of(*a);
  states[1].object = "b";
  states[1].positions = positions_of(*b);
  if (args.velocity_b.size() == 3) {
    const Eigen::Vector3d v(args.velocity_b[0], args.velocity_b[1], args.velocity_b[2]);
    if (!v.allFinite())
      return report_error("--velocity-b: the velocity must be finite", kExitUsage);
    states[1].velocities = v.replicate(1, states[1].positions.cols());
  }
  const std::vector<std::int64_t> ids_a = node_ids_of(*a), ids_b = node_ids_of(*b);
  if (Status st = register_object(pipeline, "a", std::move(*a), params, args.file_a); !st)
    return report_error(st.error());
  if (Status st = register_object(pipeline, "b", std::move(*b), params, args.file_b); !st)
    return report_error(st.error());

  RespondRun run;
  const std::vector<FrameObjectInput> sent = states;
  for (int r = 0; r < std::max(1, args.repeat); ++r) {
    // As in the daemon, the states are made for the frame and the pipeline takes their
    // matrices (run_frame_taking): refilled here, outside the frame's time.
    for (std::size_t i = 0; i < states.size(); ++i) {
      jitter_positions(sent[i].positions, args.jitter, r, static_cast<int>(i), states[i].positions);
      states[i].velocities = sent[i].velocities;
    }
    if (args.spin_b != 0.0 && r > 0) {
      std::vector<double> spin = {0.0, 0.0, 1.0, args.spin_b * r};
      if (!args.turn_b.empty()) std::copy_n(args.turn_b.begin(), 3, spin.begin());
      if (Status st = turn_about_centre(states[1].positions, spin); !st)
        return report_error(st.error().message, kExitUsage);
    }
    run.add(pipeline.run_frame_taking(r, states));
  }
  return report(args, pipeline, run, {kind_a, kind_b}, {ids_a, ids_b}, {diag_a, diag_b});
}

int report(const RespondArgs& args, const Pipeline& pipeline, const RespondRun& run,
           const std::array<std::string, 2>& kinds,
           const std::array<std::vector<std::int64_t>, 2>& node_ids,
           const std::array<double, 2>& diags) {
  const FrameOutput& output = run.output;
  for (const ObjectError& e : output.errors) return report_error(e.error);
  const std::string& kind_a = kinds[0];
  const std::string& kind_b = kinds[1];
  const std::vector<std::int64_t>& ids_a = node_ids[0];
  const std::vector<std::int64_t>& ids_b = node_ids[1];
  const double diag_a = diags[0], diag_b = diags[1];
  const std::vector<double>& times = run.times;

  Eigen::Vector3d total_a = Eigen::Vector3d::Zero(), total_b = Eigen::Vector3d::Zero();
  for (const ObjectForces& f : output.forces)
    for (const auto& v : f.forces) (f.object == "a" ? total_a : total_b) += v;
  if (!args.forces_csv.empty()) {
    std::ofstream csv(args.forces_csv);
    if (!csv) return report_error("cannot write " + args.forces_csv, kExitFailure);
    csv << "object,node_id,fx,fy,fz\n";
    csv.precision(17);
    for (const ObjectForces& f : output.forces) {
      const auto& ids = f.object == "a" ? ids_a : ids_b;
      for (std::size_t i = 0; i < f.nodes.size(); ++i)
        csv << f.object << ',' << ids[static_cast<std::size_t>(f.nodes[i])] << ','
            << f.forces[i].x() << ',' << f.forces[i].y() << ',' << f.forces[i].z() << '\n';
    }
  }
  if (!args.contacts_csv.empty()) {
    std::ofstream csv(args.contacts_csv);
    if (!csv) return report_error("cannot write " + args.contacts_csv, kExitFailure);
    csv << "object,node_id,depth,nx,ny,nz\n";
    csv.precision(17);
    for (const FramePointContact& c : output.point_contacts) {
      const auto& ids = c.object == "a" ? ids_a : ids_b;
      csv << c.object << ',' << ids[static_cast<std::size_t>(c.node)] << ',' << c.depth << ','
          << c.normal.x() << ',' << c.normal.y() << ',' << c.normal.z() << '\n';
    }
  }
  DepthAudit audit;
  if (args.exact_check) {
    auto exact = pipeline.exact_depths(output.point_contacts);
    if (!exact) return report_error(exact.error());
    audit.min_ratio = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < exact->size(); ++i) {
      const FramePointContact& c = output.point_contacts[i];
      const double e = (*exact)[i], d = c.depth;
      const double tol = 1e-3 * (c.penetrated == "a" ? diag_a : diag_b);
      ++audit.contacts;
      audit.within += std::abs(d - e) <= 0.1 * e + tol;
      audit.beyond_1_5 += d > 1.5 * e + tol || d < e / 1.5 - tol;
      audit.zero += d == 0.0 && e > tol;
      if (e > tol) {
        audit.max_ratio = std::max(audit.max_ratio, d / e);
        audit.min_ratio = std::min(audit.min_ratio, d / e);
      }
    }
    if (!std::isfinite(audit.min_ratio)) audit.min_ratio = 0.0;
  }
  const double time_ms = median(times);
  if (args.json) {
    nlohmann::json j = {{"kinds", {{"a", kind_a}, {"b", kind_b}}},
                        {"contacts", output.stats.contacts},
                        {"total_force_a", {total_a.x(), total_a.y(), total_a.z()}},
                        {"total_force_b", {total_b.x(), total_b.y(), total_b.z()}},
                        {"max_depth", output.stats.max_depth},
                        {"time_ms", time_ms},
                        {"stage_ms",
                         {{"detect", median(run.detect_ms)},
                          {"depth", median(run.depth_ms)},
                          {"response", median(run.response_ms)}}}};
    if (args.self) j["self"] = true;
    // Every object is a key, 0 when out of contact.
    nlohmann::json settled = {{"a", 0}, {"b", 0}};
    for (const auto& [name, n] : output.settled_by_object) settled[name] = n;
    j["settled_nodes"] = settled;
    if (args.exact_check)
      j["exact_check"] = {{"point_contacts", audit.contacts}, {"within_10_percent", audit.within},
                          {"beyond_1_5x", audit.beyond_1_5},  {"zero_depth", audit.zero},
                          {"max_ratio", audit.max_ratio},     {"min_ratio", audit.min_ratio}};
    print_json(j);
    return kExitOk;
  }
  const FrameStats& s = output.stats;
  if (args.self)
    std::printf("objects:           a %s, self-contact\n", kind_a.c_str());
  else if (kind_a == "surface" || kind_b == "surface")
    std::printf("objects:           a %s, b %s\n", kind_a.c_str(), kind_b.c_str());
  std::printf("contacts:          %zu\n", s.contacts);
  std::printf("overlapping pairs: %zu (of %zu candidates)\n", s.overlapping_pairs,
              s.candidate_pairs);
  std::printf("settled nodes:     %zu\n", s.settled_nodes);
  std::printf("max depth:         %.6g m\n", s.max_depth);
  std::printf("total force a:     [%.6g, %.6g, %.6g] N\n", total_a.x(), total_a.y(), total_a.z());
  std::printf("total force b:     [%.6g, %.6g, %.6g] N\n", total_b.x(), total_b.y(), total_b.z());
  std::printf(
      "time per frame:    %.3f ms median of %zu (broad %.3f, narrow %.3f, depth %.3f, "
      "response %.3f in the last)\n",
      time_ms, times.size(), s.broad_ms, s.narrow_ms, s.depth_ms, s.response_ms);
  if (args.exact_check) {
    const double share = audit.contacts ? 100.0 * static_cast<double>(audit.within) /
                                              static_cast<double>(audit.contacts)
                                        : 100.0;
    std::printf(
        "exact check:       %zu point contacts, %.2f%% within 10%% (+1e-3 diagonal), %zu beyond "
        "1.5x, %zu at zero depth; depth/exact %.4g..%.4g\n",
        audit.contacts, share, audit.beyond_1_5, audit.zero, audit.min_ratio, audit.max_ratio);
  }
  return kExitOk;
}

}  // namespace

void add_respond_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<RespondArgs>();
  auto* cmd = app.add_subcommand(
      "respond", "One frame of detection + lazy depth map + penalty response on two meshes");
  cmd->add_option("FILE_A", args->file_a, "Mesh of object a (tets, or a surface: .stl, .obj, .msh)")
      ->required();
  cmd->add_option("FILE_B", args->file_b,
                  "Mesh of object b (tets, or a surface: .stl, .obj, .msh); not with --self");
  cmd->add_flag("--self", args->self,
                "One tet object (FILE_A) and its self-contact, reported as a (no FILE_B)");
  cmd->add_option("--move-b", args->move_b, "Translate b by DX DY DZ (metres)")->expected(3);
  cmd->add_option("--turn-b", args->turn_b,
                  "Turn b by DEG degrees about the axis AX AY AZ through the centre of its box "
                  "(after --scale-b, before --move-b)")
      ->expected(4)
      ->type_name("AX AY AZ DEG");
  cmd->add_option("--spin-b", args->spin_b,
                  "Turn b a further DEG degrees each frame (about the --turn-b axis, else z, "
                  "through the centre of its box); the last frame is reported")
      ->type_name("DEG");
  cmd->add_option("--scale-a", args->scale_a, "Scale a by SX SY SZ about the origin (first)")
      ->expected(3);
  cmd->add_option("--scale-b", args->scale_b, "Scale b by SX SY SZ about the origin (first)")
      ->expected(3);
  cmd->add_option("--response", args->response,
                  "Response: point, segment or auto (required for two objects; --self: auto)")
      ->check(CLI::IsMember({"point", "segment", "auto"}));
  cmd->add_option("--depth", args->depth, "Depth map: cpfm, cffm or exact")
      ->check(CLI::IsMember({"cpfm", "cffm", "exact"}));
  cmd->add_option("--broad", args->broad, "Broad phase: grid, hash, sap or bvh")
      ->check(CLI::IsMember({"grid", "hash", "sap", "bvh"}));
  cmd->add_option("--stiffness", args->stiffness, "Penalty stiffness k (N/m^2)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--friction", args->friction,
                  "Coulomb friction coefficient mu of both objects (the pair's is mu)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--friction-velocity", args->friction_velocity,
                  "Tangential speed below which friction sticks viscously, m/s (0: 1e-3)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--velocity-b", args->velocity_b,
                  "Every node of b moves at VX VY VZ (m/s); a is at rest")
      ->expected(3)
      ->type_name("VX VY VZ");
  cmd->add_option("--jitter", args->jitter,
                  "Move every node of both objects by a seeded random offset in [-M, M] per "
                  "axis each frame (metres): repeats time deforming frames; the last is reported")
      ->check(CLI::NonNegativeNumber)
      ->type_name("M");
  cmd->add_option("--repeat", args->repeat, "Frames to time (median reported)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--forces", args->forces_csv, "Write object,node_id,fx,fy,fz CSV");
  cmd->add_option("--contacts", args->contacts_csv,
                  "Write the point contacts as object,node_id,depth,nx,ny,nz CSV");
  cmd->add_option("--evaluation", args->evaluation,
                  "Contact depth: nearest-face (default) or interpolate (the paper's 5.1)")
      ->check(CLI::IsMember({"nearest-face", "interpolate"}));
  cmd->add_option("--lazy", args->lazy,
                  "Lazy depth maps march around the contact (local, default) or from the whole "
                  "boundary (whole, the paper's 4.4)")
      ->check(CLI::IsMember({"local", "whole"}));
  cmd->add_flag("--exact-check", args->exact_check,
                "Compare each point contact's depth with the exact distance to the boundary");
  cmd->add_flag("--json", args->json, "Print one JSON object");
  cmd->callback([&ctx, args, cmd] {
    args->response_given = cmd->count("--response") > 0;
    ctx.exit_code = run_respond(*args);
  });
}

}  // namespace tc::cli
