// `tetcollide status [--domain N] [--partition P] [--duration S] [--watch] [--json]`:
// every tetcollided on a DDS domain and what its scenes are doing, from the ServiceStatus
// and FrameStats topics alone (so any service of the domain, on this host or another):
// each service's id, state, protocol version, uptime and ownership strength; per scene
// its objects, frames per second, compute p50 and p99, contacts, rejected states,
// dropped frames and latest errors, over a listening window of --duration seconds.
// --watch redraws every window like `top` until SIGINT/SIGTERM. Exit 1 when no service
// was heard in the first window.
#include <csignal>
#include <cstdio>

#include "cli_common.hpp"
#include "status_watch.hpp"

namespace tc::cli {
namespace {

struct StatusArgs {
  std::uint32_t domain = 0;
  std::string partition;
  double duration = 2.0;
  bool watch = false;
  bool json = false;
};

std::atomic<bool> g_stop_status{false};

extern "C" void on_status_signal(int) {
  g_stop_status.store(true);
}

nlohmann::json to_json(const replay::StatusSnapshot& s) {
  nlohmann::json services = nlohmann::json::array(), scenes = nlohmann::json::array();
  for (const auto& v : s.services)
    services.push_back({{"id", v.id},
                        {"state", v.state},
                        {"alive", v.alive},
                        {"protocol_version", v.protocol_version},
                        {"uptime_s", v.uptime_s},
                        {"ownership_strength", v.ownership_strength},
                        {"message", v.message}});
  for (const auto& v : s.scenes)
    scenes.push_back({{"scene", v.scene},
                      {"objects", v.objects},
                      {"frames", v.frames},
                      {"frames_per_s", v.frames_per_s},
                      {"compute_ms_p50", v.compute_ms_p50},
                      {"compute_ms_p99", v.compute_ms_p99},
                      {"contacts", v.contacts},
                      {"rejected", v.rejected},
                      {"dropped_frames", v.dropped_frames},
                      {"errors", v.errors}});
  return {{"window_s", s.window_s}, {"services", services}, {"scenes", scenes}};
}

void print_text(const replay::StatusSnapshot& s, const StatusArgs& args) {
  std::printf("tetcollide status: domain %u, %.1f s window\n", args.domain, s.window_s);
  std::printf("services (%zu):\n", s.services.size());
  for (const auto& v : s.services)
    std::printf("  %-36s %-8s protocol %u  up %.0f s  strength %d%s\n", v.id.c_str(),
                v.state.c_str(), v.protocol_version, v.uptime_s, v.ownership_strength,
                v.alive ? "" : "  (gone)");
  std::printf("scenes (%zu):\n", s.scenes.size());
  if (!s.scenes.empty())
    std::printf("  %-24s %7s %9s %12s %12s %9s %8s %8s\n", "scene", "objects", "frames/s",
                "compute p50", "compute p99", "contacts", "rejected", "dropped");
  for (const auto& v : s.scenes) {
    std::printf("  %-24s %7u %9.1f %9.3f ms %9.3f ms %9llu %8llu %8llu\n", v.scene.c_str(),
                v.objects, v.frames_per_s, v.compute_ms_p50, v.compute_ms_p99,
                static_cast<unsigned long long>(v.contacts),
                static_cast<unsigned long long>(v.rejected),
                static_cast<unsigned long long>(v.dropped_frames));
    for (const auto& e : v.errors) std::printf("      error: %s\n", e.c_str());
  }
  std::fflush(stdout);
}

int run_status(const StatusArgs& args) {
  if (!(args.duration > 0.0) || args.duration > 3600.0)
    return report_error("--duration: the window must be in (0, 3600] seconds", kExitUsage);
  g_stop_status.store(false);
  struct sigaction action {};
  action.sa_handler = on_status_signal;
  sigemptyset(&action.sa_mask);
  struct sigaction old_int {};
  struct sigaction old_term {};
  sigaction(SIGINT, &action, &old_int);
  sigaction(SIGTERM, &action, &old_term);
  auto watcher = replay::StatusWatcher::create(args.domain, args.partition);
  int code = kExitOk;
  if (!watcher) {
    code = report_error(watcher.error().message, kExitFailure);
  } else {
    const auto window = std::chrono::milliseconds(static_cast<std::int64_t>(args.duration * 1e3));
    for (bool first = true; first || (args.watch && !g_stop_status.load()); first = false) {
      auto snapshot = watcher->listen(window, g_stop_status);
      if (!snapshot) {
        code = report_error(snapshot.error().message, kExitFailure);
        break;
      }
      if (args.watch && !args.json) std::printf("\033[H\033[2J");  // like top: redraw
      if (args.json)
        print_json(to_json(*snapshot));
      else
        print_text(*snapshot, args);
      if (first && snapshot->services.empty()) {
        std::fprintf(stderr, "tetcollide: no tetcollided heard on domain %u within %.1f s\n",
                     args.domain, args.duration);
        code = kExitFailure;
        break;
      }
    }
  }
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  return code;
}

}  // namespace

void add_status_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<StatusArgs>();
  CLI::App* cmd = app.add_subcommand(
      "status", "Show the services on a DDS domain and what their scenes are doing");
  cmd->add_option("--domain", args->domain, "DDS domain id (default 0)")->check(CLI::Range(0, 232));
  cmd->add_option("--partition", args->partition, "DDS partition (default: none)");
  cmd->add_option("--duration", args->duration,
                  "Seconds to listen per window: frames/s and percentiles are over it (2)");
  cmd->add_flag("--watch", args->watch, "Redraw every window until SIGINT, like top");
  cmd->add_flag("--json", args->json,
                "Print {\"services\": [...], \"scenes\": [...]} (one object per window)");
  cmd->callback([args, &ctx] { ctx.exit_code = run_status(*args); });
}

}  // namespace tc::cli
