// `tetcollide demo SCENE [--frames N] [--out DIR] [--domain N] [--spawn-daemon]`: a small
// simulator (sim: lumped-mass FEM, backward Euler with the service's contact
// stiffness blocks) that drives a running tetcollided over DDS exactly as an external
// simulator would: it registers the scene's objects, publishes every frame's node
// positions, waits for the contact forces and blocks and integrates with them. The
// frame loop itself is sim::SceneRun (sim/scene_run.hpp); this file connects it to
// the service and writes the outputs. Writes a VTK series, PNG pictures, a stage-time plot and
// summary.json under --out (default out/<scene>/). docs/DEMO.md documents the scenes,
// the model, the outputs and the summary keys.
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>

#include "body.hpp"
#include "cli_common.hpp"
#include "core/io/mesh_io.hpp"
#include "core/mesh/topology.hpp"
#include "demo_support.hpp"
#include "friction_check.hpp"
#include "penetration.hpp"
#include "recording.hpp"
#include "render.hpp"
#include "scene_file.hpp"
#include "scene_run.hpp"
#include "tetcollide/client.hpp"

namespace tc::cli {
namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

struct DemoArgs {
  std::string scene;
  int frames = 0;  // 0 = the scene's
  std::string out;
  std::optional<std::uint32_t> domain;
  bool spawn_daemon = false;
  std::string record;  // hidden: record frames [record_from, record_to] into this file
  int record_from = 0;
  int record_to = -1;
};

std::atomic<bool> g_demo_stop{false};
extern "C" void on_demo_signal(int) {
  g_demo_stop.store(true);
}

/// Restores SIGINT/SIGTERM on scope exit.
class SignalScope {
 public:
  SignalScope() {
    g_demo_stop.store(false);
    struct sigaction a {};
    a.sa_handler = on_demo_signal;
    sigemptyset(&a.sa_mask);
    sigaction(SIGINT, &a, &old_int_);
    sigaction(SIGTERM, &a, &old_term_);
  }
  ~SignalScope() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  SignalScope(const SignalScope&) = delete;
  SignalScope& operator=(const SignalScope&) = delete;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

/// An object's parameters for the service. Blocks (df/dx, df/dv) are asked for the
/// objects the simulator integrates implicitly: every moving object of an implicit scene
/// and every shell; static objects and explicit bodies do not pay for them.
client::ObjectParams to_params(const sim::ObjectSpec& o, const sim::SceneSpec& scene) {
  client::ObjectParams p;
  p.stiffness = o.contact.stiffness;
  p.friction = o.contact.friction;
  p.friction_velocity = o.contact.friction_velocity;
  p.self_contact = o.contact.self_contact;
  p.blocks = !o.is_static && (o.shell.has_value() || scene.integrator == "implicit");
  p.damping = o.contact.damping;
  p.max_force = o.contact.max_force;
  p.is_static = o.is_static;
  // Scene files are validated on load (scene_file.cpp): both names parse.
  p.depth = client::parse_depth_method(o.contact.depth).value_or(client::DepthMethod::kCpfm);
  p.response =
      client::parse_response_kind(o.contact.response).value_or(client::ResponseKind::kAuto);
  return p;
}

client::Mesh to_client_mesh(const TetMesh& m) {
  client::Mesh out;
  out.node_ids = m.node_ids;
  out.rest_positions.assign(m.positions.data(), m.positions.data() + m.positions.size());
  out.tets.reserve(m.tets.size() * 4);
  for (const Tet& t : m.tets) out.tets.insert(out.tets.end(), t.begin(), t.end());
  return out;
}

/// A scene object's topology for the service: its tets, or a shell's triangles (a surface
/// object, docs/SURFACES.md).
client::Mesh to_client_mesh(const sim::SimObject& o) {
  const SurfaceMesh* s = o.surface();
  if (s == nullptr) return to_client_mesh(o.mesh());
  client::Mesh out;
  out.node_ids = s->node_ids;
  out.rest_positions.assign(s->positions.data(), s->positions.data() + s->positions.size());
  out.triangles.reserve(s->triangles.size() * 3);
  for (const Triangle& t : s->triangles)
    out.triangles.insert(out.triangles.end(), t.begin(), t.end());
  return out;
}

/// The collision service of sim::SceneRun over DDS: one publish / wait_forces round trip
/// per frame; FrameStats and round-trip times are kept for the outputs.
class DdsContactService final : public sim::ContactService {
 public:
  explicit DdsContactService(client::Client& c) : c_(c) {}
  void set_params(const std::string& object, const client::ObjectParams& p) { params_[object] = p; }

  Expected<std::map<std::string, sim::ContactAnswer>> exchange(
      std::int64_t frame, const std::vector<sim::StateView>& states) override {
    std::vector<client::ObjectState> out;
    out.reserve(states.size());
    for (const auto& s : states)
      out.push_back({*s.object,
                     std::span<const double>(s.positions->data(),
                                             static_cast<std::size_t>(s.positions->size())),
                     std::span<const double>(s.velocities->data(),
                                             static_cast<std::size_t>(s.velocities->size()))});
    const auto t0 = Clock::now();
    c_.publish_states(frame, out);
    auto answer = c_.wait_forces(frame, 20s);
    if (!answer)
      return Error{ErrorCode::kIo,
                   "frame " + std::to_string(frame) + " was not answered within 20 s"};
    round_trip.push_back(elapsed_ms(t0));
    for (auto& st : c_.take_frame_stats()) stats[st.frame] = st;
    std::map<std::string, sim::ContactAnswer> result;
    for (auto& o : answer->objects)
      result[o.object] = {o.status,
                          client::status_name(o.status),
                          std::move(o.nodes),
                          std::move(o.forces),
                          std::move(o.stiffness),
                          std::move(o.damping)};
    return result;
  }

  Status reregister(const std::string& object, const TetMesh& mesh) override {
    c_.register_object(object, to_client_mesh(mesh), params_[object]);
    const auto r = c_.wait_registered(object, 20s);
    if (!r.done || !r.ok)
      return Error{ErrorCode::kIo,
                   "the service did not register version " + std::to_string(c_.version(object)) +
                       " of '" + object +
                       "': " + (r.done ? r.message : std::string("no verdict in 20 s"))};
    return {};
  }

  std::vector<double> round_trip;  ///< ms per answered frame
  std::map<std::int64_t, client::FrameStatsEvent> stats;

 private:
  client::Client& c_;
  std::map<std::string, client::ObjectParams> params_;
};

/// Progress on stderr: a bar redrawn in place on a terminal, a line per 10 % otherwise.
class Progress {
 public:
  explicit Progress(int total) : total_(total), tty_(isatty(STDERR_FILENO) != 0) {}
  void update(int done, double ms_per_frame, std::size_t contacts) {
    const auto now = Clock::now();
    const int decile = done * 10 / std::max(1, total_);
    if (tty_) {
      if (done != total_ && now - last_ < 100ms) return;
      last_ = now;
      constexpr int kWidth = 30;
      const int filled = done * kWidth / std::max(1, total_);
      std::fprintf(stderr, "\r  [%.*s%.*s] %d/%d frames  %.1f ms/frame  %zu contacts   ", filled,
                   "##############################", kWidth - filled,
                   "..............................", done, total_, ms_per_frame, contacts);
      if (done == total_) std::fprintf(stderr, "\n");
    } else if (decile != last_decile_) {
      last_decile_ = decile;
      std::fprintf(stderr, "  %d/%d frames (%d%%), %.1f ms/frame, %zu contacts\n", done, total_,
                   decile * 10, ms_per_frame, contacts);
    }
  }

 private:
  int total_;
  bool tty_;
  Clock::time_point last_{};
  int last_decile_ = 0;
};

nlohmann::json stage_json(const std::vector<double>& v) {
  return {{"p50", demo::percentile(v, 0.5)}, {"p99", demo::percentile(v, 0.99)}};
}

/// Counts forces records of `frame` in a recording (0 when unreadable).
std::size_t recorded_answers(const std::filesystem::path& file, std::int64_t frame,
                             std::size_t* topologies = nullptr) {
  const auto records = replay::read_recording(file);
  if (!records) return 0;
  std::size_t n = 0;
  std::size_t t = 0;
  for (const auto& r : *records) {
    if (const auto* f = std::get_if<replay::ForcesRecord>(&r)) n += f->frame == frame ? 1 : 0;
    if (std::holds_alternative<replay::TopologyRecord>(r)) ++t;
  }
  if (topologies != nullptr) *topologies = t;
  return n;
}

/// Per-stage times of the frames whose FrameStats arrived (milliseconds), and the
/// service's figures over the run.
struct StageTimes {
  std::vector<double> frames, round_trip, assembly, queue, broad, narrow, depth, response, compute,
      publish;
  double service_max_depth = 0.0;
  std::uint64_t max_contacts = 0;
  std::uint64_t dropped = 0;
  std::string csv;  ///< stage_times.csv
};

StageTimes stage_times(const std::map<std::int64_t, client::FrameStatsEvent>& stats,
                       const std::vector<double>& round_trip, int done) {
  StageTimes t;
  t.csv =
      "frame,round_trip_ms,assembly_ms,queue_ms,broad_ms,narrow_ms,depth_ms,response_ms,"
      "compute_ms,publish_ms,contacts,max_depth_m\n";
  for (int f = 0; f < done && static_cast<std::size_t>(f) < round_trip.size(); ++f) {
    const auto it = stats.find(f);
    if (it == stats.end()) continue;
    const auto& s = it->second;
    const double rt = round_trip[static_cast<std::size_t>(f)];
    t.frames.push_back(f);
    t.round_trip.push_back(rt);
    t.assembly.push_back(s.assembly_ms);
    t.queue.push_back(s.queue_ms);
    t.broad.push_back(s.broad_ms);
    t.narrow.push_back(s.narrow_ms);
    t.depth.push_back(s.depth_ms);
    t.response.push_back(s.response_ms);
    t.compute.push_back(s.compute_ms);
    t.publish.push_back(s.publish_ms);
    t.service_max_depth = std::max(t.service_max_depth, s.max_depth);
    t.max_contacts = std::max<std::uint64_t>(t.max_contacts, s.contacts);
    t.dropped = s.dropped_frames;
    char line[256];
    std::snprintf(line, sizeof line, "%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%llu,%.6g\n",
                  f, rt, s.assembly_ms, s.queue_ms, s.broad_ms, s.narrow_ms, s.depth_ms,
                  s.response_ms, s.compute_ms, s.publish_ms,
                  static_cast<unsigned long long>(s.contacts), s.max_depth);
    t.csv += line;
  }
  return t;
}

/// stage_times.csv, .svg and .png under `out`.
Status write_stage_times(const std::filesystem::path& out, const std::string& scene,
                         const StageTimes& t) {
  {
    std::ofstream csv(out / "stage_times.csv");
    csv << t.csv;
  }
  const std::string title = "Collision time per frame by stage (" + scene + ")";
  const std::vector<viz::Series> lines{{"round trip (client)", t.round_trip, {0, 0, 0}},
                                       {"compute (pipeline)", t.compute, {127, 127, 127}},
                                       {"broad phase", t.broad, {31, 119, 180}},
                                       {"narrow phase", t.narrow, {255, 127, 14}},
                                       {"depth", t.depth, {44, 160, 44}},
                                       {"response", t.response, {214, 39, 40}},
                                       {"publish", t.publish, {148, 103, 189}}};
  viz::PlotOptions po;
  po.title = title;
  po.x_label = "frame";
  po.y_label = "milliseconds";
  po.width = 1000;
  po.height = 500;
  {
    std::ofstream svg(out / "stage_times.svg");
    svg << viz::plot_lines_svg(t.frames, lines, po);
  }
  return viz::write_png(viz::plot_lines(t.frames, lines, po), (out / "stage_times.png").string());
}

/// What a finished run reports (summary.json and the human summary).
struct RunReport {
  const sim::SceneSpec& scene;
  int done;
  double run_s;
  std::size_t stats_received;
  const StageTimes& t;
  const sim::RunBooks& books;
  std::size_t vtus;
  const std::vector<std::string>& pngs;
  const nlohmann::json& versions;
  const std::vector<std::string>& failures;
  bool interrupted;
  const std::optional<sim::FrictionCheckResult>& check;
};

/// summary.json (docs/DEMO.md, "summary.json keys").
nlohmann::json summary_json(const RunReport& r) {
  const sim::RunBooks& books = r.books;
  const StageTimes& t = r.t;
  nlohmann::json summary = {
      {"scene", r.scene.name},
      {"frames", r.done},
      {"frame_stats_received", r.stats_received},
      {"dt_s", r.scene.dt},
      {"integrator", r.scene.integrator},
      {"substeps", r.scene.substeps},
      {"newton_iterations_mean", books.frames > 0 ? static_cast<double>(books.newton_iterations) /
                                                        static_cast<double>(books.frames)
                                                  : 0.0},
      {"simulated_s", r.done * r.scene.dt},
      {"run_s", r.run_s},
      {"objects", r.scene.objects.size()},
      {"collision_ms",
       {{"round_trip", stage_json(t.round_trip)},
        {"assembly", stage_json(t.assembly)},
        {"queue", stage_json(t.queue)},
        {"broad", stage_json(t.broad)},
        {"narrow", stage_json(t.narrow)},
        {"depth", stage_json(t.depth)},
        {"response", stage_json(t.response)},
        {"compute", stage_json(t.compute)},
        {"publish", stage_json(t.publish)}}},
      {"max_penetration_m", books.max_penetration},
      {"max_penetration_frame", books.max_penetration_frame},
      {"final_penetration_m", books.last_penetration},
      {"self_penetration_m",
       {{"max", books.max_self_penetration},
        {"max_frame", books.max_self_penetration_frame},
        {"final", books.last_self_penetration}}},
      {"service_max_depth_m", t.service_max_depth},
      {"max_contacts", t.max_contacts},
      {"peak_contact_force_n", books.peak_contact_force},
      {"energy_j",
       {{"initial", books.energy_initial},
        {"max", books.energy_max},
        {"final", books.energy_final},
        {"torn", books.torn_energy},
        {"dissipated", books.dissipated}}},
      {"kinetic_max_j", books.kinetic_max},
      {"kinetic_final_j", books.kinetic_final},
      {"inverted_tets", books.inverted_tets},
      {"first_non_finite_frame", books.first_non_finite_frame},
      {"implicit_step_failures", books.step_failures},
      {"rejected_states", books.rejected},
      {"dropped_frames", t.dropped},
      {"tears", books.tears},
      {"torn_tets", books.torn_tets},
      {"first_tear_frame", books.first_tear},
      {"interrupted", r.interrupted},
      {"failures", r.failures},
      {"outputs",
       {{"pvd", r.scene.name + ".pvd"},
        {"vtu", r.vtus},
        {"png", r.pngs},
        {"stage_times_png", "stage_times.png"},
        {"stage_times_csv", "stage_times.csv"},
        {"stage_times_svg", "stage_times.svg"}}}};
  summary["topology_versions"] = r.versions;
  // Each moving object's mass-weighted centre: last frame minus start, and its velocity.
  nlohmann::json displacement = nlohmann::json::object(), velocity = nlohmann::json::object();
  for (const auto& [name, path] : books.com) {
    if (path.empty()) continue;
    const Eigen::Vector3d d = path.back() - books.com_start.at(name);
    const Eigen::Vector3d& v = books.com_velocity.at(name);
    displacement[name] = {d.x(), d.y(), d.z()};
    velocity[name] = {v.x(), v.y(), v.z()};
  }
  summary["com_displacement_m"] = displacement;
  summary["com_velocity_m_s"] = velocity;
  if (r.check) {
    const sim::FrictionCheckResult& c = *r.check;
    summary["analytic_check"] = {{"kind", c.kind},           {"quantity", c.quantity},
                                 {"expected", c.expected},   {"measured", c.measured},
                                 {"slope_deg", c.slope_deg}, {"mu", c.mu},
                                 {"drift_m", c.drift_m},     {"passed", c.passed}};
  }
  return summary;
}

/// The human summary on stdout.
void print_summary(const RunReport& r, const std::filesystem::path& out) {
  const sim::RunBooks& books = r.books;
  const StageTimes& t = r.t;
  std::printf("\n== tetcollide demo %s: %d frames (%.2f s simulated) in %.1f s\n",
              r.scene.name.c_str(), r.done, r.done * r.scene.dt, r.run_s);
  std::printf("   frame statistics received: %zu\n", r.stats_received);
  std::printf("   collision time per frame, ms      p50      p99\n");
  const auto row = [&](const char* name, const std::vector<double>& v) {
    std::printf("     %-28s %8.3f %8.3f\n", name, demo::percentile(v, 0.5),
                demo::percentile(v, 0.99));
  };
  row("round trip (client)", t.round_trip);
  row("assembly", t.assembly);
  row("broad phase", t.broad);
  row("narrow phase", t.narrow);
  row("depth", t.depth);
  row("response", t.response);
  row("compute (pipeline total)", t.compute);
  row("publish", t.publish);
  std::printf(
      "   max penetration (local, exact depth): %.3f mm at frame %lld; %.3f mm at the end\n",
      books.max_penetration * 1e3, static_cast<long long>(books.max_penetration_frame),
      books.last_penetration * 1e3);
  if (books.max_self_penetration_frame >= 0)
    std::printf(
        "   max self-penetration (exact depth):   %.3f mm at frame %lld; %.3f mm at the end\n",
        books.max_self_penetration * 1e3, static_cast<long long>(books.max_self_penetration_frame),
        books.last_self_penetration * 1e3);
  std::printf("   max depth (service FrameStats):       %.3f mm, max contacts %llu\n",
              t.service_max_depth * 1e3, static_cast<unsigned long long>(t.max_contacts));
  std::printf(
      "   mechanical energy (J): initial %.4f, max %.4f (%+.3f %%), final %.4f (kinetic %.3g, "
      "peak %.4g); inverted tets %zu\n",
      books.energy_initial, books.energy_max, 100.0 * sim::energy_rise(books), books.energy_final,
      books.kinetic_final, books.kinetic_max, books.inverted_tets);
  if (books.tears > 0)
    std::printf("   tearing: %zu tets removed in %zu cuts (first at frame %lld), %.4g J torn\n",
                books.torn_tets, books.tears, static_cast<long long>(books.first_tear),
                books.torn_energy);
  if (books.rejected > 0)
    std::printf("   rejected states: %zu (first: %s)\n", books.rejected,
                books.first_rejection.c_str());
  std::printf("   outputs in %s/:\n", out.string().c_str());
  std::printf(
      "     %s.pvd + %zu frame_NNNN.vtu (ParaView; fields depth, force, velocity, object)\n",
      r.scene.name.c_str(), r.vtus);
  for (const auto& p : r.pngs) std::printf("     %s\n", p.c_str());
  std::printf("     stage_times.png, stage_times.svg, stage_times.csv, summary.json\n");
}

/// Writes the config of a private daemon (--spawn-daemon) into `out` and starts it, its
/// log in out/tetcollided.log.
Status spawn_daemon(demo::ChildProcess& daemon, const std::filesystem::path& out,
                    std::uint32_t domain, const std::string& dds_config) {
  const auto config = out / "tetcollided.yaml";
  {
    // No pipeline.compute_stiffness: the demo asks for blocks per object (ObjectParams).
    std::ofstream c(config);
    c << "# Written by tetcollide demo --spawn-daemon: the embedded defaults, a private\n"
         "# domain and the loopback Cyclone DDS config.\n"
         "version: 1\ndds:\n  domain: "
      << domain << "\n  cyclonedds_config: \"" << dds_config
      << "\"\nlog:\n  timing_summary_period_s: 0\n";
  }
  const auto log = out / "tetcollided.log";
  std::error_code ec;
  std::filesystem::remove(log, ec);
  if (auto st = daemon.start({(demo::exe_dir() / "tetcollided").string(), "--config",
                              config.string(), "--domain", std::to_string(domain)},
                             log);
      !st)
    return Error{st.error().code, st.error().message + " (build it: ninja -C build tetcollided)"};
  return {};
}

/// Connects to the service and waits up to 20 s for it to answer; a spawned `daemon` that
/// exits meanwhile is an error naming its log.
Expected<std::unique_ptr<client::Client>> connect_service(const client::Options& options,
                                                          demo::ChildProcess* daemon,
                                                          const std::filesystem::path& out) {
  std::unique_ptr<client::Client> c;
  try {
    c = client::Client::connect(options);
  } catch (const std::exception& e) {
    return Error{ErrorCode::kIo, e.what()};
  }
  {
    const auto deadline = Clock::now() + 20s;
    bool ready = false;
    while (!ready && Clock::now() < deadline && !g_demo_stop.load()) {
      ready = c->wait_for_service(100ms);
      if (daemon != nullptr && !daemon->alive())
        return Error{ErrorCode::kIo, "tetcollided exited during start-up; see " +
                                         (out / "tetcollided.log").string()};
    }
    if (!ready)
      return Error{ErrorCode::kIo, "no tetcollided answered on domain " +
                                       std::to_string(options.domain) +
                                       " within 20 s (start one, or pass --spawn-daemon)"};
  }
  return c;
}

int run_demo(const DemoArgs& args) {
  // ---- the scene ----
  const auto roots = demo::data_roots();
  Expected<sim::SceneSpec> spec = Error{ErrorCode::kIo, ""};
  const auto file = demo::find_scene_file(args.scene);
  if (!file.empty()) {
    spec = sim::load_scene_file(file, roots);
  } else if (args.scene == "torus_on_box") {
    spec = sim::parse_scene(sim::embedded_torus_on_box(), "torus_on_box (embedded)", roots);
  } else {
    return report_error(Error{ErrorCode::kIo, "scene '" + args.scene +
                                                  "' not found (a file, or a name in "
                                                  "config/scenes: torus_on_box, ellipsoid_rain, "
                                                  "tissue_tear, sphere_on_tissue)"});
  }
  if (!spec) return report_error(spec.error());
  sim::SceneSpec& scene = *spec;
  if (args.frames > 0) scene.frames = args.frames;
  const std::filesystem::path out = args.out.empty() ? std::filesystem::path("out") / scene.name
                                                     : std::filesystem::path(args.out);
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) return report_error("cannot create " + out.string() + ": " + ec.message(), kExitBadInput);
  // Old frames of an earlier run would mix with this run's series.
  for (const auto& e : std::filesystem::directory_iterator(out, ec)) {
    const auto name = e.path().filename().string();
    if ((name.rfind("frame_", 0) == 0 &&
         (e.path().extension() == ".vtu" || e.path().extension() == ".png")))
      std::filesystem::remove(e.path(), ec);
  }

  auto run_or = sim::SceneRun::create(scene);
  if (!run_or) return report_error(run_or.error());
  sim::SceneRun& run = *run_or;
  const auto& objects = run.objects();
  // Boundary faces of each object, for the pictures (recomputed after a cut).
  std::vector<std::vector<std::array<std::int32_t, 3>>> surface;
  for (const auto& o : objects) surface.push_back(demo::boundary_of(o));
  const bool implicit = scene.integrator == "implicit";
  if (!implicit) {
    double stable = std::numeric_limits<double>::infinity();
    for (const auto& o : objects)
      if (o.body) stable = std::min(stable, o.body->stable_dt());
    const double sub_dt = scene.dt / scene.substeps;
    if (sub_dt > stable)
      std::fprintf(stderr,
                   "tetcollide: warning: substep %.3g s exceeds the elastic stability limit %.3g "
                   "s; raise 'substeps'\n",
                   sub_dt, stable);
  }

  // ---- the service ----
  SignalScope signals;
  demo::ChildProcess daemon;
  demo::ChildProcess recorder;
  std::uint32_t domain = args.domain.value_or(0);
  std::string dds_config;
  if (args.spawn_daemon) {
    if (!args.domain) domain = 100 + static_cast<std::uint32_t>(getpid()) % 120;
    const auto xml = demo::find_cyclonedds_config();
    if (!xml.empty()) dds_config = "file://" + xml.string();
    if (auto st = spawn_daemon(daemon, out, domain, dds_config); !st)
      return report_error(st.error().message, kExitFailure);
    std::fprintf(stderr, "tetcollide: started tetcollided (pid %d) on domain %u, log %s\n",
                 static_cast<int>(daemon.pid()), domain,
                 (out / "tetcollided.log").string().c_str());
  }
  client::Options options;
  options.domain = domain;
  options.scene = scene.name;
  options.cyclonedds_config = dds_config;
  options.resend_after = 500ms;
  auto connected = connect_service(options, args.spawn_daemon ? &daemon : nullptr, out);
  if (!connected) return report_error(connected.error().message, kExitFailure);
  std::unique_ptr<client::Client> c = std::move(*connected);
  DdsContactService service(*c);
  for (const auto& o : objects) {
    service.set_params(o.spec.name, to_params(o.spec, scene));
    c->register_object(o.spec.name, to_client_mesh(o), to_params(o.spec, scene));
  }
  for (const auto& o : objects) {
    const auto r = c->wait_registered(o.spec.name, 20s);
    if (!r.done || !r.ok)
      return report_error("the service did not register '" + o.spec.name +
                              "': " + (r.done ? r.message : std::string("no verdict in 20 s")),
                          kExitFailure);
  }

  // ---- the run ----
  const int frames = scene.frames;
  std::fprintf(stderr, "tetcollide: scene %s, %zu objects, %d frames of %.3g s (%s), output %s\n",
               scene.name.c_str(), objects.size(), frames, scene.dt, scene.integrator.c_str(),
               out.string().c_str());
  std::vector<demo::PvdEntry> pvd;
  std::vector<std::string> pngs;
  Progress progress(frames);
  const auto run_start = Clock::now();
  int done = 0;
  bool recording = false;
  for (int f = 0; f < frames; ++f) {
    if (g_demo_stop.load()) break;
    if (!args.record.empty() && f == args.record_from) {
      std::filesystem::remove(args.record, ec);
      // The recorder is a child process: it inherits CYCLONEDDS_URI, which must name the
      // same (loopback) Cyclone config as the daemon spawned above, or the two never meet.
      if (!dds_config.empty()) ::setenv("CYCLONEDDS_URI", dds_config.c_str(), 1);
      if (auto st = recorder.start({(demo::exe_dir() / "tetcollide").string(), "record", "--domain",
                                    std::to_string(domain), "--out", args.record},
                                   out / "record.log");
          !st)
        return report_error(st.error().message, kExitFailure);
      if (!c->wait_for_readers(2, 20s))
        return report_error("the recorder did not start", kExitFailure);
      std::size_t topologies = 0;
      const auto until = Clock::now() + 20s;
      while (Clock::now() < until) {
        recorded_answers(args.record, -1, &topologies);
        if (topologies >= objects.size()) break;
        c->poll(20ms);
      }
      if (topologies < objects.size())
        return report_error("the recorder missed the topologies", kExitFailure);
      recording = true;
    }
    const bool vtu_due = f % scene.output_every == 0 || f == frames - 1;
    const bool png_due =
        std::find(scene.render_frames.begin(), scene.render_frames.end(), f) !=
            scene.render_frames.end() ||
        (f == frames - 1 && !scene.render_frames.empty() &&
         *std::max_element(scene.render_frames.begin(), scene.render_frames.end()) >= frames);
    // Local check of the service's work (how deep does any node sit in another object?)
    // every 4th contact frame, at every output and at the last frame.
    const auto probe = vtu_due || png_due ? sim::SceneRun::Probe::kYes
                       : f % 4 == 0       ? sim::SceneRun::Probe::kIfContact
                                          : sim::SceneRun::Probe::kNo;
    if (auto st = run.exchange(service, f, probe); !st)
      return report_error(st.error().message, kExitFailure);
    const auto& depth = run.depth();
    if (vtu_due) {
      if (auto st = demo::write_frame_vtu(objects, depth, out, f); !st)
        return report_error(st.error());
      char name[32];
      std::snprintf(name, sizeof name, "frame_%04d.vtu", f);
      pvd.push_back({f * scene.dt, name});
    }
    if (png_due) {
      char name[32];
      std::snprintf(name, sizeof name, "frame_%04d.png", f);
      double deepest = 0.0;
      for (const auto& d : depth)
        for (const double v : d) deepest = std::max(deepest, v);
      if (auto st = demo::render_frame(objects, surface, scene, f, deepest * 1e3, out / name); !st)
        return report_error(st.error());
      pngs.push_back(name);
    }
    // ---- integrate, tear (a new topology version; the states go on with it) ----
    auto cut = run.advance(service, f);
    if (!cut) return report_error(cut.error().message, kExitFailure);
    for (const std::size_t i : *cut) surface[i] = demo::boundary_of(objects[i]);
    if (recording && f == args.record_to) {
      const auto until = Clock::now() + 20s;
      while (recorded_answers(args.record, f) < objects.size() && Clock::now() < until)
        c->poll(20ms);
      recorder.stop(SIGINT);
      recording = false;
    }
    done = f + 1;
    progress.update(done, elapsed_ms(run_start) / done, run.books().contacts);
    // A NaN state cannot be sent nor written: stop here (exit 1 below).
    if (run.books().first_non_finite_frame >= 0) break;
  }
  if (recording) recorder.stop(SIGINT);
  const double run_s = elapsed_ms(run_start) / 1000.0;
  auto& stats = service.stats;
  const auto& round_trip = service.round_trip;
  const sim::RunBooks& books = run.books();
  // The last frame's statistics follow its forces.
  {
    const auto until = Clock::now() + 2s;
    while (done > 0 && stats.count(done - 1) == 0 && Clock::now() < until) {
      c->poll(20ms);
      for (auto& s : c->take_frame_stats()) stats[s.frame] = s;
    }
  }
  nlohmann::json versions = nlohmann::json::object();
  for (const auto& o : objects) versions[o.spec.name] = c->version(o.spec.name);
  c.reset();
  const int daemon_exit = args.spawn_daemon ? daemon.stop(SIGTERM) : 0;
  if (g_demo_stop.load()) std::fprintf(stderr, "\ntetcollide: interrupted after %d frames\n", done);

  // ---- outputs ----
  if (auto st = demo::write_pvd(out / (scene.name + ".pvd"), pvd); !st)
    return report_error(st.error());
  const StageTimes t = stage_times(stats, round_trip, done);
  if (auto st = write_stage_times(out, scene.name, t); !st) return report_error(st.error());
  std::vector<std::string> failures =
      sim::run_failures(books, scene.max_energy_rise, scene.max_self_penetration);
  std::optional<sim::FrictionCheckResult> check;
  if (scene.check && books.com.count(scene.check->object) != 0) {
    check =
        sim::evaluate_friction_check(scene, *scene.check, books.com_start.at(scene.check->object),
                                     books.com.at(scene.check->object));
    if (!check->passed)
      failures.push_back("analytic check (" + check->kind + "): " + check->failure);
  }
  const RunReport report{scene, done,     run_s,    stats.size(),       t,    books, pvd.size(),
                         pngs,  versions, failures, g_demo_stop.load(), check};
  {
    std::ofstream js(out / "summary.json");
    js << summary_json(report).dump(2) << "\n";
  }
  print_summary(report, out);
  if (args.spawn_daemon && daemon_exit != 0)
    std::fprintf(stderr, "tetcollide: warning: tetcollided exited with %d\n", daemon_exit);
  if (g_demo_stop.load()) return kExitFailure;
  if (!failures.empty()) {
    for (const auto& f : failures) std::fprintf(stderr, "tetcollide: demo failed: %s\n", f.c_str());
    return kExitFailure;
  }
  return kExitOk;
}

}  // namespace

void add_demo_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<DemoArgs>();
  CLI::App* cmd = app.add_subcommand(
      "demo", "Run a demo scene (simulator client) against tetcollided over DDS");
  cmd->add_option("scene", args->scene,
                  "Scene name (config/scenes: torus_on_box, ellipsoid_rain, tissue_tear, "
                  "sphere_on_tissue) or a "
                  "scene file")
      ->required();
  cmd->add_option("--frames", args->frames, "Frames to simulate (default: the scene's)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--out", args->out, "Output directory (default: out/<scene>)");
  cmd->add_option("--domain", args->domain, "DDS domain id of the service")
      ->check(CLI::Range(0, 232));
  cmd->add_flag("--spawn-daemon", args->spawn_daemon,
                "Start a private tetcollided for the run (loopback config) and stop it after");
  cmd->add_option("--record", args->record, "Record frames --record-from..--record-to")->group("");
  cmd->add_option("--record-from", args->record_from)->group("");
  cmd->add_option("--record-to", args->record_to)->group("");
  cmd->callback([args, &ctx] { ctx.exit_code = run_demo(*args); });
}

}  // namespace tc::cli
