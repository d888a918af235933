// `tetcollide record --domain N --out FILE [--duration S] [--partition P]`: captures
// topologies, states, forces and status of every scene on a domain into a recording
// (docs/RECORDING.md). Stops after --duration seconds or on SIGINT/SIGTERM.
#include <csignal>
#include <cstdio>

#include "cli_common.hpp"
#include "recorder.hpp"

namespace tc::cli {
namespace {

struct RecordArgs {
  std::uint32_t domain = 0;
  std::string out;
  double duration = 0.0;
  std::string partition;
};

std::atomic<bool> g_stop_recording{false};

extern "C" void on_stop_signal(int) {
  g_stop_recording.store(true);
}

int run_record(const RecordArgs& args) {
  g_stop_recording.store(false);
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  struct sigaction old_int {};
  struct sigaction old_term {};
  sigaction(SIGINT, &action, &old_int);
  sigaction(SIGTERM, &action, &old_term);
  replay::RecordOptions options;
  options.domain = args.domain;
  options.partition = args.partition;
  options.out = args.out;
  options.duration = std::chrono::milliseconds(static_cast<std::int64_t>(args.duration * 1000.0));
  std::fprintf(stderr, "tetcollide: recording domain %u into %s%s\n", args.domain, args.out.c_str(),
               args.duration > 0 ? "" : " until SIGINT/SIGTERM");
  const auto summary = replay::record(options, g_stop_recording);
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  if (!summary) return report_error(summary.error().message, kExitFailure);
  std::fprintf(stderr,
               "tetcollide: recorded %zu topologies, %zu removals, %zu states, %zu forces, %zu "
               "status samples\n",
               summary->topologies, summary->removals, summary->states, summary->forces,
               summary->status);
  return kExitOk;
}

}  // namespace

void add_record_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<RecordArgs>();
  CLI::App* cmd = app.add_subcommand("record", "Record a service session on a DDS domain");
  cmd->add_option("--domain", args->domain, "DDS domain id")->required()->check(CLI::Range(0, 232));
  cmd->add_option("--out", args->out, "Recording file to write (JSON lines)")->required();
  cmd->add_option("--duration", args->duration, "Seconds to record (default: until SIGINT)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--partition", args->partition, "DDS partition (default: none)");
  cmd->callback([args, &ctx] { ctx.exit_code = run_record(*args); });
}

}  // namespace tc::cli
