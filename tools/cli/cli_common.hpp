// Shared plumbing of the `tetcollide` subcommands: exit codes, error printing, timing.
#pragma once

#include <CLI/CLI.hpp>
#include <chrono>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/common/result.hpp"
#include "core/mesh/jitter.hpp"  // --jitter M: jitter_positions()
#include "core/mesh/tet_mesh.hpp"

namespace tc::cli {

/// Process exit codes (public interface: scripts test them).
enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitUsage = 2, kExitBadInput = 3 };

/// Where a subcommand's callback leaves its exit code.
struct Context {
  int exit_code = kExitOk;
};

/// Prints "tetcollide: error: <message>" to stderr and returns kExitBadInput.
int report_error(const Error& error);
/// Prints "tetcollide: error: <message>" to stderr and returns `code`.
int report_error(const std::string& message, int code);

/// Median of a non-empty list of values (the list is reordered).
double median(std::vector<double> values);

/// Milliseconds elapsed since `start`.
inline double elapsed_ms(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

/// Turns `x` by turn[3] degrees about the axis (turn[0], turn[1], turn[2]) through the centre
/// of x's box, right-handed (--turn-b AX AY AZ DEG). An error names what is wrong when the
/// axis is zero or a number is not finite; `x` is then unchanged.
Status turn_about_centre(Positions& x, const std::vector<double>& turn);

/// Prints a JSON object on stdout (2-space indent, newline).
void print_json(const nlohmann::json& value);

// Subcommand registration; each is defined in cmd_<name>.cpp.
void add_mesh_command(CLI::App& app, Context& ctx);
void add_detect_command(CLI::App& app, Context& ctx);
void add_respond_command(CLI::App& app, Context& ctx);
void add_distance_command(CLI::App& app, Context& ctx);
void add_bench_command(CLI::App& app, Context& ctx);
/// `bench response`, added under the `bench` subcommand by add_bench_command.
void add_bench_response_command(CLI::App& bench, Context& ctx);
void add_render_command(CLI::App& app, Context& ctx);
#ifdef TC_WITH_SERVICE
void add_record_command(CLI::App& app, Context& ctx);
void add_replay_command(CLI::App& app, Context& ctx);
void add_status_command(CLI::App& app, Context& ctx);
void add_demo_command(CLI::App& app, Context& ctx);
#endif

}  // namespace tc::cli
