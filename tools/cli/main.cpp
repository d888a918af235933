// tetcollide: command-line front end of the engine and the service.
// Exit codes: 0 ok, 1 failure, 2 usage error, 3 bad input (message on stderr).
#include <CLI/CLI.hpp>
#include <cstdio>

#include "cli_common.hpp"

int main(int argc, char** argv) {
  CLI::App app{"tetcollide: collision of deformable tetrahedral meshes"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "tetcollide " TC_VERSION);
  tc::cli::Context ctx;
  tc::cli::add_mesh_command(app, ctx);
  tc::cli::add_detect_command(app, ctx);
  tc::cli::add_respond_command(app, ctx);
  tc::cli::add_distance_command(app, ctx);
  tc::cli::add_bench_command(app, ctx);
  tc::cli::add_render_command(app, ctx);
#ifdef TC_WITH_SERVICE
  tc::cli::add_record_command(app, ctx);
  tc::cli::add_replay_command(app, ctx);
  tc::cli::add_status_command(app, ctx);
  tc::cli::add_demo_command(app, ctx);
#endif
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return tc::cli::kExitUsage;
  }
  return ctx.exit_code;
}
