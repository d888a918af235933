// The demo's frame loop without DDS: SceneRun against a fake service that answers a
// penalty floor z = 0 (forces, and blocks unless told not to). An ellipsoid dropped on it
// lands without gaining energy; forces without blocks stop an implicit run with the
// message telling how to enable them; the run's verdict (run_failures) names rejected
// states, inverted tets, NaN and an energy rise above 5 %.
#include <gtest/gtest.h>

#include <map>

#include "scene_file.hpp"
#include "scene_run.hpp"

namespace tc::sim {
namespace {

const std::filesystem::path kRoot = TC_SOURCE_DIR;

/// Answers every moving object with the floor's penalty forces (k per node, N/m).
class FloorService final : public ContactService {
 public:
  explicit FloorService(double k, bool blocks) : k_(k), blocks_(blocks) {}
  Expected<std::map<std::string, ContactAnswer>> exchange(
      std::int64_t, const std::vector<StateView>& states) override {
    std::map<std::string, ContactAnswer> out;
    for (const auto& s : states) {
      ContactAnswer a;
      for (Eigen::Index i = 0; i < s.positions->cols(); ++i) {
        const double z = (*s.positions)(2, i);
        if (z >= 0.0) continue;
        a.nodes.push_back(static_cast<std::int32_t>(i));
        a.forces.insert(a.forces.end(), {0.0, 0.0, -k_ * z});
        if (blocks_) a.stiffness.insert(a.stiffness.end(), {0, 0, 0, 0, 0, 0, 0, 0, -k_});
      }
      out[*s.object] = std::move(a);
    }
    ++exchanges;
    return out;
  }
  Status reregister(const std::string&, const TetMesh&) override {
    ++reregistered;
    return {};
  }
  int exchanges = 0;
  int reregistered = 0;

 private:
  double k_;
  bool blocks_;
};

SceneSpec drop_scene() {
  auto s = parse_scene(
      "version: 1\nname: drop\ndt: 0.001\nnewton_iterations: 1\nobjects:\n"
      "  - name: e\n    mesh: data/meshes/ellipsoid.msh\n    translate: [0, 0, 0.08]\n"
      "    velocity: [0, 0, -0.5]\n"
      "    material: {density: 1000, young: 1.0e6, poisson: 0.3, damping: 1.0}\n",
      "drop.yaml", {kRoot});
  EXPECT_TRUE(s) << s.error().message;
  return *s;
}

TEST(SceneRun, ADroppedBodyLandsOnTheServiceFloorWithoutGainingEnergy) {
  auto run = SceneRun::create(drop_scene());
  ASSERT_TRUE(run) << run.error().message;
  FloorService floor(1e5, true);
  std::size_t contact_frames = 0;
  for (int f = 0; f < 300; ++f) {
    ASSERT_TRUE(run->exchange(floor, f, SceneRun::Probe::kNo));
    contact_frames += run->books().contacts > 0 ? 1 : 0;
    const auto cut = run->advance(floor, f);
    ASSERT_TRUE(cut);
    EXPECT_TRUE(cut->empty());
  }
  const RunBooks& b = run->books();
  EXPECT_EQ(floor.exchanges, 300);
  EXPECT_GT(contact_frames, 10u);  // it lands (and bounces: 27 contact frames)
  EXPECT_EQ(b.frames, 300u);
  EXPECT_LE(b.energy_max, b.energy_initial);
  EXPECT_LT(b.energy_final, b.energy_initial);
  EXPECT_EQ(b.inverted_tets, 0u);
  EXPECT_EQ(b.step_failures, 0u);
  EXPECT_TRUE(run_failures(b).empty());
  // Not sunk through the floor, and not thrown off: above -1 mm, below its start.
  const auto& x = run->objects()[0].positions();
  EXPECT_GT(x.row(2).minCoeff(), -1e-3);
  EXPECT_LT(x.row(2).minCoeff(), 0.08);
}

TEST(SceneRun, AShellSphereLandsOnTheServiceFloorWithoutGainingEnergy) {
  auto spec = parse_scene(
      "version: 1\nname: drop\ndt: 0.0005\nnewton_iterations: 2\nobjects:\n"
      "  - name: s\n    mesh: data/meshes/sphere_shell.obj\n    translate: [0, 0, 0.21]\n"
      "    velocity: [0, 0, -1]\n"
      "    shell: {mass: 4, stretch: 4.0e3, pressure: 1.0e4, damping: 5.0}\n",
      "drop.yaml", {kRoot});
  ASSERT_TRUE(spec) << spec.error().message;
  auto run = SceneRun::create(*spec);
  ASSERT_TRUE(run) << run.error().message;
  ASSERT_EQ(run->objects().size(), 1u);
  const SimObject& o = run->objects()[0];
  ASSERT_TRUE(o.shell.has_value());
  ASSERT_NE(o.surface(), nullptr);
  EXPECT_TRUE(o.mesh().tets.empty());
  FloorService floor(1e6, true);
  std::size_t contact_frames = 0;
  double lowest = 1.0;
  double smallest_volume = o.shell->rest_volume();
  for (int f = 0; f < 250; ++f) {
    ASSERT_TRUE(run->exchange(floor, f, SceneRun::Probe::kIfContact));
    contact_frames += run->books().contacts > 0 ? 1 : 0;
    ASSERT_TRUE(run->advance(floor, f));
    lowest = std::min(lowest, o.positions().row(2).minCoeff());
    smallest_volume = std::min(smallest_volume, o.shell->volume());
  }
  const RunBooks& b = run->books();
  EXPECT_GT(contact_frames, 100u);
  EXPECT_LE(b.energy_max, b.energy_initial);
  EXPECT_EQ(b.step_failures, 0u);
  EXPECT_EQ(b.first_non_finite_frame, -1);
  EXPECT_TRUE(run_failures(b).empty());
  // The landing (from 1 m/s onto 1e6 N/m per vertex) stops the sphere within a few
  // millimetres, squeezes its gas and brakes it: it leaves with less than it came with.
  EXPECT_GT(b.peak_contact_force.at("s"), 4 * 9.81);
  EXPECT_GT(lowest, -0.003);
  EXPECT_LT(smallest_volume, 0.99 * o.shell->rest_volume());
  EXPECT_LT(b.kinetic_final, 0.5 * b.kinetic_max);
}

TEST(SceneRun, ForcesWithoutBlocksStopAnImplicitRun) {
  auto run = SceneRun::create(drop_scene());
  ASSERT_TRUE(run);
  FloorService floor(1e5, false);
  Status st;
  int f = 0;
  for (; f < 300 && st; ++f) {
    st = run->exchange(floor, f, SceneRun::Probe::kNo);
    if (st) {
      ASSERT_TRUE(run->advance(floor, f));
    }
  }
  ASSERT_FALSE(st) << "the floor was never reached";
  EXPECT_GT(f, 1);
  EXPECT_NE(st.error().message.find("without stiffness blocks"), std::string::npos);
  EXPECT_NE(st.error().message.find("compute_stiffness: true"), std::string::npos);
}

TEST(SceneRun, RunFailuresNameEachReason) {
  RunBooks b;
  b.energy_initial = 100.0;
  b.energy_max = 104.9;
  EXPECT_TRUE(run_failures(b).empty());
  b.energy_max = 105.1;
  ASSERT_EQ(run_failures(b).size(), 1u);
  EXPECT_NE(run_failures(b)[0].find("rose 5.1 %"), std::string::npos) << run_failures(b)[0];
  b.energy_max = std::numeric_limits<double>::infinity();
  EXPECT_EQ(run_failures(b).size(), 1u);
  b.energy_max = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(run_failures(b).size(), 1u);
  b.energy_max = 100.0;
  b.rejected = 3;
  b.first_rejection = "torus at frame 7: invalid_mesh";
  b.inverted_tets = 2;
  b.first_inverted_frame = 6;
  b.first_non_finite_frame = 9;
  const auto f = run_failures(b);
  ASSERT_EQ(f.size(), 3u);
  EXPECT_NE(f[0].find("rejected 3 states (first: torus at frame 7"), std::string::npos);
  EXPECT_NE(f[1].find("NaN or infinite at frame 9"), std::string::npos);
  EXPECT_NE(f[2].find("2 tets inverted (first at frame 6)"), std::string::npos);
  // Negative initial energy (gravity from the origin): the rise is relative to |E0|.
  RunBooks n;
  n.energy_initial = -50.0;
  n.energy_max = -48.0;  // +4 %
  EXPECT_TRUE(run_failures(n).empty());
  n.energy_max = -47.0;  // +6 %
  EXPECT_EQ(run_failures(n).size(), 1u);
}

}  // namespace
}  // namespace tc::sim
