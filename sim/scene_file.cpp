#include "scene_file.hpp"

#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <fstream>
#include <random>
#include <set>
#include <sstream>

#include "core/depth/depth_solver.hpp"
#include "core/io/mesh_io.hpp"
#include "core/io/surface_io.hpp"
#include "core/response/penalty.hpp"

namespace tc::sim {
namespace {

/// Thrown inside the parser, turned into an Error at the boundary.
struct ParseFailure {
  ErrorCode code;
  std::string message;
};

class Parser {
 public:
  Parser(std::string where, std::vector<std::filesystem::path> search)
      : where_(std::move(where)), search_(std::move(search)) {}

  [[noreturn]] void fail(const YAML::Node& node, const std::string& message,
                         ErrorCode code = ErrorCode::kInvalidArgument) const {
    std::string at = where_;
    if (node.IsDefined() && node.Mark().line >= 0) at += ":" + std::to_string(node.Mark().line + 1);
    throw ParseFailure{code, at + ": " + message};
  }

  void check_keys(const YAML::Node& map, const std::set<std::string>& allowed,
                  const std::string& what) const {
    if (!map.IsMap()) fail(map, what + " must be a mapping");
    for (const auto& kv : map) {
      const auto key = kv.first.as<std::string>();
      if (allowed.count(key) == 0) fail(kv.first, "unknown key '" + key + "' in " + what);
    }
  }

  template <typename T>
  T get(const YAML::Node& map, const std::string& key, T fallback) const {
    const YAML::Node n = map[key];
    if (!n.IsDefined() || n.IsNull()) return fallback;
    try {
      return n.as<T>();
    } catch (const YAML::Exception&) {
      fail(n, "'" + key + "' has the wrong type");
    }
  }

  double number(const YAML::Node& map, const std::string& key, double fallback, double lo,
                double hi) const {
    const double v = get<double>(map, key, fallback);
    if (!(v >= lo && v <= hi))
      fail(map[key], "'" + key + "' = " + std::to_string(v) + " is outside [" + std::to_string(lo) +
                         ", " + std::to_string(hi) + "]");
    return v;
  }

  Eigen::Vector3d vec3(const YAML::Node& map, const std::string& key,
                       const Eigen::Vector3d& fallback) const {
    const YAML::Node n = map[key];
    if (!n.IsDefined() || n.IsNull()) return fallback;
    if (!n.IsSequence() || n.size() != 3) fail(n, "'" + key + "' must be a list of 3 numbers");
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) {
      try {
        v[i] = n[static_cast<std::size_t>(i)].as<double>();
      } catch (const YAML::Exception&) {
        fail(n, "'" + key + "' must be a list of 3 numbers");
      }
      if (!std::isfinite(v[i])) fail(n, "'" + key + "' must be finite");
    }
    return v;
  }

  std::filesystem::path resolve(const YAML::Node& node, const std::string& file) const {
    const std::filesystem::path p(file);
    if (p.is_absolute()) {
      if (std::filesystem::exists(p)) return p;
    } else {
      for (const auto& dir : search_)
        if (std::filesystem::exists(dir / p)) return dir / p;
    }
    // Appended piece by piece: GCC 12 reports a false -Wrestrict on chained operator+.
    std::ostringstream msg;
    msg << "mesh '" << file << "' not found (tried";
    for (const auto& dir : search_) msg << ' ' << (dir / p).string();
    msg << ')';
    fail(node, msg.str(), ErrorCode::kIo);
  }

  ObjectSpec object(const YAML::Node& n, bool in_rain) const {
    check_keys(n,
               {"name", "mesh", "static", "translate", "rotate_deg", "scale", "velocity",
                "material", "shell", "contact", "fix_border", "tear_strain", "color"},
               "object");
    ObjectSpec o;
    o.name = get<std::string>(n, "name", "");
    if (o.name.empty() || o.name.size() > (in_rain ? 120u : 128u))
      fail(n, "an object needs a 'name' of 1..128 bytes");
    const auto mesh = get<std::string>(n, "mesh", "");
    if (mesh.empty()) fail(n, "object '" + o.name + "' needs a 'mesh'");
    o.mesh = resolve(n["mesh"], mesh);
    o.is_static = get<bool>(n, "static", false);
    o.translate = vec3(n, "translate", o.translate);
    o.rotate_deg = vec3(n, "rotate_deg", o.rotate_deg);
    o.scale = number(n, "scale", 1.0, 1e-6, 1e6);
    o.velocity = vec3(n, "velocity", o.velocity);
    o.color = vec3(n, "color", o.color);
    o.fix_border = number(n, "fix_border", 0.0, 0.0, 1e6);
    o.tear_strain = number(n, "tear_strain", 0.0, 0.0, 100.0);
    if (const YAML::Node m = n["material"]; m.IsDefined()) {
      check_keys(m, {"density", "young", "poisson", "damping"}, "material");
      o.material.density = number(m, "density", o.material.density, 1e-3, 1e6);
      o.material.young = number(m, "young", o.material.young, 1.0, 1e12);
      o.material.poisson = number(m, "poisson", o.material.poisson, 0.0, 0.49);
      o.material.damping = number(m, "damping", o.material.damping, 0.0, 1e4);
    }
    if (const YAML::Node sh = n["shell"]; sh.IsDefined()) {
      if (in_rain) fail(sh, "a rain object cannot be a shell");
      for (const char* k : {"material", "static", "fix_border", "tear_strain"})
        if (n[k].IsDefined())
          fail(n[k], "object '" + o.name + "' is a shell: '" + k + "' does not apply to it");
      check_keys(sh, {"mass", "stretch", "pressure", "damping"}, "shell");
      ShellMaterial m;
      m.mass = number(sh, "mass", m.mass, 1e-6, 1e6);
      m.stretch = number(sh, "stretch", m.stretch, 1e-3, 1e12);
      m.pressure = number(sh, "pressure", m.pressure, 0.0, 1e9);
      m.damping = number(sh, "damping", m.damping, 0.0, 1e4);
      o.shell = m;
    }
    if (const YAML::Node c = n["contact"]; c.IsDefined()) {
      check_keys(c,
                 {"stiffness", "damping", "max_force", "depth", "response", "friction",
                  "friction_velocity", "self_contact"},
                 "contact");
      o.contact.self_contact = get<bool>(c, "self_contact", false);
      if (o.contact.self_contact && o.shell)
        fail(c["self_contact"],
             "'self_contact' needs a tet object: a shell is a surface object, which has no "
             "depth map to push its own nodes out of");
      o.contact.friction = number(c, "friction", o.contact.friction, 0.0, 1e3);
      o.contact.friction_velocity =
          number(c, "friction_velocity", o.contact.friction_velocity, 0.0, 1e3);
      o.contact.stiffness = number(c, "stiffness", o.contact.stiffness, 1e-12, 1e12);
      o.contact.damping = number(c, "damping", o.contact.damping, 0.0, 1e12);
      o.contact.max_force = number(c, "max_force", o.contact.max_force, 0.0, 1e12);
      o.contact.depth = get<std::string>(c, "depth", o.contact.depth);
      o.contact.response = get<std::string>(c, "response", o.contact.response);
      if (!parse_depth_method(o.contact.depth))
        fail(c["depth"], "'depth' must be cpfm, cffm or exact");
      if (!parse_response_kind(o.contact.response))
        fail(c["response"], "'response' must be point, segment or auto");
    }
    return o;
  }

  SceneSpec scene(const YAML::Node& root) const {
    if (!root.IsMap()) fail(root, "a scene file is a mapping (version, name, objects, ...)");
    check_keys(root,
               {"version",
                "name",
                "description",
                "dt",
                "integrator",
                "substeps",
                "newton_iterations",
                "linear_solver",
                "frames",
                "gravity",
                "output_every",
                "render_frames",
                "image",
                "camera",
                "objects",
                "rain",
                "check",
                "max_energy_rise",
                "self_penetration_probe",
                "max_self_penetration"},
               "the scene");
    if (get<int>(root, "version", 0) != 1) fail(root["version"], "'version: 1' is required");
    SceneSpec s;
    s.name = get<std::string>(root, "name", "");
    if (s.name.empty() || s.name.size() > 64) fail(root, "'name' must have 1..64 bytes");
    for (const char c : s.name)
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'))
        fail(root["name"], "'name' may hold letters, digits, '_' and '-' only");
    s.description = get<std::string>(root, "description", "");
    s.dt = number(root, "dt", s.dt, 1e-6, 0.1);
    s.integrator = get<std::string>(root, "integrator", s.integrator);
    if (s.integrator != "implicit" && s.integrator != "explicit")
      fail(root["integrator"], "'integrator' must be implicit or explicit");
    s.substeps = static_cast<int>(number(root, "substeps", s.substeps, 1, 1000));
    s.newton_iterations =
        static_cast<int>(number(root, "newton_iterations", s.newton_iterations, 1, 100));
    s.linear_solver = get<std::string>(root, "linear_solver", s.linear_solver);
    if (s.linear_solver != "cg" && s.linear_solver != "ldlt")
      fail(root["linear_solver"], "'linear_solver' must be cg or ldlt");
    s.frames = static_cast<int>(number(root, "frames", s.frames, 1, 1e7));
    s.gravity = vec3(root, "gravity", s.gravity);
    s.output_every = static_cast<int>(number(root, "output_every", s.output_every, 1, 1e7));
    if (const YAML::Node r = root["render_frames"]; r.IsDefined()) {
      if (!r.IsSequence()) fail(r, "'render_frames' must be a list of frame numbers");
      for (const auto& f : r) {
        int v = -1;
        try {
          v = f.as<int>();
        } catch (const YAML::Exception&) {
          fail(f, "'render_frames' must be a list of frame numbers");
        }
        if (v < 0) fail(f, "'render_frames' must be >= 0");
        s.render_frames.push_back(v);
      }
    }
    if (const YAML::Node im = root["image"]; im.IsDefined()) {
      check_keys(im, {"width", "height"}, "image");
      s.image_width = static_cast<int>(number(im, "width", s.image_width, 16, 4096));
      s.image_height = static_cast<int>(number(im, "height", s.image_height, 16, 4096));
    }
    if (const YAML::Node c = root["camera"]; c.IsDefined()) {
      check_keys(c, {"eye", "target", "up", "fov_deg"}, "camera");
      s.camera.set = true;
      s.camera.eye = vec3(c, "eye", s.camera.eye);
      s.camera.target = vec3(c, "target", s.camera.target);
      s.camera.up = vec3(c, "up", s.camera.up);
      s.camera.fov_deg = number(c, "fov_deg", s.camera.fov_deg, 1.0, 170.0);
    }
    const YAML::Node objects = root["objects"];
    if (!objects.IsDefined() || !objects.IsSequence() || objects.size() == 0)
      fail(root, "'objects' must be a non-empty list");
    for (const auto& o : objects) s.objects.push_back(object(o, false));
    if (const YAML::Node r = root["rain"]; r.IsDefined()) {
      check_keys(r, {"object", "count", "region_min", "region_max", "seed"}, "rain");
      RainSpec rain;
      if (!r["object"].IsDefined()) fail(r, "'rain' needs an 'object'");
      rain.object = object(r["object"], true);
      rain.count = static_cast<int>(number(r, "count", 0, 1, 1000));
      rain.region_min = vec3(r, "region_min", rain.region_min);
      rain.region_max = vec3(r, "region_max", rain.region_max);
      rain.seed = static_cast<std::uint64_t>(number(r, "seed", 1, 0, 1e15));
      if (!(rain.region_min.array() <= rain.region_max.array()).all())
        fail(r, "'region_min' must be <= 'region_max'");
      // The copies' bounding spheres (about the mesh origin, which rotation keeps).
      if (auto mesh = read_mesh(rain.object.mesh); mesh) {
        for (Eigen::Index n = 0; n < mesh->positions.cols(); ++n)
          rain.radius = std::max(rain.radius, mesh->positions.col(n).norm());
        rain.radius *= rain.object.scale;
      } else {
        fail(r["object"]["mesh"], mesh.error().message, mesh.error().code);
      }
      // Deterministic drops: the same seed gives the same rain on every machine
      // (mt19937_64 is specified; the doubles are made from its integers here). A
      // candidate place closer than 2 radii to an earlier drop is rejected (up to
      // kAttempts candidates per drop), so no two copies start overlapping.
      std::mt19937_64 rng(rain.seed);
      const auto unit = [&] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
      constexpr int kAttempts = 10000;
      std::vector<Eigen::Vector3d> placed;
      for (int i = 0; i < rain.count; ++i) {
        ObjectSpec o = rain.object;
        char suffix[16];
        std::snprintf(suffix, sizeof suffix, "_%03d", i);
        o.name = rain.object.name + suffix;
        bool free = false;
        for (int attempt = 0; attempt < kAttempts && !free; ++attempt) {
          for (int k = 0; k < 3; ++k)
            o.translate[k] =
                rain.region_min[k] + unit() * (rain.region_max[k] - rain.region_min[k]);
          free = std::all_of(placed.begin(), placed.end(), [&](const Eigen::Vector3d& p) {
            return (p - o.translate).norm() >= 2.0 * rain.radius;
          });
        }
        if (!free)
          fail(r, "the rain region cannot hold " + std::to_string(rain.count) +
                      " copies without overlaps (bounding radius " + std::to_string(rain.radius) +
                      " m); enlarge it or lower 'count'");
        placed.push_back(o.translate);
        for (int k = 0; k < 3; ++k) o.rotate_deg[k] = 360.0 * unit();
        s.objects.push_back(o);
      }
      s.rain = rain;
    }
    std::set<std::string> names;
    for (const auto& o : s.objects)
      if (!names.insert(o.name).second) fail(root, "object name '" + o.name + "' is repeated");
    s.max_energy_rise = number(root, "max_energy_rise", s.max_energy_rise, 0.0, 1e3);
    s.self_penetration_probe = get<bool>(root, "self_penetration_probe", false);
    s.max_self_penetration = number(root, "max_self_penetration", 0.0, 0.0, 1e3);
    if (const YAML::Node c = root["check"]; c.IsDefined()) {
      check_keys(c, {"kind", "object", "support", "from_s", "window_s", "max_drift_m", "tolerance"},
                 "check");
      FrictionCheck check;
      check.kind = get<std::string>(c, "kind", "");
      if (check.kind != "stick" && check.kind != "slide" && check.kind != "skid")
        fail(c, "check 'kind' must be stick, slide or skid");
      check.object = get<std::string>(c, "object", "");
      check.support = get<std::string>(c, "support", "");
      const auto find = [&](const std::string& name) -> const ObjectSpec* {
        for (const auto& o : s.objects)
          if (o.name == name) return &o;
        return nullptr;
      };
      const ObjectSpec* object = find(check.object);
      const ObjectSpec* support = find(check.support);
      if (object == nullptr || object->is_static)
        fail(c, "check 'object' must name a moving object of the scene");
      if (support == nullptr || !support->is_static)
        fail(c, "check 'support' must name a static object of the scene");
      check.from_s = number(c, "from_s", check.from_s, 0.0, 1e6);
      check.window_s = number(c, "window_s", check.window_s, 1e-6, 1e6);
      check.max_drift_m = number(c, "max_drift_m", check.max_drift_m, 0.0, 1e6);
      check.tolerance = number(c, "tolerance", check.tolerance, 0.0, 1.0);
      s.check = check;
    }
    return s;
  }

 private:
  std::string where_;
  std::vector<std::filesystem::path> search_;
};

}  // namespace

Expected<SceneSpec> parse_scene(const std::string& text, const std::string& where,
                                const std::vector<std::filesystem::path>& search) {
  Parser p(where, search);
  try {
    const YAML::Node root = YAML::Load(text);
    return p.scene(root);
  } catch (const ParseFailure& f) {
    return Error{f.code, f.message};
  } catch (const YAML::Exception& e) {
    return Error{ErrorCode::kParse, where + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg};
  }
}

Expected<SceneSpec> load_scene_file(const std::filesystem::path& path,
                                    const std::vector<std::filesystem::path>& extra_search) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{ErrorCode::kIo, path.string() + ": cannot open the scene file"};
  std::ostringstream text;
  text << in.rdbuf();
  const auto dir = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
  std::vector<std::filesystem::path> search{dir, dir / ".." / ".."};
  search.insert(search.end(), extra_search.begin(), extra_search.end());
  return parse_scene(text.str(), path.string(), search);
}

}  // namespace tc::sim

namespace tc::sim {

Eigen::Matrix3d object_rotation(const ObjectSpec& object) {
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  return (Eigen::AngleAxisd(object.rotate_deg.z() * kDeg, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(object.rotate_deg.y() * kDeg, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(object.rotate_deg.x() * kDeg, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

namespace {

/// Scales, rotates (x, then y, then z, degrees) and translates positions as the object says.
void place(const ObjectSpec& object, Eigen::Matrix3Xd& positions) {
  const Eigen::Matrix3d r = object_rotation(object);
  for (Eigen::Index n = 0; n < positions.cols(); ++n)
    positions.col(n) = r * (object.scale * positions.col(n)) + object.translate;
}

}  // namespace

Expected<TetMesh> load_object_mesh(const ObjectSpec& object) {
  auto mesh = read_mesh(object.mesh);
  if (!mesh) return mesh.error();
  place(object, mesh->positions);
  return mesh;
}

Expected<SurfaceMesh> load_object_surface(const ObjectSpec& object) {
  auto surface = read_surface(object.mesh);
  if (!surface) return surface.error();
  place(object, surface->positions);
  return surface;
}

}  // namespace tc::sim
