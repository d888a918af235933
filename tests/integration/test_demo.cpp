// `tetcollide demo` against the real daemon: the torus-on-box scene run in isolation with
// --spawn-daemon writes every output and a sane summary that agrees with the FrameStats
// topic; at contact stiffness 1e6 the implicit integrator stays stable (no rejected state,
// no inverted tet, no energy gain, penetration under 2 mm); a daemon that sends no
// stiffness blocks is a clear error; the recordings of the demo scenes (tests/data/recordings/demo)
// replay bit for bit against a fresh daemon, including the tissue's topology versions mid-run;
// the triangle shell sphere (a surface object) is held by the tissue it tears.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>

#include "daemon_process.hpp"
#include "recording.hpp"
#include "sanitizer.hpp"

namespace tc::itest {
namespace {

using namespace std::chrono_literals;

std::filesystem::path demo_recordings() {
  const auto d = recordings_dir();
  return d.empty() ? d : d / "demo";
}

bool finite_everywhere(const nlohmann::json& j) {
  if (j.is_number_float()) return std::isfinite(j.get<double>());
  if (j.is_structured())
    for (const auto& v : j)
      if (!finite_everywhere(v)) return false;
  return true;
}

TEST(DemoTest, TorusOnBoxWritesOutputsAndASaneSummary) {
  const auto dir = make_temp_dir("itest-demo");
  const auto out = dir / "out";
  const int frames = 120;  // the torus touches the box near frame 60
  const auto r = run_program(
      {program_from_env("TC_CLI"), "demo", "torus_on_box", "--frames", std::to_string(frames),
       "--spawn-daemon", "--domain", std::to_string(private_domain()), "--out", out.string()},
      // 3-10 s in Release; 60-100 s with an ASan client and daemon sharing 2 cores.
      test::kSanitized ? 300s : 90s);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  // The human summary names the outputs.
  EXPECT_NE(r.out.find("outputs in"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("max penetration"), std::string::npos) << r.out;
  std::ifstream in(out / "summary.json");
  ASSERT_TRUE(in) << "no summary.json";
  const auto s = nlohmann::json::parse(in);
  EXPECT_TRUE(finite_everywhere(s)) << s.dump(2);
  EXPECT_EQ(s["frames"].get<int>(), frames);
  // Every frame's statistics came over the FrameStats topic.
  EXPECT_EQ(s["frame_stats_received"].get<int>(), frames);
  EXPECT_EQ(s["rejected_states"].get<int>(), 0);
  // Lock-step: nothing is superseded. Under a sanitizer (TSan: 5-15x slower) a frame can
  // take longer than the client's 0.5 s resend interval; each re-sent copy of the frame
  // is queued behind the one being computed, and a third copy drops the oldest queued
  // one (max_queued_frames 2), as designed. Seen once in 160 frames under TSan.
  if (test::kSanitized)
    EXPECT_LE(s["dropped_frames"].get<int>(), 5);
  else
    EXPECT_EQ(s["dropped_frames"].get<int>(), 0);
  // The torus reached the box and stayed out of it.
  EXPECT_GT(s["max_contacts"].get<int>(), 0);
  EXPECT_GT(s["service_max_depth_m"].get<double>(), 0.0);
  EXPECT_LT(s["max_penetration_m"].get<double>(), 0.020);
  EXPECT_EQ(s["inverted_tets"].get<int>(), 0);
  EXPECT_EQ(s["integrator"].get<std::string>(), "implicit");
  // Mechanical energy: never above its initial value (backward Euler and the damping
  // only remove energy), lower at the end.
  const auto& e = s["energy_j"];
  EXPECT_LE(e["max"].get<double>(), 1.01 * e["initial"].get<double>()) << e.dump();
  EXPECT_LT(e["final"].get<double>(), e["initial"].get<double>()) << e.dump();
  EXPECT_FALSE(s.contains("energy_drift_j"));
  for (const char* stage : {"round_trip", "broad", "narrow", "depth", "response", "compute"}) {
    const auto& st = s["collision_ms"][stage];
    EXPECT_GE(st["p99"].get<double>(), st["p50"].get<double>()) << stage;
    EXPECT_GE(st["p50"].get<double>(), 0.0) << stage;
  }
  EXPECT_GT(s["collision_ms"]["round_trip"]["p50"].get<double>(), 0.0);
  // The files.
  EXPECT_TRUE(std::filesystem::exists(out / "torus_on_box.pvd"));
  const int vtus = s["outputs"]["vtu"].get<int>();
  EXPECT_EQ(vtus, (frames - 1) / 20 + 1 + ((frames - 1) % 20 != 0 ? 1 : 0));  // output_every 20
  EXPECT_TRUE(std::filesystem::exists(out / "frame_0000.vtu"));
  EXPECT_TRUE(std::filesystem::exists(out / "frame_0119.vtu"));
  for (const auto& png : s["outputs"]["png"]) {
    const auto p = out / png.get<std::string>();
    EXPECT_TRUE(std::filesystem::exists(p)) << p;
    EXPECT_GT(std::filesystem::file_size(p), 1000u) << p;
  }
  // The CSV has a row per frame (and the header).
  std::ifstream csv(out / "stage_times.csv");
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, frames + 1);
  // The daemon was stopped.
  EXPECT_NE(r.err.find("started tetcollided"), std::string::npos) << r.err;
  std::ifstream log(out / "tetcollided.log");
  std::string text;
  for (std::string line; std::getline(log, line);) text += line + "\n";
  EXPECT_NE(text.find("tetcollided stopped"), std::string::npos) << text;
  std::filesystem::remove_all(dir);
}

/// Runs `tetcollide demo SCENE --frames N --spawn-daemon` into DIR/out and checks what
/// every healthy run shows: exit 0, a finite summary of N frames, no rejected state, no
/// inverted tet, contacts, and no energy above the initial value (1 % slack). Returns the
/// summary, or an empty object when the run could not be read (the failure is reported).
nlohmann::json run_healthy_scene(const std::filesystem::path& dir, const std::string& scene,
                                 int frames) {
  const auto out = dir / "out";
  const auto r = run_program(
      {program_from_env("TC_CLI"), "demo", scene, "--frames", std::to_string(frames),
       "--spawn-daemon", "--domain", std::to_string(private_domain()), "--out", out.string()},
      test::kSanitized ? 300s : 120s);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  std::ifstream in(out / "summary.json");
  if (!in) {
    ADD_FAILURE() << "no summary.json from " << scene;
    return {};
  }
  const auto s = nlohmann::json::parse(in);
  EXPECT_TRUE(finite_everywhere(s)) << s.dump(2);
  EXPECT_EQ(s["frames"].get<int>(), frames);
  EXPECT_EQ(s["rejected_states"].get<int>(), 0);
  EXPECT_EQ(s["inverted_tets"].get<int>(), 0);
  EXPECT_GT(s["max_contacts"].get<int>(), 0);
  const auto& e = s["energy_j"];
  const double e0 = e["initial"].get<double>();
  EXPECT_LE(e["max"].get<double>(), e0 + 0.01 * std::abs(e0)) << e.dump();
  return s;
}

/// The issue-12 stiff case through the real service: torus_on_box at contact stiffness
/// 1e6 N/m^2 (the explicit integrator reached NaN at frame 242 there).
TEST(DemoTest, StiffContactStaysStableThroughTheService) {
  const auto dir = make_temp_dir("itest-demo-k1e6");
  // The torus lands near frame 60 and bounces; 600 frames take ~10-15 s in Release. Under
  // ASan+UBSan (clang -O1) a frame costs ~0.8 s (250 frames took 197 s): 150 frames, the
  // first 90 frames of contact (the explicit integrator inverted tets from frame 75 here).
  const auto s = run_healthy_scene(dir, "torus_on_box_k1e6", test::kSanitized ? 150 : 600);
  if (s.empty()) return;
  const auto& e = s["energy_j"];
  const double e0 = e["initial"].get<double>();
  EXPECT_LT(e["final"].get<double>(), e0) << e.dump();
  EXPECT_LE(s["final_penetration_m"].get<double>(), 0.002) << s.dump(2);
  EXPECT_LT(s["max_penetration_m"].get<double>(), 0.010) << s.dump(2);
  std::filesystem::remove_all(dir);
}

/// Stiff contact with friction: torus_on_box at 1e6 N/m^2 with mu = 0.3 on both objects
/// lands and settles with no energy gain, as without friction.
TEST(DemoTest, StiffContactWithFrictionStaysStable) {
  const auto dir = make_temp_dir("itest-demo-friction-k1e6");
  const auto s = run_healthy_scene(dir, "torus_on_box_friction", test::kSanitized ? 150 : 600);
  if (s.empty()) return;
  const auto& e = s["energy_j"];
  EXPECT_LT(e["final"].get<double>(), e["initial"].get<double>()) << e.dump();
  EXPECT_LE(s["final_penetration_m"].get<double>(), 0.002) << s.dump(2);
  std::filesystem::remove_all(dir);
}

/// The friction scenes against their analytic answers, recomputed here from the scenes'
/// parameters (g = 9.81 m/s^2): a block sliding down 25 degrees with mu = 0.3 accelerates at
/// g (sin - mu cos); one on 20 degrees with mu = 0.6 stays (<= 1 mm in the last second);
/// one launched at 1 m/s with mu = 0.5 stops after v^2 / (2 mu g) and stays.
TEST(DemoTest, FrictionScenesMeetTheirAnalyticAnswers) {
  // 700-1500 frames of a 3,276-tet block each: ~6-10 s in Release, tens of minutes under
  // the sanitizers, which run the same friction code in the unit and service tests.
  if (test::kSanitized) GTEST_SKIP() << "analytic friction scenes run in the Release tree";
  constexpr double kPi = 3.14159265358979323846, g = 9.81;
  const auto deg = [&](double d) { return d * kPi / 180.0; };
  struct Case {
    const char* scene;
    int frames;
  };
  for (const Case c :
       {Case{"slope_slide", 700}, Case{"slope_stick", 1500}, Case{"block_skid", 800}}) {
    SCOPED_TRACE(c.scene);
    const auto dir = make_temp_dir(std::string("itest-demo-") + c.scene);
    const auto s = run_healthy_scene(dir, c.scene, c.frames);
    if (s.empty()) continue;
    const auto& check = s["analytic_check"];
    ASSERT_TRUE(check.is_object()) << s.dump(2);
    EXPECT_TRUE(check["passed"].get<bool>()) << check.dump();
    const double measured = check["measured"].get<double>();
    const auto& d = s["com_displacement_m"]["block"];
    if (std::string(c.scene) == "slope_slide") {
      const double a = g * (std::sin(deg(25)) - 0.3 * std::cos(deg(25)));
      EXPECT_NEAR(measured, a, 0.05 * a) << check.dump();
      EXPECT_LT(d[1].get<double>(), -0.2) << d.dump();  // it went down the slope (-y)
    } else if (std::string(c.scene) == "slope_stick") {
      EXPECT_LE(check["drift_m"].get<double>(), 1e-3) << check.dump();
    } else {
      const double distance = 1.0 / (2.0 * 0.5 * g);
      EXPECT_NEAR(d[0].get<double>(), distance, 0.05 * distance) << d.dump();
      EXPECT_LE(check["drift_m"].get<double>(), 1e-3) << check.dump();
      EXPECT_LT(std::abs(s["com_velocity_m_s"]["block"][0].get<double>()), 0.01);
    }
    std::filesystem::remove_all(dir);
  }
}

/// The paper's Fig. 14 with a triangle-based body: the shell sphere (a surface object)
/// lands on the tissue at frame ~61 and the tissue tears from frame ~362. The sphere is
/// held by forces on its vertices that balance the tissue's reactions, with no rejected
/// state, no inverted tet and no energy gain.
TEST(DemoTest, TriangleShellSphereOnTissueIsHeldAndTearsIt) {
  const auto dir = make_temp_dir("itest-demo-shell");
  // 400 frames take ~10 s in Release; under ASan+UBSan the first 40 frames of contact.
  const auto s = run_healthy_scene(dir, "sphere_on_tissue", test::kSanitized ? 100 : 400);
  if (s.empty()) return;
  EXPECT_LT(s["max_penetration_m"].get<double>(), 0.005) << s.dump(2);
  // Forces on the sphere's vertices, balanced by the tissue's reactions.
  const double sphere = s["peak_contact_force_n"]["sphere"].get<double>();
  const double tissue = s["peak_contact_force_n"]["tissue"].get<double>();
  EXPECT_GT(sphere, 0.0) << s.dump(2);
  EXPECT_NEAR(sphere, tissue, 1e-6 * sphere) << s.dump(2);
  if (!test::kSanitized) {
    // By frame 400 the tissue carries the 30 kg sphere (294 N) and more while braking it,
    // and has torn: a new topology version of the tissue went to the service.
    EXPECT_GT(sphere, 294.0) << s.dump(2);
    EXPECT_GT(s["tears"].get<int>(), 0) << s.dump(2);
    EXPECT_GT(s["topology_versions"]["tissue"].get<int>(), 1) << s.dump(2);
    EXPECT_EQ(s["topology_versions"]["sphere"].get<int>(), 1) << s.dump(2);
  }
  std::filesystem::remove_all(dir);
}

/// Self-contact (issue 45): the upper arm of the soft U in sheet_fold sags onto the lower
/// arm of the same object; with self-contact the deepest node of the U inside its own other
/// arm stays under 2 mm (the scene's limit: the run exits 1 beyond), and the arms do meet.
/// The same scene without self-contact goes through (5 mm in the Release run).
TEST(DemoTest, SelfContactKeepsAFoldApart) {
  const auto dir = make_temp_dir("itest-demo-fold");
  // The arm lands near frame 40: 600 frames take ~10 s in Release, 120 under the sanitizers.
  const auto s = run_healthy_scene(dir, "sheet_fold", test::kSanitized ? 120 : 600);
  if (s.empty()) return;
  const auto& self = s["self_penetration_m"];
  EXPECT_LE(self["max"].get<double>(), 0.002) << self.dump();
  EXPECT_GT(self["max"].get<double>(), 0.0) << "the arms never met: " << s.dump(2);
  EXPECT_LE(self["final"].get<double>(), self["max"].get<double>());
  std::filesystem::remove_all(dir);
  if (test::kSanitized) return;
  const auto off_dir = make_temp_dir("itest-demo-fold-off");
  const auto off = run_healthy_scene(off_dir, "sheet_fold_off", 600);
  if (off.empty()) return;
  EXPECT_GT(off["self_penetration_m"]["max"].get<double>(), 0.003) << off.dump(2);
  std::filesystem::remove_all(off_dir);
}

/// The paper's Fig. 14 with self-contact on the tissue (issue 45): the torn tissue's
/// fragments are one object; the run passes the usual checks through its tears.
TEST(DemoTest, TheTearingTissueWithSelfContactStaysHealthy) {
  // 900 frames of 10,823 tets: ~40 s in Release; the sanitizers run self-contact in the
  // unit tests and in the fold above.
  if (test::kSanitized) GTEST_SKIP() << "the whole tear runs in the Release tree";
  const auto dir = make_temp_dir("itest-demo-tear-self");
  const auto s = run_healthy_scene(dir, "tissue_tear", 900);
  if (s.empty()) return;
  EXPECT_GT(s["tears"].get<int>(), 0) << s.dump(2);
  EXPECT_GT(s["topology_versions"]["tissue"].get<int>(), 1) << s.dump(2);
  EXPECT_LE(s["self_penetration_m"]["max"].get<double>(), 0.002) << s.dump(2);
  std::filesystem::remove_all(dir);
}

/// A daemon on its embedded defaults (no pipeline.compute_stiffness): the demo asks for
/// the blocks of the objects it integrates implicitly (ObjectParams.blocks, protocol 3)
/// and gets them, so the torus lands through its first contact frames. (A service that
/// sends forces without blocks stops the run with a clear error: test_scene_run.)
TEST(DemoTest, TheDemoAsksForItsBlocksPerObject) {
  const auto dir = make_temp_dir("itest-demo-perobject");
  const std::uint32_t domain = private_domain();
  DaemonProcess daemon(dir, domain, "version: 1\nlog:\n  timing_summary_period_s: 0\n");
  ASSERT_TRUE(daemon.start()) << daemon.log_text();
  // The torus touches the box from frame ~60; under the sanitizers a contact frame costs
  // ~0.8 s, so 80 frames there (20 of contact), 200 in Release.
  const std::string frames = test::kSanitized ? "80" : "200";
  const auto r =
      run_program({program_from_env("TC_CLI"), "demo", "torus_on_box", "--frames", frames,
                   "--domain", std::to_string(domain), "--out", (dir / "out").string()},
                  test::kSanitized ? 300s : 90s);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto summary = nlohmann::json::parse(std::ifstream(dir / "out" / "summary.json"));
  EXPECT_GT(summary["max_contacts"].get<int>(), 0) << summary.dump(2);
  std::filesystem::remove_all(dir);
}

TEST(DemoTest, UnknownSceneIsBadInput) {
  const auto r = run_program({program_from_env("TC_CLI"), "demo", "no_such_scene", "--domain",
                              std::to_string(private_domain())},
                             30s);
  EXPECT_EQ(r.exit_code, 3) << r.out << r.err;
  EXPECT_NE(r.err.find("scene 'no_such_scene' not found"), std::string::npos) << r.err;
}

TEST(DemoTest, RecordingsOfTheDemoScenesReplayBitForBit) {
  ASSERT_TRUE(std::filesystem::is_directory(demo_recordings()))
      << "no demo recordings in '" << demo_recordings().string() << "' (TC_RECORDINGS unset?)";
  const auto dir = make_temp_dir("itest-demo-replay");
  const std::uint32_t domain = private_domain();
  // The demo records with the contact stiffness blocks on (the implicit integrator needs
  // them), so the replaying service sends them too.
  DaemonProcess daemon(dir, domain,
                       "version: 1\nlog:\n  timing_summary_period_s: 0\n"
                       "pipeline:\n  compute_stiffness: true\n");
  ASSERT_TRUE(daemon.start()) << daemon.log_text();
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(demo_recordings()))
    if (e.path().extension() == ".jsonl") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  ASSERT_EQ(files.size(), 4u) << "recordings in " << demo_recordings();
  bool saw_cut = false;
  bool saw_surface = false;
  for (const auto& file : files) {
    SCOPED_TRACE(file.string());
    const auto records = replay::read_recording(file);
    ASSERT_TRUE(records) << records.error().message;
    std::size_t forces = 0;
    for (const auto& rec : *records) {
      if (const auto* t = std::get_if<replay::TopologyRecord>(&rec)) {
        saw_cut |= t->version > 1;
        saw_surface |= !t->mesh.triangles.empty();
      }
      if (const auto* f = std::get_if<replay::ForcesRecord>(&rec)) forces += f->nodes.size();
    }
    EXPECT_GT(forces, 0u) << "the recording must hold contacts";
    const auto r = run_program({program_from_env("TC_CLI"), "replay", file.string(), "--domain",
                                std::to_string(domain), "--rate", "0", "--check", "--json"},
                               60s);
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_GT(j["frames"].get<int>(), 0);
    EXPECT_EQ(j["mismatched_frames"].get<int>(), 0);
    EXPECT_EQ(j["max_force_deviation"].get<double>(), 0.0);
  }
  EXPECT_TRUE(saw_cut) << "the tissue recording must hold a topology version > 1";
  EXPECT_TRUE(saw_surface) << "the sphere_on_tissue recording must hold a surface object";
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace tc::itest
