// Scene files: the committed scenes parse, the embedded torus-on-box scene is the
// committed file, the rain expands deterministically, and bad files give clear errors
// naming the file, the line and the key.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "scene_file.hpp"

namespace tc::sim {
namespace {

const std::filesystem::path kRoot = TC_SOURCE_DIR;

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

Expected<SceneSpec> parse(const std::string& text) {
  return parse_scene(text, "bad.yaml", {kRoot});
}

const char* kMinimal = R"(version: 1
name: tiny
objects:
  - name: box
    mesh: data/meshes/box.msh
    static: true
)";

TEST(SceneFile, CommittedScenesParse) {
  for (const char* name : {"torus_on_box", "torus_on_box_k1e5", "torus_on_box_k1e6",
                           "torus_on_box_friction", "ellipsoid_rain", "tissue_tear",
                           "sphere_on_tissue", "slope_slide", "slope_stick", "block_skid"}) {
    SCOPED_TRACE(name);
    const auto s = load_scene_file(kRoot / "config" / "scenes" / (std::string(name) + ".yaml"), {});
    ASSERT_TRUE(s) << s.error().message;
    EXPECT_EQ(s->name, name);
    EXPECT_EQ(s->integrator, "implicit");
    EXPECT_GT(s->frames, 0);
    EXPECT_FALSE(s->render_frames.empty());
    for (const auto& o : s->objects) EXPECT_TRUE(std::filesystem::exists(o.mesh)) << o.mesh;
  }
}

TEST(SceneFile, FrictionAndItsCheck) {
  const std::string scene = R"(version: 1
name: slide
max_energy_rise: 0.01
objects:
  - name: ramp
    mesh: data/meshes/box.msh
    static: true
    rotate_deg: [25, 0, 0]
    contact: {stiffness: 1.0e5, friction: 0.3}
  - name: block
    mesh: data/meshes/box.msh
    scale: 0.1
    contact: {stiffness: 1.0e5, friction: 0.4, friction_velocity: 1.0e-4}
check: {kind: slide, object: block, support: ramp, from_s: 0.1}
)";
  const auto s = parse(scene);
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_EQ(s->objects[0].contact.friction, 0.3);
  EXPECT_EQ(s->objects[0].contact.friction_velocity, 0.0);
  EXPECT_EQ(s->objects[1].contact.friction, 0.4);
  EXPECT_EQ(s->objects[1].contact.friction_velocity, 1e-4);
  EXPECT_EQ(s->max_energy_rise, 0.01);
  ASSERT_TRUE(s->check.has_value());
  EXPECT_EQ(s->check->kind, "slide");
  EXPECT_EQ(s->check->from_s, 0.1);
  EXPECT_EQ(s->check->tolerance, 0.05);  // the default
  const auto fails = [&](const std::string& from, const std::string& to, const char* says) {
    std::string text = scene;
    text.replace(text.find(from), from.size(), to);
    const auto bad = parse(text);
    ASSERT_FALSE(bad) << to;
    EXPECT_NE(bad.error().message.find(says), std::string::npos) << bad.error().message;
    EXPECT_NE(bad.error().message.find("bad.yaml:"), std::string::npos) << bad.error().message;
  };
  fails("kind: slide", "kind: roll", "stick, slide or skid");
  fails("support: ramp", "support: block", "'support' must name a static object");
  fails("object: block", "object: ramp", "'object' must name a moving object");
  fails("friction: 0.3}", "friction: -1}", "'friction'");
  fails("from_s: 0.1", "sideways: 1", "unknown key 'sideways' in check");
}

TEST(SceneFile, EmbeddedSceneIsTheCommittedFile) {
  EXPECT_EQ(embedded_torus_on_box(), read_text(kRoot / "config" / "scenes" / "torus_on_box.yaml"));
  const auto s = parse_scene(embedded_torus_on_box(), "embedded", {kRoot});
  ASSERT_TRUE(s) << s.error().message;
  ASSERT_EQ(s->objects.size(), 2u);
  EXPECT_TRUE(s->objects[0].is_static);
  EXPECT_EQ(s->objects[1].name, "torus");
  EXPECT_DOUBLE_EQ(s->objects[1].rotate_deg.x(), 20.0);
}

TEST(SceneFile, DefaultsAndPlacement) {
  const auto s = parse(std::string(kMinimal) +
                       "  - name: t\n    mesh: data/meshes/ellipsoid.msh\n    translate: [1, 2, "
                       "3]\n    rotate_deg: [0, 0, 90]\n    scale: 2\n");
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_EQ(s->dt, 1e-3);
  EXPECT_EQ(s->substeps, 8);
  const auto m = load_object_mesh(s->objects[1]);
  ASSERT_TRUE(m);
  // The ellipsoid's long axis (x, semi-axis 0.05) turned onto y, doubled, moved.
  EXPECT_NEAR(m->positions.row(1).maxCoeff(), 2.0 + 0.1, 1e-3);
  EXPECT_NEAR(m->positions.row(0).maxCoeff(), 1.0 + 0.06, 5e-3);  // faceted
  EXPECT_NEAR(m->positions.row(2).mean(), 3.0, 0.01);
}

TEST(SceneFile, ShellObjectsReadASurfaceAndPlaceIt) {
  const auto s = parse(std::string(kMinimal) +
                       "  - name: sphere\n    mesh: data/meshes/sphere_shell.obj\n    translate: "
                       "[0, 0, 1]\n    scale: 0.5\n    velocity: [0, 0, -2]\n    shell: {mass: "
                       "3, stretch: 5.0e3, pressure: 2.0e4, damping: 0.5}\n");
  ASSERT_TRUE(s) << s.error().message;
  const ObjectSpec& o = s->objects[1];
  ASSERT_TRUE(o.shell.has_value());
  EXPECT_EQ(o.shell->mass, 3.0);
  EXPECT_EQ(o.shell->stretch, 5e3);
  EXPECT_EQ(o.shell->pressure, 2e4);
  EXPECT_EQ(o.shell->damping, 0.5);
  EXPECT_FALSE(s->objects[0].shell.has_value());
  const auto m = load_object_surface(o);
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_EQ(m->num_nodes(), 642);
  EXPECT_NEAR(m->positions.row(2).maxCoeff(), 1.1, 1e-9);  // radius 0.2 halved, moved up
  // A tet mesh is no shell: the surface reader says what the file holds.
  auto tets = o;
  tets.mesh = kRoot / "data/meshes/box.msh";
  const auto bad = load_object_surface(tets);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("box.msh"), std::string::npos) << bad.error().message;
}

TEST(SceneFile, RainIsDeterministic) {
  const auto a = load_scene_file(kRoot / "config" / "scenes" / "ellipsoid_rain.yaml", {});
  const auto b = load_scene_file(kRoot / "config" / "scenes" / "ellipsoid_rain.yaml", {});
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->rain);
  ASSERT_EQ(a->objects.size(), 1u + static_cast<std::size_t>(a->rain->count));
  EXPECT_EQ(a->objects[1].name, "ellipsoid_000");
  for (std::size_t i = 1; i < a->objects.size(); ++i) {
    EXPECT_EQ(a->objects[i].translate, b->objects[i].translate);
    EXPECT_TRUE((a->objects[i].translate.array() >= a->rain->region_min.array()).all());
    EXPECT_TRUE((a->objects[i].translate.array() <= a->rain->region_max.array()).all());
  }
  EXPECT_NE(a->objects[1].translate, a->objects[2].translate);
}

TEST(SceneFile, RainCopiesDoNotOverlap) {
  const auto s = load_scene_file(kRoot / "config" / "scenes" / "ellipsoid_rain.yaml", {});
  ASSERT_TRUE(s && s->rain);
  const double r = s->rain->radius;
  ASSERT_GT(r, 0.0);
  // The radius bounds every placed mesh about its translation, and no two bounding
  // spheres meet, so no two copies overlap.
  for (std::size_t i = 1; i < s->objects.size(); ++i) {
    const auto m = load_object_mesh(s->objects[i]);
    ASSERT_TRUE(m);
    const Eigen::Matrix3Xd rel = m->positions.colwise() - s->objects[i].translate;
    EXPECT_LE(rel.colwise().norm().maxCoeff(), r * (1.0 + 1e-12));
  }
  for (std::size_t i = 1; i < s->objects.size(); ++i)
    for (std::size_t j = i + 1; j < s->objects.size(); ++j)
      EXPECT_GE((s->objects[i].translate - s->objects[j].translate).norm(), 2.0 * r)
          << s->objects[i].name << " " << s->objects[j].name;
  // A region too small for the count is a clear error.
  const auto crowded = parse_scene(
      "version: 1\nname: crowd\nobjects:\n  - {name: box, mesh: data/meshes/box.msh, static: "
      "true}\nrain:\n  count: 20\n  region_min: [0, 0, 0]\n  region_max: [0.1, 0.1, 0.1]\n"
      "  object: {name: e, mesh: data/meshes/ellipsoid.msh}\n",
      "crowd.yaml", {kRoot});
  ASSERT_FALSE(crowded);
  EXPECT_NE(crowded.error().message.find("without overlaps"), std::string::npos)
      << crowded.error().message;
}

struct BadCase {
  const char* what;
  std::string text;
  ErrorCode code;
  const char* expect;  // in the message
};

class SceneFileErrors : public ::testing::TestWithParam<BadCase> {};

TEST_P(SceneFileErrors, AreClear) {
  const auto& c = GetParam();
  const auto s = parse(c.text);
  ASSERT_FALSE(s) << c.what;
  EXPECT_EQ(s.error().code, c.code) << s.error().message;
  EXPECT_NE(s.error().message.find(c.expect), std::string::npos) << s.error().message;
  EXPECT_EQ(s.error().message.rfind("bad.yaml", 0), 0u) << s.error().message;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, SceneFileErrors,
    ::testing::Values(
        BadCase{"not yaml", "version: 1\nobjects: [\n", ErrorCode::kParse, "bad.yaml:"},
        BadCase{"no version", "name: x\nobjects: []\n", ErrorCode::kInvalidArgument,
                "'version: 1' is required"},
        BadCase{"unknown key", std::string(kMinimal) + "    colour: [1, 0, 0]\n",
                ErrorCode::kInvalidArgument, "bad.yaml:7: unknown key 'colour' in object"},
        BadCase{"missing mesh",
                "version: 1\nname: x\nobjects:\n  - name: a\n    mesh: nowhere.msh\n",
                ErrorCode::kIo, "mesh 'nowhere.msh' not found"},
        BadCase{"dt out of range", "version: 1\nname: x\ndt: 5\nobjects: []\n",
                ErrorCode::kInvalidArgument, "'dt' = 5"},
        BadCase{"no objects", "version: 1\nname: x\n", ErrorCode::kInvalidArgument,
                "'objects' must be a non-empty list"},
        BadCase{"bad vector", std::string(kMinimal) + "    translate: [1, 2]\n",
                ErrorCode::kInvalidArgument, "'translate' must be a list of 3 numbers"},
        BadCase{"wrong type", std::string(kMinimal) + "    scale: big\n",
                ErrorCode::kInvalidArgument, "'scale' has the wrong type"},
        BadCase{"bad name", "version: 1\nname: a b\nobjects: []\n", ErrorCode::kInvalidArgument,
                "'name' may hold"},
        BadCase{"repeated object", std::string(kMinimal) + std::string(kMinimal).substr(31),
                ErrorCode::kInvalidArgument, "repeated"},
        BadCase{"bad depth", std::string(kMinimal) + "    contact: {depth: magic}\n",
                ErrorCode::kInvalidArgument, "'depth' must be cpfm, cffm or exact"},
        BadCase{"static shell", std::string(kMinimal) + "    shell: {mass: 1}\n",
                ErrorCode::kInvalidArgument,
                "bad.yaml:6: object 'box' is a shell: 'static' does not apply to it"},
        BadCase{"shell with a material",
                "version: 1\nname: x\nobjects:\n  - name: s\n    mesh: "
                "data/meshes/sphere_shell.obj\n    material: {density: 1}\n    shell: {mass: 1}\n",
                ErrorCode::kInvalidArgument, "'material' does not apply to it"},
        BadCase{"shell key",
                "version: 1\nname: x\nobjects:\n  - name: s\n    mesh: "
                "data/meshes/sphere_shell.obj\n    shell: {mas: 1}\n",
                ErrorCode::kInvalidArgument, "unknown key 'mas' in shell"},
        BadCase{"shell mass",
                "version: 1\nname: x\nobjects:\n  - name: s\n    mesh: "
                "data/meshes/sphere_shell.obj\n    shell: {mass: -1}\n",
                ErrorCode::kInvalidArgument, "'mass' = -1"}));

TEST(SceneFile, MissingFileIsAnIoError) {
  const auto s = load_scene_file(kRoot / "config" / "scenes" / "no_such_scene.yaml", {});
  ASSERT_FALSE(s);
  EXPECT_EQ(s.error().code, ErrorCode::kIo);
  EXPECT_NE(s.error().message.find("no_such_scene.yaml"), std::string::npos);
}

}  // namespace
}  // namespace tc::sim
