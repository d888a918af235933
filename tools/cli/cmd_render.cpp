// `tetcollide render FILE [FILE ...] --out OUT.png [--field NAME] [--view X Y Z]
//  [--size WxH] [--wireframe] [--offset X,Y,Z ...] [--range MIN,MAX] [--title TEXT]`:
// draws the boundary surfaces of meshes into a PNG, headless (no ParaView).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <set>

#include "cli_common.hpp"
#include "core/io/mesh_io.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/topology.hpp"
#include "core/mesh/validate.hpp"
#include "render.hpp"
#include "vtu_reader.hpp"

namespace tc::cli {
namespace {

struct RenderArgs {
  std::vector<std::string> files;
  std::string out;
  std::string field;
  std::vector<double> view;
  std::string size = "1024x768";
  bool wireframe = false;
  std::vector<std::string> offsets;
  std::string range;
  std::string title;
};

// Object colours in file order (muted, distinguishable, print-friendly).
const std::array<Eigen::Vector3f, 6> kPalette = {
    Eigen::Vector3f(0.93f, 0.55f, 0.30f), Eigen::Vector3f(0.55f, 0.68f, 0.85f),
    Eigen::Vector3f(0.56f, 0.78f, 0.52f), Eigen::Vector3f(0.85f, 0.55f, 0.70f),
    Eigen::Vector3f(0.92f, 0.82f, 0.45f), Eigen::Vector3f(0.62f, 0.62f, 0.66f)};

/// One loaded object: its mesh and the point fields it carries.
struct Object {
  TetMesh mesh;
  std::vector<VtuField> fields;  // per node
};

bool has_suffix(const std::string& s, std::string_view suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix.data(), suffix.size()) == 0;
}

Expected<Object> load(const std::string& file) {
  Object o;
  if (has_suffix(file, ".vtu")) {
    auto v = viz::read_vtu(file);
    if (!v) return v.error();
    o.mesh = std::move(v->mesh);
    o.fields = std::move(v->point_fields);
  } else {
    auto m = read_mesh(file);
    if (!m) return m.error();
    o.mesh = std::move(*m);
  }
  const ValidationReport report = validate_mesh(o.mesh);
  if (report.structurally_invalid())
    return Error{ErrorCode::kInvalidMesh, file + ": " + report.summary()};
  if (o.mesh.tets.empty()) return Error{ErrorCode::kInvalidMesh, file + ": no tetrahedra"};
  return o;
}

/// The per-node values of `name` for one object: a field of the file, or a built-in
/// (x, y, z of the drawn, offset positions; quality = worst quality of the tets around
/// the node). Empty if unknown.
std::vector<double> field_values(const Object& o, const Eigen::Matrix3Xd& positions,
                                 const std::string& name) {
  for (const VtuField& f : o.fields)
    if (f.name == name) return f.values;
  const auto n = static_cast<std::size_t>(o.mesh.num_nodes());
  std::vector<double> v;
  if (name == "x" || name == "y" || name == "z") {
    const int k = name[0] - 'x';
    v.resize(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = positions(k, static_cast<Eigen::Index>(i));
  } else if (name == "quality") {
    v.assign(n, std::numeric_limits<double>::quiet_NaN());
    for (const Tet& t : o.mesh.tets) {
      const double q = tet_quality(o.mesh.positions, t);
      for (const Index i : t) {
        double& dst = v[static_cast<std::size_t>(i)];
        dst = std::isnan(dst) ? q : std::min(dst, q);
      }
    }
  }
  return v;
}

bool parse_triple(const std::string& s, Eigen::Vector3d& out) {
  double a = 0, b = 0, c = 0;
  char tail = 0;
  if (std::sscanf(s.c_str(), "%lf,%lf,%lf%c", &a, &b, &c, &tail) != 3) return false;
  out = Eigen::Vector3d(a, b, c);
  return out.allFinite();
}

int run_render(const RenderArgs& args) {
  // Options first (usage errors, exit 2) so no file is read for a bad command line.
  int width = 0, height = 0;
  char tail = 0;
  if (std::sscanf(args.size.c_str(), "%dx%d%c", &width, &height, &tail) != 2 || width < 16 ||
      height < 16 || width > 8192 || height > 8192)
    return report_error("--size '" + args.size + "': expected WxH, 16..8192 each", kExitUsage);
  if (args.offsets.size() > args.files.size())
    return report_error("more --offset values than files", kExitUsage);
  std::vector<Eigen::Vector3d> offsets(args.files.size(), Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < args.offsets.size(); ++i)
    if (!parse_triple(args.offsets[i], offsets[i]))
      return report_error("--offset '" + args.offsets[i] + "': expected X,Y,Z", kExitUsage);
  Eigen::Vector3d view_dir(-0.6, 1.0, -0.55);
  if (!args.view.empty()) {
    view_dir = Eigen::Vector3d(args.view[0], args.view[1], args.view[2]);
    if (!view_dir.allFinite() || view_dir.norm() == 0)
      return report_error("--view must be a non-zero direction", kExitUsage);
  }
  double range_lo = 0, range_hi = 0;
  const bool fixed_range = !args.range.empty();
  if (fixed_range &&
      (std::sscanf(args.range.c_str(), "%lf,%lf%c", &range_lo, &range_hi, &tail) != 2 ||
       !std::isfinite(range_lo) || !std::isfinite(range_hi) || range_lo >= range_hi))
    return report_error("--range '" + args.range + "': expected MIN,MAX with MIN < MAX",
                        kExitUsage);

  const auto start = std::chrono::steady_clock::now();
  std::vector<Object> objects;
  for (const std::string& file : args.files) {
    auto o = load(file);
    if (!o) return report_error(o.error());
    objects.push_back(std::move(*o));
  }
  std::vector<Eigen::Matrix3Xd> positions(objects.size());
  std::vector<viz::Surface> surfaces(objects.size());
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  std::size_t triangles = 0;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const Object& o = objects[i];
    positions[i] = o.mesh.positions.colwise() + offsets[i];
    viz::Surface& s = surfaces[i];
    s.positions = &positions[i];
    const Topology topo = build_topology(o.mesh.tets, o.mesh.num_nodes());
    s.triangles = topo.boundary_faces;
    triangles += s.triangles.size();
    s.base_color = kPalette[i % kPalette.size()];
    s.wireframe = args.wireframe;
    if (!args.field.empty()) {
      s.scalar = field_values(o, positions[i], args.field);
      if (s.scalar.empty())
        return report_error(Error{ErrorCode::kInvalidArgument,
                                  args.files[i] + ": no point field '" + args.field + "'"});
      s.scalar_name = args.field;
      for (const Index v : topo.boundary_nodes) {
        const double x = s.scalar[static_cast<std::size_t>(v)];
        if (std::isfinite(x)) lo = std::min(lo, x), hi = std::max(hi, x);
      }
    }
  }
  // One colour range shared by all objects.
  if (!args.field.empty()) {
    if (fixed_range) lo = range_lo, hi = range_hi;
    if (!(hi >= lo)) lo = 0, hi = 1;
    if (hi == lo) hi = lo + 1;
    for (auto& s : surfaces) s.scalar_min = lo, s.scalar_max = hi;
  }
  const viz::Camera camera = viz::fit_camera(surfaces, view_dir, width, height);
  viz::RenderOptions options;
  options.title = args.title;
  const auto render_start = std::chrono::steady_clock::now();
  const viz::Image image = viz::render(surfaces, camera, options);
  const double render_ms = elapsed_ms(render_start);
  const Status st = viz::write_png(image, args.out);
  if (!st) return report_error(st.error().message, kExitFailure);
  std::fprintf(
      stderr, "wrote %s (%dx%d, %zu objects, %zu triangles, render %.1f ms, total %.1f ms)\n",
      args.out.c_str(), width, height, objects.size(), triangles, render_ms, elapsed_ms(start));
  return kExitOk;
}

}  // namespace

void add_render_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<RenderArgs>();
  auto* cmd = app.add_subcommand("render", "Draw the boundary of meshes into a PNG (headless)");
  cmd->add_option("FILE", args->files, "Mesh files (.msh, .node/.ele, .vtu from this project)")
      ->required();
  cmd->add_option("--out", args->out, "Output PNG file")->required();
  cmd->add_option("--field", args->field,
                  "Colour by a point field: a .vtu field name, or x, y, z, quality");
  cmd->add_option("--view", args->view, "View direction X Y Z (from the eye toward the scene)")
      ->expected(3);
  cmd->add_option("--size", args->size, "Image size WxH (default 1024x768)");
  cmd->add_flag("--wireframe", args->wireframe, "Draw the boundary triangles' edges");
  cmd->add_option("--offset", args->offsets,
                  "Translate the k-th file by X,Y,Z (repeat, in file order)")
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_option("--range", args->range, "Colour range MIN,MAX (default: the data's range)");
  cmd->add_option("--title", args->title, "Title drawn top-left");
  cmd->callback([&ctx, args] { ctx.exit_code = run_render(*args); });
}

}  // namespace tc::cli
