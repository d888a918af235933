// `tetcollide replay FILE --domain N [--rate X] [--check] [--json]`: replays a recording
// against a running tetcollided and, with --check, compares the forces bit for bit.
// --json prints {"frames", "mismatched_frames", "max_force_deviation", "latency_ms_p50",
// "latency_ms_p99"}. Exit code 1 when --check finds a difference or a frame unanswered.
#include <cstdio>

#include "cli_common.hpp"
#include "replayer.hpp"

namespace tc::cli {
namespace {

struct ReplayArgs {
  std::string file;
  std::uint32_t domain = 0;
  double rate = 1.0;
  bool check = false;
  bool json = false;
  std::string partition;
  double frame_timeout = 10.0;
};

int run_replay(const ReplayArgs& args) {
  const auto records = replay::read_recording(args.file);
  if (!records) return report_error(records.error());
  replay::ReplayOptions options;
  options.domain = args.domain;
  options.partition = args.partition;
  options.rate = args.rate;
  options.check = args.check;
  options.frame_timeout =
      std::chrono::milliseconds(static_cast<std::int64_t>(args.frame_timeout * 1000.0));
  const auto report = replay::replay(*records, options);
  if (!report) return report_error(report.error().message, kExitFailure);
  if (args.json) {
    print_json({{"frames", report->frames},
                {"mismatched_frames", report->mismatched_frames},
                {"max_force_deviation", report->max_force_deviation},
                {"latency_ms_p50", report->latency_ms_p50},
                {"latency_ms_p99", report->latency_ms_p99}});
  } else {
    std::printf("frames:              %zu\n", report->frames);
    std::printf("unanswered:          %zu\n", report->unanswered);
    if (args.check) {
      std::printf("mismatched_frames:   %zu\n", report->mismatched_frames);
      std::printf("max_force_deviation: %.17g\n", report->max_force_deviation);
    }
    std::printf("latency_ms_p50:      %.3f\n", report->latency_ms_p50);
    std::printf("latency_ms_p99:      %.3f\n", report->latency_ms_p99);
  }
  for (const auto& m : report->mismatches)
    std::fprintf(stderr, "tetcollide: mismatch: %s\n", m.c_str());
  if (args.check && (report->mismatched_frames > 0 || report->unanswered > 0)) return kExitFailure;
  if (report->unanswered > 0) return kExitFailure;
  return kExitOk;
}

}  // namespace

void add_replay_command(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<ReplayArgs>();
  CLI::App* cmd = app.add_subcommand("replay", "Replay a recording against a running tetcollided");
  cmd->add_option("file", args->file, "Recording (from tetcollide record)")->required();
  cmd->add_option("--domain", args->domain, "DDS domain id")->required()->check(CLI::Range(0, 232));
  cmd->add_option("--rate", args->rate, "Speed factor of the recorded pacing; 0 = no pacing")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--check", args->check, "Compare the forces with the recorded ones, bit for bit");
  cmd->add_flag("--json", args->json, "Print the summary as JSON");
  cmd->add_option("--partition", args->partition, "DDS partition (default: none)");
  cmd->add_option("--frame-timeout", args->frame_timeout,
                  "Seconds to wait for one frame's answer (re-sending it meanwhile)")
      ->check(CLI::PositiveNumber);
  cmd->callback([args, &ctx] { ctx.exit_code = run_replay(*args); });
}

}  // namespace tc::cli
