// Service load and soak tool: several client processes streaming to the real tetcollided.
//
//   service_load --daemon PATH [--clients 4] [--objects 2] [--rate 60]
//                [--cells 38] [--seconds 20] [--json]
//   service_load --soak --daemon PATH [--seconds 180] [--cycles 20] [--stream-clients 2]
//                [--warmup-cycles 5] [--heap-limit-kb 8] [--json]
//   service_load --worker --domain N --scene S [--objects 2] [--cells 38] [--rate 60]
//                [--seconds 0]
//
// Load mode: starts --clients worker processes (this program with --worker), each in its
// own scene with --objects structured boxes of --cells^3 cells (38: 59,319 nodes and
// 329,232 tets per object), neighbouring boxes overlapping by 2% of their width and
// moving a little every frame. Each worker publishes its objects' states open-loop at
// --rate Hz for --seconds after its registration and measures, per answered frame, the
// time from publishing the states to holding the answer for every object. The tool
// reports frames answered per second (sum over clients), p50/p99 latency over every
// answered frame, frames superseded (newest wins: the service answered a later frame
// instead), the longest publish_states call, and the daemon's CPU (from
// /proc/<pid>/stat, in % of one core) and RSS over the measured window.
//
// Soak mode: --stream-clients workers (2) stream (small objects, 60 Hz) for --seconds
// while this process runs --cycles register/unregister cycles in another scene: each
// cycle connects a new client (new DDS participant), registers two objects, streams 30
// lock-step frames, removes the objects, waits for the service's REMOVED verdicts and
// disconnects. After each cycle it samples the daemon's live heap (glibc's bytes in use,
// tetcollide_heap_in_use_bytes from its metrics endpoint, the least of 5 reads 100 ms
// apart), RSS, open file descriptors (/proc/<pid>/fd) and threads (/proc/<pid>/task).
// Pass: from cycle --warmup-cycles (5) on, the live heap's trend (Theil-Sen slope) and its
// rise from the first to the last third of the samples both under --heap-limit-kb per
// cycle; fds and threads the same after every cycle; every cycle succeeded. The RSS is
// reported, not judged: it moves with the allocator's fragmentation, not with what the
// daemon keeps (docs/RELIABILITY.md "Soak"). A daemon started with the test-only
// TETCOLLIDED_TEST_LEAK_BYTES_PER_REMOVAL=N (the tool's environment is the daemon's)
// keeps N bytes per removal, 2N per cycle, and must fail.
//
// Worker mode (also the client the reliability tests kill and stop): registers, prints
// "streaming" on stderr, streams until --seconds passed (0: until SIGTERM/SIGINT), then
// prints a JSON summary on stdout.
//
// The tool starts the --daemon on a private domain (loopback Cyclone config) and stops it
// at the end; it reads the daemon's /proc figures, so it does not use a running one.
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "metrics_scrape.hpp"
#include "service_common.hpp"
#include "test_meshes.hpp"
#include "tetcollide/client.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;
using tc::bench::percentile;

std::atomic<bool> g_stop{false};

/// The soak's limit on the live heap's growth per register/unregister cycle, KB
/// (--heap-limit-kb): above the noise of a healthy daemon, below the smallest leak the
/// soak must catch (docs/RELIABILITY.md "Soak" has both).
constexpr double kHeapLimitKb = 8.0;

void on_signal(int) {
  g_stop.store(true);
}

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

struct WorkerArgs {
  std::uint32_t domain = 0;
  std::string scene = "load";
  int objects = 2;
  int cells = 38;
  double rate = 60.0;
  double seconds = 0.0;
  std::string go;  ///< when set: after registering, print "registered", wait for this file
};

/// Object k of a worker: a unit box shifted by 0.98 k along x (2% overlap with k-1).
tc::client::Mesh worker_mesh(int cells, int k) {
  const tc::TetMesh m =
      tc::test::structured_box(cells, cells, cells, {0.0, 0.0, 0.0}, {1.0, 1.0, 1.0});
  return tc::bench::to_client(m, {0.98 * k, 0.0, 0.0});
}

int run_worker(const WorkerArgs& a) {
  signal(SIGTERM, on_signal);
  signal(SIGINT, on_signal);
  tc::client::Options o;
  o.domain = a.domain;
  o.scene = a.scene;
  auto c = tc::client::Client::connect(o);
  if (!c->wait_for_service(30s)) {
    std::fprintf(stderr, "worker %s: no service on domain %u\n", a.scene.c_str(), a.domain);
    return 1;
  }
  std::vector<tc::client::Mesh> meshes;
  std::vector<std::string> names;
  for (int k = 0; k < a.objects; ++k) {
    meshes.push_back(worker_mesh(a.cells, k));
    names.push_back("obj" + std::to_string(k));
    c->register_object(names.back(), meshes.back(), {});
  }
  for (const auto& n : names)
    if (!c->wait_registered(n, 60s).ok) {
      std::fprintf(stderr, "worker %s: %s not registered\n", a.scene.c_str(), n.c_str());
      return 1;
    }

  std::mutex mutex;
  std::map<std::int64_t, Clock::time_point> sent;  // frame -> publish time
  std::vector<double> latency_ms;
  std::int64_t answered = 0;
  std::int64_t last_answered = -1;
  std::int64_t rejected = 0;
  c->set_forces_callback([&](const tc::client::FrameForces& f) {
    const auto now = Clock::now();
    std::lock_guard lock(mutex);
    const auto it = sent.find(f.frame);
    if (it == sent.end() || f.frame <= last_answered) return;
    latency_ms.push_back(ms_between(it->second, now));
    ++answered;
    last_answered = f.frame;
    rejected += f.ok() ? 0 : 1;
    sent.erase(sent.begin(), std::next(it));
  });
  if (!a.go.empty()) {
    // Load mode: every worker streams in the same window, after all are registered.
    std::fprintf(stderr, "registered\n");
    std::fflush(stderr);
    const auto until = Clock::now() + 600s;
    while (!std::filesystem::exists(a.go) && Clock::now() < until && !g_stop.load())
      std::this_thread::sleep_for(10ms);
  }
  std::fprintf(stderr, "streaming\n");
  std::fflush(stderr);

  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / a.rate));
  const auto start = Clock::now();
  auto next = start;
  std::vector<std::vector<double>> positions(meshes.size());
  double max_publish_ms = 0.0;
  std::int64_t frame = 0;
  for (; !g_stop.load(); ++frame) {
    const double t = std::chrono::duration<double>(Clock::now() - start).count();
    if (a.seconds > 0.0 && t >= a.seconds) break;
    std::vector<tc::client::ObjectState> states;
    for (std::size_t k = 0; k < meshes.size(); ++k) {
      positions[k] = meshes[k].rest_positions;
      const double dz = 0.002 * std::sin(0.1 * static_cast<double>(frame) + static_cast<double>(k));
      for (std::size_t i = 2; i < positions[k].size(); i += 3) positions[k][i] += dz;
      states.push_back({names[k], positions[k]});
    }
    const auto t0 = Clock::now();
    {
      std::lock_guard lock(mutex);
      sent[frame] = t0;
    }
    c->publish_states(frame, states);
    max_publish_ms = std::max(max_publish_ms, ms_between(t0, Clock::now()));
    next += period;
    const auto now = Clock::now();
    if (next < now) next = now;  // late: publish the newest state now, no catch-up burst
    std::this_thread::sleep_until(next);
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  std::this_thread::sleep_for(500ms);  // answers still on the way
  c->set_forces_callback(nullptr);
  std::lock_guard lock(mutex);
  const nlohmann::json out{{"scene", a.scene},
                           {"seconds", elapsed},
                           {"frames_published", frame},
                           {"frames_answered", answered},
                           {"frames_rejected", rejected},
                           {"last_published_frame", frame - 1},
                           {"last_answered_frame", last_answered},
                           {"max_publish_ms", max_publish_ms},
                           {"latency_ms", latency_ms}};
  std::printf("%s\n", out.dump().c_str());
  return 0;
}

/// A worker process started by the tool.
struct Worker {
  tc::process::Child child;  ///< SIGKILLed if still running when the tool ends
  std::filesystem::path out;
  std::filesystem::path err;
  bool start(const std::vector<std::string>& args) {
    return child
        .start(
            {.argv = args, .program = "/proc/self/exe", .out = out, .err = err, .truncate = true})
        .ok();
  }
  [[nodiscard]] bool says(const std::string& marker) const {
    std::ifstream in(err);
    std::string line;
    while (std::getline(in, line))
      if (line == marker) return true;
    return false;
  }
  [[nodiscard]] int exit_status() const { return child.status(); }  ///< waitpid status once exited
  [[nodiscard]] bool exited() { return child.running() && child.exited(); }
  int wait() { return tc::process::exit_code(child.wait()); }
  [[nodiscard]] nlohmann::json summary() const {
    std::ifstream in(out);
    std::string line;
    std::getline(in, line);
    return line.empty() ? nlohmann::json() : nlohmann::json::parse(line, nullptr, false);
  }
};

std::vector<std::unique_ptr<Worker>> start_workers(const std::filesystem::path& dir,
                                                   std::uint32_t domain, int n, int objects,
                                                   int cells, double rate, double seconds) {
  std::vector<std::unique_ptr<Worker>> workers;
  for (int i = 0; i < n; ++i) {
    auto w = std::make_unique<Worker>();
    const std::string scene = "load" + std::to_string(i);
    w->out = dir / (scene + ".out");
    w->err = dir / (scene + ".err");
    if (!w->start({"service_load", "--worker", "--domain", std::to_string(domain), "--scene", scene,
                   "--objects", std::to_string(objects), "--cells", std::to_string(cells), "--rate",
                   std::to_string(rate), "--seconds", std::to_string(seconds), "--go",
                   (dir / "go").string()}))
      throw std::runtime_error("fork failed");
    workers.push_back(std::move(w));
  }
  return workers;
}

/// Waits for every worker to exit: the summaries they printed. `failed` counts a worker
/// that exited non-zero and one without a summary (so once or twice).
std::vector<nlohmann::json> wait_workers(std::vector<std::unique_ptr<Worker>>& workers,
                                         int& failed) {
  std::vector<nlohmann::json> summaries;
  for (auto& w : workers) {
    failed += w->wait() != 0 ? 1 : 0;
    auto s = w->summary();
    if (s.is_discarded() || s.is_null()) {
      ++failed;
      continue;
    }
    summaries.push_back(std::move(s));
  }
  return summaries;
}

/// Waits until every worker has registered its objects, then lets them all stream at
/// once; false when one exits first or after `timeout`.
bool wait_streaming(std::vector<std::unique_ptr<Worker>>& workers, Clock::duration timeout) {
  if (workers.empty()) return true;
  const auto go = workers.front()->err.parent_path() / "go";
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    bool all = true;
    for (auto& w : workers) {
      if (w->exited()) {
        std::fprintf(stderr, "worker %s exited before streaming (status %d)\n", w->err.c_str(),
                     w->exit_status());
        return false;
      }
      all = all && w->says("registered");
    }
    if (all) {
      std::ofstream{go} << "go\n";
      return true;
    }
    std::this_thread::sleep_for(50ms);
  }
  return false;
}

struct LoadArgs {
  int clients = 4;
  int objects = 2;
  int cells = 38;
  double rate = 60.0;
  double seconds = 20.0;
};

int run_load(std::uint32_t domain, pid_t daemon, const LoadArgs& a, bool json) {
  const auto dir = std::filesystem::temp_directory_path() / ("tc-load-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  auto workers = start_workers(dir, domain, a.clients, a.objects, a.cells, a.rate, a.seconds);
  if (!wait_streaming(workers, 300s)) {
    std::fprintf(stderr, "the workers did not all start streaming (logs in %s)\n", dir.c_str());
    return 1;
  }
  const auto cpu0 = tc::bench::proc_figures(daemon);
  const auto t0 = Clock::now();
  double rss_max = cpu0.rss_mb;
  bool done = false;
  while (!done) {
    std::this_thread::sleep_for(200ms);
    rss_max = std::max(rss_max, tc::bench::proc_figures(daemon).rss_mb);
    done = Clock::now() - t0 > std::chrono::duration<double>(a.seconds);
  }
  const auto cpu1 = tc::bench::proc_figures(daemon);
  const double window = std::chrono::duration<double>(Clock::now() - t0).count();
  std::vector<double> latency;
  std::int64_t published = 0;
  std::int64_t answered = 0;
  std::int64_t rejected = 0;
  double max_publish_ms = 0.0;
  double seconds = 0.0;
  int failed = 0;
  for (const auto& s : wait_workers(workers, failed)) {
    for (const double v : s["latency_ms"]) latency.push_back(v);
    published += s["frames_published"].get<std::int64_t>();
    answered += s["frames_answered"].get<std::int64_t>();
    rejected += s["frames_rejected"].get<std::int64_t>();
    max_publish_ms = std::max(max_publish_ms, s["max_publish_ms"].get<double>());
    seconds = std::max(seconds, s["seconds"].get<double>());
  }
  const auto nodes = static_cast<long>(a.cells + 1) * (a.cells + 1) * (a.cells + 1);
  const nlohmann::json out{
      {"clients", a.clients},
      {"objects_per_client", a.objects},
      {"nodes_per_object", nodes},
      {"tets_per_object", 6L * a.cells * a.cells * a.cells},
      {"rate_hz", a.rate},
      {"seconds", seconds},
      {"frames_published", published},
      {"frames_answered", answered},
      {"frames_superseded", published - answered},
      {"frames_rejected", rejected},
      {"answered_per_s", seconds > 0 ? static_cast<double>(answered) / seconds : 0.0},
      {"latency_ms_p50", percentile(latency, 0.5)},
      {"latency_ms_p99", percentile(latency, 0.99)},
      {"max_publish_ms", max_publish_ms},
      {"daemon_cpu_percent", 100.0 * (cpu1.cpu_s - cpu0.cpu_s) / window},
      {"daemon_rss_mb_start", cpu0.rss_mb},
      {"daemon_rss_mb_max", rss_max},
      {"failed_workers", failed}};
  if (json) {
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    std::printf(
        "%d clients x %d objects (%ld nodes) at %.0f Hz for %.1f s: %lld frames published, "
        "%lld answered (%.1f/s), %lld superseded, %lld rejected\n",
        a.clients, a.objects, nodes, a.rate, seconds, static_cast<long long>(published),
        static_cast<long long>(answered), out["answered_per_s"].get<double>(),
        static_cast<long long>(published - answered), static_cast<long long>(rejected));
    std::printf("latency p50 %.1f ms, p99 %.1f ms; longest publish_states %.1f ms\n",
                out["latency_ms_p50"].get<double>(), out["latency_ms_p99"].get<double>(),
                max_publish_ms);
    std::printf("daemon CPU %.0f%% of one core, RSS %.0f MB at start, %.0f MB max\n",
                out["daemon_cpu_percent"].get<double>(), cpu0.rss_mb, rss_max);
  }
  std::filesystem::remove_all(dir);
  return failed == 0 && answered > 0 ? 0 : 1;
}

/// Waits for the service's REMOVED verdict on (scene, object).
bool wait_removed(tc::client::Client& c, const std::string& object, Clock::duration timeout) {
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    for (const auto& e : c.take_status_events())
      if (e.kind == tc::client::StatusEvent::Kind::kRemoved && e.scene == c.options().scene &&
          e.object == object)
        return true;
    c.poll(20ms);
  }
  return false;
}

/// The daemon's live heap (tetcollide_heap_in_use_bytes) now: the least of `reads`
/// scrapes 100 ms apart, so that the buffers of a frame in flight do not count; -1 when the
/// endpoint does not answer.
double heap_in_use(int metrics_port, int reads) {
  double least = -1.0;
  for (int i = 0; i < reads; ++i) {
    if (i > 0) std::this_thread::sleep_for(100ms);
    const auto text = tc::test::scrape_metrics(metrics_port);
    const double v =
        text ? tc::test::metric_sample(*text, "tetcollide_heap_in_use_bytes").value_or(-1.0) : -1.0;
    if (v >= 0.0 && (least < 0.0 || v < least)) least = v;
  }
  return least;
}

/// Theil-Sen slope of y over 0, 1, 2, ...: the median of the slopes of every pair of
/// points, which a few outliers (a receive buffer swapped at one sample) do not move.
double theil_sen_slope(const std::vector<double>& y) {
  std::vector<double> slopes;
  for (std::size_t i = 0; i < y.size(); ++i)
    for (std::size_t j = i + 1; j < y.size(); ++j)
      slopes.push_back((y[j] - y[i]) / static_cast<double>(j - i));
  return slopes.empty() ? 0.0 : percentile(slopes, 0.5);
}

struct SoakArgs {
  double seconds = 180.0;
  int cycles = 20;
  int stream_clients = 2;
  int warmup_cycles = 5;       ///< cycles before the first judged sample
  double heap_limit_kb = 0.0;  ///< per cycle; set in main()
  int metrics_port = 0;
};

int run_soak(std::uint32_t domain, pid_t daemon, const SoakArgs& a, bool json) {
  const auto dir = std::filesystem::temp_directory_path() / ("tc-soak-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  // The streams outlast the cycles by a few seconds: the last sample is taken while they
  // still run, like every other.
  auto workers = start_workers(dir, domain, a.stream_clients, 2, 6, 60.0, a.seconds + 5.0);
  if (!wait_streaming(workers, 60s)) {
    std::fprintf(stderr, "the workers did not all start streaming (logs in %s)\n", dir.c_str());
    return 1;
  }
  const auto start = Clock::now();
  const auto cycle_period = std::chrono::duration<double>(a.seconds / a.cycles);
  const tc::client::Mesh mesh_a = worker_mesh(8, 0);
  const tc::client::Mesh mesh_b = worker_mesh(8, 1);
  nlohmann::json samples = nlohmann::json::array();
  int failures = 0;
  for (int cycle = 0; cycle < a.cycles; ++cycle) {
    {
      tc::client::Options o;
      o.domain = domain;
      o.scene = "cycle";
      auto c = tc::client::Client::connect(o);
      bool ok = c->wait_for_service(20s);
      c->register_object("a", mesh_a, {});
      c->register_object("b", mesh_b, {});
      ok = ok && c->wait_registered("a", 20s).ok && c->wait_registered("b", 20s).ok;
      for (std::int64_t f = 0; ok && f < 30; ++f) {
        auto pa = mesh_a.rest_positions;
        for (std::size_t i = 0; i < pa.size(); i += 3) pa[i] += 0.001 * static_cast<double>(f);
        c->publish_states(f, {{"a", pa}, {"b", mesh_b.rest_positions}});
        const auto forces = c->wait_forces(f, 10s);
        ok = forces.has_value();
      }
      c->remove_object("a");
      ok = ok && wait_removed(*c, "a", 10s);
      c->remove_object("b");
      ok = ok && wait_removed(*c, "b", 10s);
      failures += ok ? 0 : 1;
    }
    // The participant is gone; give discovery a moment to drop it before sampling.
    std::this_thread::sleep_until(start + cycle_period * (cycle + 1));
    const auto f = tc::bench::proc_figures(daemon);
    const double heap = heap_in_use(a.metrics_port, 5);
    samples.push_back({{"cycle", cycle + 1},
                       {"t_s", std::chrono::duration<double>(Clock::now() - start).count()},
                       {"rss_mb", f.rss_mb},
                       {"heap_bytes", heap},
                       {"fds", f.fds},
                       {"threads", f.threads}});
    if (!json)
      std::printf(
          "cycle %2d  t %6.1f s  heap in use %8.1f KB  RSS %.2f MB  fds %d  threads %d  failed "
          "cycles %d\n",
          cycle + 1, samples.back()["t_s"].get<double>(), heap / 1024.0, f.rss_mb, f.fds, f.threads,
          failures);
    std::fflush(stdout);
  }
  std::int64_t answered = 0;
  int failed = 0;
  for (const auto& s : wait_workers(workers, failed))
    answered += s["frames_answered"].get<std::int64_t>();
  const int first_judged = std::clamp(a.warmup_cycles, 1, a.cycles);
  const auto& first = samples[static_cast<std::size_t>(first_judged - 1)];
  const auto& last = samples.back();
  // What the soak promises: nothing kept per register/unregister cycle. The live heap
  // after warm-up, one sample per cycle: its trend (Theil-Sen) must stay under the limit,
  // and so must its rise from the first to the last few samples, per cycle (a plateau).
  std::vector<double> heap;
  bool heap_read = true;
  for (std::size_t i = static_cast<std::size_t>(first_judged - 1); i < samples.size(); ++i) {
    heap.push_back(samples[i]["heap_bytes"].get<double>());
    heap_read = heap_read && heap.back() >= 0.0;
  }
  const double slope = theil_sen_slope(heap);
  const std::size_t ends = std::max<std::size_t>(1, heap.size() / 3);
  const std::vector<double> head(heap.begin(), heap.begin() + static_cast<std::ptrdiff_t>(ends));
  const std::vector<double> tail(heap.end() - static_cast<std::ptrdiff_t>(ends), heap.end());
  const double rise = heap.size() > ends ? percentile(tail, 0.5) - percentile(head, 0.5) : 0.0;
  const double rise_per_cycle =
      heap.size() > ends ? rise / static_cast<double>(heap.size() - ends) : 0.0;
  const double limit = 1024.0 * a.heap_limit_kb;
  const bool heap_flat = heap_read && slope < limit && rise_per_cycle < limit;
  const double rss_growth = 100.0 * (last["rss_mb"].get<double>() - first["rss_mb"].get<double>()) /
                            first["rss_mb"].get<double>();
  bool fds_constant = true;
  bool threads_constant = true;
  for (std::size_t i = static_cast<std::size_t>(first_judged); i < samples.size(); ++i) {
    fds_constant = fds_constant && samples[i]["fds"] == first["fds"];
    threads_constant = threads_constant && samples[i]["threads"] == first["threads"];
  }
  const bool pass = heap_flat && fds_constant && threads_constant && failures == 0 && failed == 0 &&
                    (a.stream_clients == 0 || answered > 0);
  const nlohmann::json out{{"seconds", a.seconds},
                           {"cycles", a.cycles},
                           {"stream_clients", a.stream_clients},
                           {"failed_cycles", failures},
                           {"failed_workers", failed},
                           {"stream_frames_answered", answered},
                           {"heap_slope_bytes_per_cycle", slope},
                           {"heap_rise_bytes_per_cycle", rise_per_cycle},
                           {"heap_limit_bytes_per_cycle", limit},
                           {"heap_read", heap_read},
                           {"heap_flat", heap_flat},
                           {"rss_growth_percent", rss_growth},
                           {"fds_constant", fds_constant},
                           {"threads_constant", threads_constant},
                           {"pass", pass},
                           {"samples", samples}};
  if (json) {
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    std::printf(
        "live heap, cycles %d -> %d: trend %+.2f KB/cycle (Theil-Sen), median of the last %zu "
        "- first %zu samples %+.1f KB (%+.2f KB/cycle); limit %.1f KB/cycle: %s%s\n",
        first_judged, a.cycles, slope / 1024.0, ends, ends, rise / 1024.0, rise_per_cycle / 1024.0,
        a.heap_limit_kb, heap_flat ? "flat" : "GROWS",
        heap_read ? "" : " (the metrics endpoint did not answer)");
    std::printf(
        "RSS cycle %d -> %d: %+.2f%% (not judged: the allocator's); fds constant: %s; threads "
        "constant: %s; failed cycles: %d; streamed frames answered: %lld; %s\n",
        first_judged, a.cycles, rss_growth, fds_constant ? "yes" : "no",
        threads_constant ? "yes" : "no", failures, static_cast<long long>(answered),
        pass ? "PASS" : "FAIL");
  }
  std::filesystem::remove_all(dir);
  return pass ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"tetcollided load and soak tool"};
  std::string daemon_path;
  std::uint32_t domain = 0;
  bool worker = false;
  bool soak = false;
  bool json = false;
  SoakArgs soak_args;
  LoadArgs load;
  WorkerArgs w;
  double seconds = -1.0;
  app.add_option("--daemon", daemon_path, "Start this tetcollided on a private domain");
  app.add_option("--domain", domain, "Worker: domain of the service");
  app.add_flag("--worker", worker, "Run as one streaming client (used by the tool and tests)");
  app.add_flag("--soak", soak, "Soak: register/unregister cycles while streaming");
  app.add_option("--scene", w.scene, "Worker: scene name");
  app.add_option("--clients", load.clients, "Load: client processes");
  app.add_option("--objects", load.objects, "Objects per client");
  app.add_option("--cells", load.cells, "Cells per box side (38: 59,319 nodes)");
  app.add_option("--rate", load.rate, "States per second per client");
  app.add_option("--seconds", seconds, "Duration (load 20, soak 180, worker 0 = until SIGTERM)");
  app.add_option("--cycles", soak_args.cycles, "Soak: register/unregister cycles");
  app.add_option("--stream-clients", soak_args.stream_clients,
                 "Soak: clients streaming throughout (2; 0 for the quick check)");
  app.add_option("--warmup-cycles", soak_args.warmup_cycles,
                 "Soak: the first judged sample is this cycle's (5)");
  soak_args.heap_limit_kb = kHeapLimitKb;
  app.add_option("--heap-limit-kb", soak_args.heap_limit_kb,
                 "Soak: live heap growth allowed per cycle after warm-up, KB");
  app.add_option("--go", w.go, "Worker: wait for this file after registering");
  app.add_flag("--json", json, "JSON output");
  CLI11_PARSE(app, argc, argv);
  if (std::getenv("CYCLONEDDS_URI") == nullptr)
    setenv("CYCLONEDDS_URI",
           ("file://" + std::string(TC_SOURCE_DIR) + "/config/cyclonedds.xml").c_str(), 1);
  try {
    if (worker) {
      w.domain = domain;
      w.objects = load.objects;
      w.cells = load.cells;
      w.rate = load.rate;
      w.seconds = std::max(0.0, seconds);
      return run_worker(w);
    }
    tc::bench::Daemon daemon;
    pid_t daemon_pid = -1;
    if (!daemon_path.empty()) {
      domain = 100 + static_cast<std::uint32_t>(getpid()) % 100;
      const std::string config = "/tmp/tc-load-" + std::to_string(getpid()) + ".yaml";
      std::ofstream out(config);
      out << "version: 1\nlog:\n  level: warn\n  timing_summary_period_s: 0\n";
      if (soak) {
        // The soak reads the daemon's live heap from its metrics endpoint.
        soak_args.metrics_port = tc::bench::free_loopback_port();
        out << "metrics:\n  listen: 127.0.0.1:" << soak_args.metrics_port << "\n";
      }
      out.close();
      if (!daemon.start(daemon_path, domain, config)) return 1;
      daemon_pid = daemon.pid;
    } else {
      std::fprintf(stderr, "--daemon is required (the tool samples the daemon's /proc)\n");
      return 2;
    }
    if (soak) {
      soak_args.seconds = seconds > 0 ? seconds : 180.0;
      return run_soak(domain, daemon_pid, soak_args, json);
    }
    load.seconds = seconds > 0 ? seconds : 20.0;
    return run_load(domain, daemon_pid, load, json);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
