// Service benchmark: the real tetcollided over DDS on this host.
//
//   service_latency [--daemon PATH] [--domain N] [--frames N] [--rate HZ] [--depth M]
//                   [--bob M] [--lockstep | --wait] [--daemon-dds-config URI]
//                   [--daemon-threads N] [--daemon-log FILE] [--json]
//   service_latency --organ MESH [--tool MESH] [--tool-radius M] [--depth M] [--drag M/S]
//                   [--wobble M] [--frames N] [--rate HZ] --lockstep [--daemon PATH] [--json]
//   service_latency --large [--daemon PATH] [--json]
//
// Latency mode (default): the torus-in-box scene (data/meshes/torus.msh resting
// --depth (default 5 mm) deep on data/meshes/box.msh, the box static) is registered,
// then the torus' states (bobbing by +-(--bob)) are published open-loop at --rate
// (default 1000 Hz) for --frames frames (default 5000, after 200 warm-up frames), or
// with --lockstep each frame after the previous one's answer (at most --rate; --wait:
// the same with Client::wait_forces instead of the forces callback). For each frame it measures
// state published -> forces received (client side) and the pipeline's compute time
// (FrameStats.compute_ms), and reports p50/p99 of both and of their difference (the service's
// overhead), and the core-to-core round trip before and after the stream
// (bench/core_latency.hpp: on a virtual machine it tells which kind of core pair ran).
//
// Organ mode (--organ): what a simulator of a large deforming organ does. The organ MESH
// (e.g. the 325,931-tet pawn, docs/BENCHMARKS.md "Large objects") is registered with a
// small tool (--tool, default data/meshes/ball.msh scaled to --tool-radius, 1 cm); every
// frame every organ node moves (a wave of amplitude --wobble, 0.1 mm, across the organ) and
// the tool, pressed --depth (5 mm) into the organ's top at the middle of its footprint, is
// dragged back and forth along x at --drag (5 cm/s, +-2 cm). The same latency, compute and
// CPU figures as the latency mode; use it with --lockstep.
//
// Large mode: two 303,918-tet structured boxes (37^3 cells x 6 tets) are registered one
// after the other; it reports each one's registration time (register_object -> the
// service's REGISTERED status) and the daemon's resident memory before and after.
//
// With --daemon the program starts that daemon on a private domain (loopback Cyclone
// config) and stops it at the end; otherwise it uses a running one on --domain. Then the
// daemon's CPU time (user + system, all threads, /proc/<pid>/stat) over the measured
// frames is reported too, and --daemon-dds-config sets its dds.cyclonedds_config (the
// benchmark's own participants use CYCLONEDDS_URI): bench/security_cost.sh compares the
// DDS Security profile with the plain one this way.
#include <dds/dds.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <thread>

#include "core/io/mesh_io.hpp"
#include "core_latency.hpp"
#include "protocol.hpp"
#include "service_common.hpp"
#include "test_meshes.hpp"
#include "tetcollide/client.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

using tc::bench::Daemon;
using tc::bench::percentile;
using tc::bench::to_client;

/// FrameStats.compute_ms per frame of one scene, read on its own participant.
class StatsReader {
 public:
  StatsReader(std::uint32_t domain, std::string scene) : scene_(std::move(scene)) {
    pp_ = dds_create_participant(domain, nullptr, nullptr);
    if (pp_ < 0)
      throw std::runtime_error("dds_create_participant: " + tc::protocol::dds_error(pp_));
    auto qos = tc::protocol::topic_qos(tc::protocol::Topic::kStats);
    const dds_entity_t t =
        dds_create_topic(pp_, tc::protocol::topic_descriptor(tc::protocol::Topic::kStats),
                         tc::protocol::topic_name(tc::protocol::Topic::kStats), qos.get(), nullptr);
    if (t < 0) throw std::runtime_error("dds_create_topic: " + tc::protocol::dds_error(t));
    dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, 100000);
    reader_ = dds_create_reader(pp_, t, qos.get(), nullptr);
    if (reader_ < 0)
      throw std::runtime_error("dds_create_reader: " + tc::protocol::dds_error(reader_));
  }
  ~StatsReader() { dds_delete(pp_); }
  /// Takes everything available into compute / queue maps.
  void drain() {
    std::array<void*, 256> samples{};
    std::array<dds_sample_info_t, 256> infos{};
    for (;;) {
      samples.fill(nullptr);
      const dds_return_t n = dds_take(reader_, samples.data(), infos.data(), 256, 256);
      if (n < 0) throw std::runtime_error("dds_take: " + tc::protocol::dds_error(n));
      for (dds_return_t i = 0; i < n; ++i) {
        if (!infos[i].valid_data) continue;
        const auto* s = static_cast<const tetcollide_FrameStats*>(samples[i]);
        if (tc::protocol::bounded_view(s->scene) != scene_) continue;
        compute_ms[s->frame] = s->compute_ms;
        queue_ms[s->frame] = s->queue_ms;
        assembly_ms[s->frame] = s->assembly_ms;
        in_service_ms[s->frame] = s->assembly_ms + s->queue_ms + s->compute_ms + s->publish_ms;
        stages[s->frame] = {s->broad_ms, s->narrow_ms, s->depth_ms, s->response_ms};
        contacts[s->frame] = s->contacts;
        publish_ms[s->frame] = s->publish_ms;
        dropped = s->dropped_frames;
      }
      if (const dds_return_t rc = dds_return_loan(reader_, samples.data(), n); rc < 0)
        throw std::runtime_error("dds_return_loan: " + tc::protocol::dds_error(rc));
      if (n < 256) return;
    }
  }
  std::map<std::int64_t, double> compute_ms;
  std::map<std::int64_t, double> queue_ms;  ///< frame dispatched -> pipeline started
  /// first state of the frame received -> frame dispatched (a large state's transfer shows here)
  std::map<std::int64_t, double> assembly_ms;
  /// first state taken -> last answer written (assembly + queue + compute + publish)
  std::map<std::int64_t, double> in_service_ms;
  std::map<std::int64_t, double> publish_ms;             ///< forces written
  std::map<std::int64_t, std::array<double, 4>> stages;  ///< broad, narrow, depth, response
  std::map<std::int64_t, std::uint64_t> contacts;
  std::uint64_t dropped = 0;

 private:
  std::string scene_;
  dds_entity_t pp_ = 0;
  dds_entity_t reader_ = 0;
};

struct LatencyArgs {
  int frames = 5000;
  double rate = 1000.0;
  double depth = 0.005;   ///< torus penetration into the box at rest, metres
  double bob = 0.002;     ///< amplitude of the torus' vertical motion, metres
  bool lockstep = false;  ///< wait for each answer before the next frame
  /// Lock-step with Client::wait_forces on the publishing thread instead of the forces
  /// callback (one thread switch less on the client side).
  bool wait = false;
  std::string organ;          ///< --organ: the organ's mesh (organ mode)
  std::string tool;           ///< --tool: the tool's mesh (default data/meshes/ball.msh)
  double tool_radius = 0.01;  ///< the tool scaled to this radius, metres
  double drag = 0.05;         ///< the tool's speed along x, m/s
  double wobble = 1e-4;       ///< amplitude of the organ's wave, metres
};

/// What the latency mode streams: the objects it registers and each frame's states.
struct Stream {
  struct Object {
    std::string name;
    tc::client::Mesh mesh;
    tc::client::ObjectParams params;
  };
  std::string scene;
  std::vector<Object> objects;
  /// Frame f's states (their positions stay valid until the next call).
  std::function<std::vector<tc::client::ObjectState>(int f)> states;
  nlohmann::json facts;  ///< what the scene is, merged into the JSON output
  std::string title;     ///< the same in words, for the text output
};

/// The torus-in-box scene: the box (1 x 1 x 0.3, centred) is the static floor; the torus
/// (major radius 0.3, minor 0.1, axis z) rests on it `depth` deep and bobs by +-`bob`.
std::optional<Stream> torus_in_box(const LatencyArgs& args) {
  const std::string meshes = std::string(TC_SOURCE_DIR) + "/data/meshes/";
  auto torus = tc::read_mesh(meshes + "torus.msh");
  auto box = tc::read_mesh(meshes + "box.msh");
  if (!torus || !box) {
    std::fprintf(stderr, "cannot read the meshes: %s\n",
                 (!torus ? torus.error() : box.error()).message.c_str());
    return std::nullopt;
  }
  Stream s;
  s.scene = "torus_in_box";
  tc::client::ObjectParams floor;
  floor.is_static = true;
  s.objects.push_back({"box", to_client(*box, {0.0, 0.0, 0.0}), floor});
  s.objects.push_back({"torus", to_client(*torus, {0.0, 0.0, 0.15 + 0.1 - args.depth}), {}});
  auto rest = std::make_shared<const std::vector<double>>(s.objects[1].mesh.rest_positions);
  auto positions = std::make_shared<std::vector<double>>(*rest);
  const double bob = args.bob;
  s.states = [rest, positions, bob](int f) {
    const double dz = bob * std::sin(2.0 * M_PI * static_cast<double>(f) / 500.0);
    for (std::size_t i = 2; i < positions->size(); i += 3) (*positions)[i] = (*rest)[i] + dz;
    return std::vector<tc::client::ObjectState>{{"torus", *positions}};
  };
  s.facts = {{"torus_nodes", torus->num_nodes()},
             {"torus_tets", torus->num_tets()},
             {"box_nodes", box->num_nodes()},
             {"box_tets", box->num_tets()},
             {"depth_m", args.depth},
             {"bob_m", args.bob}};
  char title[128];
  std::snprintf(title, sizeof title, "torus-in-box (%d + %d tets, %.1f mm deep)", torus->num_tets(),
                box->num_tets(), 1000.0 * args.depth);
  s.title = title;
  return s;
}

/// The organ with a tool (--organ; the header comment says what moves how).
std::optional<Stream> organ_with_tool(const LatencyArgs& args) {
  const std::string tool_path =
      args.tool.empty() ? std::string(TC_SOURCE_DIR) + "/data/meshes/ball.msh" : args.tool;
  auto organ = tc::read_mesh(args.organ);
  auto tool = tc::read_mesh(tool_path);
  if (!organ || !tool) {
    std::fprintf(stderr, "cannot read the meshes: %s\n",
                 (!organ ? organ.error() : tool.error()).message.c_str());
    return std::nullopt;
  }
  const Eigen::Vector3d lo = organ->positions.rowwise().minCoeff();
  const Eigen::Vector3d hi = organ->positions.rowwise().maxCoeff();
  const Eigen::Vector3d tlo = tool->positions.rowwise().minCoeff();
  const Eigen::Vector3d thi = tool->positions.rowwise().maxCoeff();
  // The tool scaled to radius `tool_radius` about its centre, its lowest point `depth`
  // below the organ's top, above the middle of the organ's footprint.
  const double scale = args.tool_radius / (0.5 * (thi - tlo).maxCoeff());
  const Eigen::Vector3d tool_centre = 0.5 * (tlo + thi);
  tool->positions = ((tool->positions.colwise() - tool_centre) * scale).eval();
  const Eigen::Vector3d start(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()),
                              hi.z() - args.depth + args.tool_radius);
  Stream s;
  s.scene = "organ_with_tool";
  s.objects.push_back({"organ", to_client(*organ, {0.0, 0.0, 0.0}), {}});
  s.objects.push_back({"tool", to_client(*tool, start), {}});
  auto organ_rest = std::make_shared<const std::vector<double>>(s.objects[0].mesh.rest_positions);
  auto tool_rest = std::make_shared<const std::vector<double>>(s.objects[1].mesh.rest_positions);
  auto organ_x = std::make_shared<std::vector<double>>(*organ_rest);
  auto tool_x = std::make_shared<std::vector<double>>(*tool_rest);
  const double wobble = args.wobble;
  const double wavenumber = 2.0 * M_PI / std::max((hi - lo).maxCoeff(), 1e-9);
  // Back and forth along x: +-2 cm at `drag` m/s, one frame being 1/rate s of the scene.
  const double step = args.drag / args.rate;
  constexpr double kHalfStroke = 0.02;
  s.states = [=](int f) {
    const double phase = 2.0 * M_PI * static_cast<double>(f) / 200.0;
    const std::size_t n = organ_x->size() / 3;
    for (std::size_t i = 0; i < n; ++i)
      (*organ_x)[3 * i + 2] =
          (*organ_rest)[3 * i + 2] + wobble * std::sin(phase + wavenumber * (*organ_rest)[3 * i]);
    const double travel = std::fmod(step * static_cast<double>(f), 4.0 * kHalfStroke);
    const double dx =
        travel < 2.0 * kHalfStroke ? travel - kHalfStroke : 3.0 * kHalfStroke - travel;
    for (std::size_t i = 0; i < tool_x->size(); i += 3) (*tool_x)[i] = (*tool_rest)[i] + dx;
    return std::vector<tc::client::ObjectState>{{"organ", *organ_x}, {"tool", *tool_x}};
  };
  s.facts = {{"organ_mesh", args.organ},
             {"organ_nodes", organ->num_nodes()},
             {"organ_tets", organ->num_tets()},
             {"tool_mesh", tool_path},
             {"tool_nodes", tool->num_nodes()},
             {"tool_tets", tool->num_tets()},
             {"tool_radius_m", args.tool_radius},
             {"depth_m", args.depth},
             {"drag_m_s", args.drag},
             {"wobble_m", args.wobble}};
  char title[160];
  std::snprintf(title, sizeof title,
                "organ-with-tool (%d tets, %d nodes all moving; tool %d tets, %.1f mm deep)",
                organ->num_tets(), organ->num_nodes(), tool->num_tets(), 1000.0 * args.depth);
  s.title = title;
  return s;
}

int run_latency(std::uint32_t domain, const LatencyArgs& args, const Stream& stream,
                const Daemon* daemon, bool json) {
  const int frames = args.frames;
  const double rate = args.rate;
  const std::string& scene = stream.scene;
  StatsReader stats(domain, scene);
  tc::client::Options o;
  o.domain = domain;
  o.scene = scene;
  auto c = tc::client::Client::connect(o);
  if (!c->wait_for_service(20s)) {
    std::fprintf(stderr, "no service on domain %u\n", domain);
    return 1;
  }
  for (const auto& obj : stream.objects) c->register_object(obj.name, obj.mesh, obj.params);
  for (const auto& obj : stream.objects) {
    const auto r = c->wait_registered(obj.name, 60s);
    if (!r.ok) {
      std::fprintf(stderr, "%s not registered: %s\n", obj.name.c_str(), r.message.c_str());
      return 1;
    }
  }

  std::mutex mutex;
  std::condition_variable answered_cv;
  std::map<std::int64_t, Clock::time_point> sent;
  std::map<std::int64_t, Clock::time_point> received;
  std::map<std::int64_t, std::size_t> force_nodes;
  const auto on_forces = [&](const tc::client::FrameForces& f) {
    const auto now = Clock::now();
    std::lock_guard lock(mutex);
    received.emplace(f.frame, now);
    std::size_t n = 0;
    for (const auto& obj : f.objects) n += obj.nodes.size();
    force_nodes[f.frame] = n;
    answered_cv.notify_all();
  };
  if (!args.wait) c->set_forces_callback(on_forces);
  const int warmup = 200;
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));
  // Which kind of core pair this machine gives two threads now (bench/core_latency.hpp):
  // measured before the stream and after it, never during it.
  const double core_rt_before = tc::bench::core_round_trip_ns();
  auto next = Clock::now();
  double daemon_cpu0 = 0.0, client_cpu0 = 0.0;
  for (int f = 0; f < warmup + frames; ++f) {
    if (f == warmup) {
      daemon_cpu0 = daemon != nullptr ? daemon->cpu_s() : 0.0;
      client_cpu0 = tc::bench::proc_figures(getpid()).cpu_s;
    }
    next += period;
    std::this_thread::sleep_until(next);
    const std::vector<tc::client::ObjectState> states = stream.states(f);
    const auto t = Clock::now();
    {
      std::lock_guard lock(mutex);
      sent[f] = t;
    }
    c->publish_states(f, states);
    if (args.wait) {
      if (const auto forces = c->wait_forces(f, 5s); forces && forces->frame == f)
        on_forces(*forces);
      next = std::max(next, Clock::now());
    } else if (args.lockstep) {
      std::unique_lock lock(mutex);
      answered_cv.wait_for(lock, 5s, [&] { return received.count(f) != 0; });
      next = std::max(next, Clock::now());
    }
  }
  // Let the last answers arrive.
  const auto deadline = Clock::now() + 5s;
  while (Clock::now() < deadline) {
    {
      std::lock_guard lock(mutex);
      if (received.count(warmup + frames - 1) != 0) break;
    }
    std::this_thread::sleep_for(1ms);
  }
  const double daemon_cpu = daemon != nullptr ? daemon->cpu_s() - daemon_cpu0 : 0.0;
  const double client_cpu = tc::bench::proc_figures(getpid()).cpu_s - client_cpu0;
  if (!args.wait) c->set_forces_callback(nullptr);
  stats.drain();
  const double core_rt_after = tc::bench::core_round_trip_ns();

  std::vector<double> latency, compute, overhead, assembly, queue, publish, transport;
  std::array<std::vector<double>, 4> stage;
  std::vector<double> contact_counts;
  std::size_t answered = 0, with_forces = 0;
  for (int f = warmup; f < warmup + frames; ++f) {
    const auto r = received.find(f);
    if (r == received.end()) continue;
    ++answered;
    with_forces += force_nodes[f] > 0 ? 1 : 0;
    const double l = std::chrono::duration<double, std::milli>(r->second - sent[f]).count();
    latency.push_back(l);
    const auto cm = stats.compute_ms.find(f);
    if (cm != stats.compute_ms.end()) {
      compute.push_back(cm->second);
      overhead.push_back(l - cm->second);
      queue.push_back(stats.queue_ms[f]);
      assembly.push_back(stats.assembly_ms[f]);
      publish.push_back(stats.publish_ms[f]);
      transport.push_back(l - stats.in_service_ms[f]);
      for (std::size_t k = 0; k < 4; ++k) stage[k].push_back(stats.stages[f][k]);
      contact_counts.push_back(static_cast<double>(stats.contacts[f]));
    }
  }
  nlohmann::json out{{"mode", "latency"},
                     {"scene", scene},
                     {"rate_hz", rate},
                     {"lockstep", args.lockstep || args.wait},
                     {"wait_forces", args.wait},
                     {"frames", frames},
                     {"answered", answered},
                     {"frames_with_forces", with_forces},
                     {"dropped_frames", stats.dropped},
                     {"latency_ms_p50", percentile(latency, 0.5)},
                     {"latency_ms_p99", percentile(latency, 0.99)},
                     {"compute_ms_p50", percentile(compute, 0.5)},
                     {"compute_ms_p99", percentile(compute, 0.99)},
                     {"overhead_ms_p50", percentile(overhead, 0.5)},
                     {"overhead_ms_p99", percentile(overhead, 0.99)},
                     {"assembly_ms_p50", percentile(assembly, 0.5)},
                     {"queue_ms_p50", percentile(queue, 0.5)},
                     {"publish_ms_p50", percentile(publish, 0.5)},
                     {"outside_service_ms_p50", percentile(transport, 0.5)},
                     {"broad_ms_p50", percentile(stage[0], 0.5)},
                     {"narrow_ms_p50", percentile(stage[1], 0.5)},
                     {"depth_ms_p50", percentile(stage[2], 0.5)},
                     {"response_ms_p50", percentile(stage[3], 0.5)},
                     {"contacts_p50", percentile(contact_counts, 0.5)},
                     // CPU over the measured frames (0 for the daemon without --daemon).
                     {"daemon_cpu_s", daemon_cpu},
                     {"daemon_cpu_ms_per_frame", 1000.0 * daemon_cpu / frames},
                     {"client_cpu_ms_per_frame", 1000.0 * client_cpu / frames},
                     {"core_round_trip_ns_before", core_rt_before},
                     {"core_round_trip_ns_after", core_rt_after}};
  out.update(stream.facts);
  if (json) {
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    std::printf("%s at %.0f Hz%s, %d frames: %zu answered, %zu with forces\n", stream.title.c_str(),
                rate,
                args.wait       ? " lock-step (wait_forces)"
                : args.lockstep ? " lock-step (callback)"
                                : "",
                frames, answered, with_forces);
    std::printf("latency (state published -> forces received): p50 %.3f ms, p99 %.3f ms\n",
                out["latency_ms_p50"].get<double>(), out["latency_ms_p99"].get<double>());
    std::printf("compute (FrameStats.compute_ms):              p50 %.3f ms, p99 %.3f ms\n",
                out["compute_ms_p50"].get<double>(), out["compute_ms_p99"].get<double>());
    std::printf("overhead (latency - compute, per frame):      p50 %.3f ms, p99 %.3f ms\n",
                out["overhead_ms_p50"].get<double>(), out["overhead_ms_p99"].get<double>());
    std::printf(
        "in the service: assembly p50 %.3f ms, queue p50 %.3f ms, publish p50 %.3f ms; outside "
        "it (DDS both ways, client) p50 %.3f ms\n",
        out["assembly_ms_p50"].get<double>(), out["queue_ms_p50"].get<double>(),
        out["publish_ms_p50"].get<double>(), out["outside_service_ms_p50"].get<double>());
    std::printf("stages p50: broad %.3f, narrow %.3f, depth %.3f, response %.3f ms; %g contacts\n",
                out["broad_ms_p50"].get<double>(), out["narrow_ms_p50"].get<double>(),
                out["depth_ms_p50"].get<double>(), out["response_ms_p50"].get<double>(),
                out["contacts_p50"].get<double>());
    std::printf("CPU per measured frame: daemon %.3f ms%s, this client %.3f ms\n",
                out["daemon_cpu_ms_per_frame"].get<double>(),
                daemon != nullptr ? "" : " (not started here)",
                out["client_cpu_ms_per_frame"].get<double>());
    std::printf("core-to-core round trip (bench/core_latency.hpp): %.0f ns before, %.0f ns after\n",
                core_rt_before, core_rt_after);
  }
  return answered == static_cast<std::size_t>(frames) ? 0 : 1;
}

int run_large(std::uint32_t domain, const Daemon* daemon, bool json) {
  const int n = 37;  // 37^3 cubes x 6 tets = 303,918 tets, 38^3 = 54,872 nodes
  tc::client::Options o;
  o.domain = domain;
  o.scene = "large";
  auto c = tc::client::Client::connect(o);
  if (!c->wait_for_service(20s)) {
    std::fprintf(stderr, "no service on domain %u\n", domain);
    return 1;
  }
  const double rss_before = daemon != nullptr ? daemon->rss_mb() : 0.0;
  nlohmann::json objects = nlohmann::json::array();
  for (int k = 0; k < 2; ++k) {
    const tc::TetMesh m =
        tc::test::structured_box(n, n, n, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1));
    const auto mesh = to_client(m, {0.9 * k, 0.0, 0.0});
    const std::string name = "large_" + std::to_string(k);
    const auto t0 = Clock::now();
    c->register_object(name, mesh, {});
    const auto r = c->wait_registered(name, 60s);
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (!r.ok) {
      std::fprintf(stderr, "%s not registered: %s\n", name.c_str(), r.message.c_str());
      return 1;
    }
    objects.push_back({{"object", name},
                       {"tets", m.num_tets()},
                       {"nodes", m.num_nodes()},
                       {"register_ms", ms},
                       {"service_message", r.message}});
  }
  const double rss_registered = daemon != nullptr ? daemon->rss_mb() : 0.0;
  // One frame with both (overlapping by 0.1 m: a large contact region), so the per-frame
  // buffers exist too.
  const tc::TetMesh m =
      tc::test::structured_box(n, n, n, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1));
  const auto m0 = to_client(m, {0.0, 0.0, 0.0});
  const auto m1 = to_client(m, {0.9, 0.0, 0.0});
  c->publish_states(0, {{"large_0", m0.rest_positions}, {"large_1", m1.rest_positions}});
  const auto frame_start = Clock::now();
  const auto f = c->wait_forces(0, 120s);
  const double frame_ms =
      std::chrono::duration<double, std::milli>(Clock::now() - frame_start).count();
  const double rss_after = daemon != nullptr ? daemon->rss_mb() : 0.0;
  const nlohmann::json out{{"mode", "large"},
                           {"objects", objects},
                           {"first_frame_answered", f.has_value()},
                           {"first_frame_ms", frame_ms},
                           {"daemon_rss_mb_before", rss_before},
                           {"daemon_rss_mb_registered", rss_registered},
                           {"daemon_rss_mb_after_frame", rss_after}};
  if (json) {
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    for (const auto& obj : objects)
      std::printf("%s: %d tets, %d nodes registered in %.1f ms\n",
                  obj["object"].get<std::string>().c_str(), obj["tets"].get<int>(),
                  obj["nodes"].get<int>(), obj["register_ms"].get<double>());
    std::printf("first frame (0.1 m overlap) answered: %s, in %.1f ms\n", f ? "yes" : "no",
                frame_ms);
    std::printf(
        "daemon RSS: %.1f MB before, %.1f MB with both registered, %.1f MB after the frame\n",
        rss_before, rss_registered, rss_after);
  }
  return f ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"tetcollided latency and memory benchmark"};
  std::string daemon_path;
  std::uint32_t domain = 0;
  LatencyArgs latency;
  bool large = false;
  bool json = false;
  app.add_option("--daemon", daemon_path, "Start this tetcollided on a private domain");
  app.add_option("--domain", domain, "Domain of a running service (without --daemon)");
  app.add_option("--frames", latency.frames, "Measured frames (after 200 warm-up frames)");
  app.add_option("--rate", latency.rate, "State publication rate, Hz");
  app.add_option(
      "--depth", latency.depth,
      "Torus penetration into the box at rest (organ mode: the tool's into the organ), m");
  app.add_option("--bob", latency.bob, "Amplitude of the torus' vertical motion, m");
  app.add_flag("--lockstep", latency.lockstep,
               "Wait for each frame's answer before the next (at most --rate)");
  app.add_flag("--wait", latency.wait,
               "Lock-step with Client::wait_forces instead of the forces callback");
  app.add_flag("--large", large, "Register two 300k-tet objects; time and memory");
  app.add_option("--organ", latency.organ,
                 "Organ mode: this organ mesh, every node moving, a tool pressed and dragged");
  app.add_option("--tool", latency.tool, "Organ mode: the tool's mesh (data/meshes/ball.msh)");
  app.add_option("--tool-radius", latency.tool_radius, "Organ mode: the tool's radius, m (0.01)")
      ->check(CLI::PositiveNumber);
  app.add_option("--drag", latency.drag, "Organ mode: the tool's speed along x, m/s (0.05)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--wobble", latency.wobble,
                 "Organ mode: amplitude of the wave every organ node follows, m (1e-4)")
      ->check(CLI::NonNegativeNumber);
  std::string daemon_dds_config;
  app.add_option("--daemon-dds-config", daemon_dds_config,
                 "dds.cyclonedds_config of the started daemon (e.g. a DDS Security profile)");
  int daemon_threads = 0;
  app.add_option("--daemon-threads", daemon_threads,
                 "threads of the started daemon (its config's `threads`; 0: one per core)")
      ->check(CLI::NonNegativeNumber);
  std::string daemon_log;
  app.add_option("--daemon-log", daemon_log,
                 "log.file of the started daemon, which then logs at info with a timing summary "
                 "every second (else it logs warnings to nowhere)");
  app.add_flag("--json", json, "JSON output");
  CLI11_PARSE(app, argc, argv);
  if (std::getenv("CYCLONEDDS_URI") == nullptr)
    setenv("CYCLONEDDS_URI",
           ("file://" + std::string(TC_SOURCE_DIR) + "/config/cyclonedds.xml").c_str(), 1);
  Daemon daemon;
  if (!daemon_path.empty()) {
    domain = 100 + static_cast<std::uint32_t>(getpid()) % 100;
    const std::string config = "/tmp/tc-bench-" + std::to_string(getpid()) + ".yaml";
    std::ofstream yaml(config);
    // A YAML single-quoted scalar: a ' inside is written twice.
    const auto quoted = [](const std::string& text) {
      std::string out = "'";
      for (const char ch : text) out += ch == '\'' ? std::string("''") : std::string(1, ch);
      return out + "'";
    };
    yaml << "version: 1\n";
    if (daemon_log.empty())
      yaml << "log:\n  level: warn\n  timing_summary_period_s: 0\n";
    else
      yaml << "log:\n  level: info\n  timing_summary_period_s: 1\n  file: " << quoted(daemon_log)
           << "\n";
    if (!daemon_dds_config.empty())
      yaml << "dds:\n  cyclonedds_config: " << quoted(daemon_dds_config) << "\n";
    yaml << "threads: " << daemon_threads << "\n";
    yaml.close();
    if (!daemon.start(daemon_path, domain, config)) return 1;
  }
  try {
    const Daemon* started = daemon_path.empty() ? nullptr : &daemon;
    if (large) return run_large(domain, started, json);
    const std::optional<Stream> stream =
        latency.organ.empty() ? torus_in_box(latency) : organ_with_tool(latency);
    if (!stream) return 1;
    return run_latency(domain, latency, *stream, started, json);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
