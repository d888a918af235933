#include "demo_support.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "core/mesh/topology.hpp"
#include "render.hpp"

#ifndef TC_SOURCE_DIR
#define TC_SOURCE_DIR ""
#endif

namespace tc::cli::demo {

std::filesystem::path exe_dir() {
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::current_path() : self.parent_path();
}

std::vector<std::filesystem::path> data_roots() {
  std::vector<std::filesystem::path> roots{std::filesystem::current_path()};
  if (std::string(TC_SOURCE_DIR).size() > 0) roots.emplace_back(TC_SOURCE_DIR);
  const auto bin = exe_dir();
  roots.push_back(bin / ".." / "..");                    // <repo>/build/bin
  roots.push_back(bin / ".." / "share" / "tetcollide");  // <prefix>/bin
  return roots;
}

std::filesystem::path find_scene_file(const std::string& scene) {
  const std::filesystem::path p(scene);
  if (p.has_extension() || scene.find('/') != std::string::npos)
    return std::filesystem::exists(p) ? p : std::filesystem::path();
  for (const auto& root : data_roots())
    for (const auto& sub : {root / "config" / "scenes", root / "scenes"}) {
      const auto f = sub / (scene + ".yaml");
      if (std::filesystem::exists(f)) return f;
    }
  return {};
}

std::filesystem::path find_cyclonedds_config() {
  for (const auto& root : data_roots())
    for (const auto& f : {root / "config" / "cyclonedds.xml",
                          root / ".." / ".." / "etc" / "tetcollide" / "cyclonedds.xml"})
      if (std::filesystem::exists(f)) return std::filesystem::weakly_canonical(f);
  if (std::filesystem::exists("/etc/tetcollide/cyclonedds.xml"))
    return "/etc/tetcollide/cyclonedds.xml";
  return {};
}

ChildProcess::~ChildProcess() {
  stop();
}

Status ChildProcess::start(const std::vector<std::string>& argv, const std::filesystem::path& log) {
  if (argv.empty() || !std::filesystem::exists(argv[0]))
    return Error{ErrorCode::kIo, "program not found: " + (argv.empty() ? std::string() : argv[0])};
  // The demo's own signal dispositions must not leak into the daemon, and Ctrl-C in the
  // terminal reaches the demo only; the demo stops the daemon.
  return child_.start({.argv = argv,
                       .out = log,
                       .err = log,
                       .parent_death_signal = SIGTERM,
                       .reset_signals = true,
                       .own_process_group = true});
}

bool ChildProcess::alive() {
  return !child_.exited();
}

int ChildProcess::stop(int sig, std::chrono::milliseconds timeout) {
  const std::optional<int> status = child_.stop(sig, timeout);
  return status ? process::exit_code(*status) : -1;
}

Status write_pvd(const std::filesystem::path& path, const std::vector<PvdEntry>& entries) {
  std::ofstream out(path);
  out << "<?xml version=\"1.0\"?>\n"
         "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
         "  <Collection>\n";
  char line[512];
  for (const auto& e : entries) {
    std::snprintf(line, sizeof line,
                  "    <DataSet timestep=\"%.6f\" group=\"\" part=\"0\" file=\"%s\"/>\n", e.time,
                  e.file.c_str());
    out << line;
  }
  out << "  </Collection>\n</VTKFile>\n";
  out.close();
  if (!out) return Error{ErrorCode::kIo, "cannot write " + path.string()};
  return {};
}

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size())));
  return values[std::min(values.size() - 1, rank == 0 ? 0 : rank - 1)];
}

/// What the pictures draw of an object: a tet object's boundary faces, a shell's triangles.
std::vector<std::array<std::int32_t, 3>> boundary_of(const sim::SimObject& o) {
  if (const SurfaceMesh* s = o.surface(); s != nullptr) {
    std::vector<std::array<std::int32_t, 3>> out;
    out.reserve(s->triangles.size());
    for (const Triangle& t : s->triangles)
      out.push_back({static_cast<std::int32_t>(t[0]), static_cast<std::int32_t>(t[1]),
                     static_cast<std::int32_t>(t[2])});
    return out;
  }
  const Topology topo = build_topology(o.mesh().tets, o.mesh().num_nodes());
  return {topo.boundary_faces.begin(), topo.boundary_faces.end()};
}

/// Writes frame `f` of every object into one unstructured grid `out/frame_NNNN.vtu`: point
/// fields depth (m; 0 when not probed), force (N), velocity (m/s), cell field object. The
/// tets of every tet object come first, then the triangles of the shells.
Status write_frame_vtu(const std::vector<sim::SimObject>& objects,
                       const std::vector<std::vector<double>>& depth,
                       const std::filesystem::path& out, int f) {
  TetMesh all;
  std::vector<std::array<Index, 3>> triangles;
  std::vector<double> triangle_object;
  Index total = 0;
  std::size_t tets = 0;
  for (const auto& e : objects) {
    total += static_cast<Index>(e.positions().cols());
    tets += e.mesh().tets.size();
  }
  all.positions.resize(3, total);
  all.tets.reserve(tets);
  VtuField fd{"depth", 1, {}};
  VtuField ff{"force", 3, {}};
  VtuField fv{"velocity", 3, {}};
  VtuField fo{"object", 1, {}};
  Index base = 0;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const auto& e = objects[i];
    const auto& x = e.positions();
    all.positions.middleCols(base, x.cols()) = x;
    for (Eigen::Index n = 0; n < x.cols(); ++n) {
      all.node_ids.push_back(n);
      fd.values.push_back(depth.empty() ? 0.0 : depth[i][static_cast<std::size_t>(n)]);
      for (int k = 0; k < 3; ++k) {
        ff.values.push_back(e.contact(k, n));
        fv.values.push_back(e.velocities()(k, n));
      }
    }
    for (Tet t : e.mesh().tets) {
      for (auto& n : t) n += base;
      all.tets.push_back(t);
      fo.values.push_back(static_cast<double>(i));
    }
    if (const SurfaceMesh* s = e.surface(); s != nullptr)
      for (Triangle t : s->triangles) {
        for (auto& n : t) n += base;
        triangles.push_back(t);
        triangle_object.push_back(static_cast<double>(i));
      }
    base += static_cast<Index>(x.cols());
  }
  fo.values.insert(fo.values.end(), triangle_object.begin(), triangle_object.end());
  char name[32];
  std::snprintf(name, sizeof name, "frame_%04d.vtu", f);
  const std::vector<VtuField> point{fd, ff, fv};
  const std::vector<VtuField> cell{fo};
  return write_vtu(out / name, all, triangles, point, cell);
}

/// Draws the scene's objects at their current positions into `path`.
Status render_frame(const std::vector<sim::SimObject>& objects,
                    const std::vector<std::vector<std::array<std::int32_t, 3>>>& surface,
                    const sim::SceneSpec& scene, int frame, double max_depth_mm,
                    const std::filesystem::path& path) {
  std::vector<viz::Surface> surfaces;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const auto& e = objects[i];
    viz::Surface s;
    s.positions = &e.positions();
    s.triangles = surface[i];
    s.base_color = e.spec.color.cast<float>();
    surfaces.push_back(std::move(s));
  }
  viz::Camera cam;
  if (scene.camera.set) {
    cam.eye = scene.camera.eye;
    cam.target = scene.camera.target;
    cam.up = scene.camera.up;
    cam.fov_deg = scene.camera.fov_deg;
    cam.width = scene.image_width;
    cam.height = scene.image_height;
  } else {
    cam = viz::fit_camera(surfaces, Eigen::Vector3d(-1.0, 1.2, -0.7), scene.image_width,
                          scene.image_height);
  }
  viz::RenderOptions options;
  char title[160];
  std::snprintf(title, sizeof title, "frame %d  t = %.3f s  penetration %.1f mm", frame,
                frame * scene.dt, max_depth_mm);
  options.title = title;
  return viz::write_png(viz::render(surfaces, cam, options), path.string());
}

}  // namespace tc::cli::demo
