// tetcollided: the collision service. Thin by design: parse the command line, read the
// configuration, set up logging and signals, run the Service.
//
//   tetcollided [--config FILE] [--domain N] [--log-level L]
//
// Exit codes: 0 clean stop (SIGINT/SIGTERM), 1 runtime failure (DDS), 2 usage,
// 3 bad configuration.
#include <pthread.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <optional>
#include <thread>

#include "config.hpp"
#include "logging.hpp"
#include "service.hpp"

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;
constexpr int kExitBadConfig = 3;

int fail_config(const tc::Error& e) {
  std::fprintf(stderr, "tetcollided: error: %s\n", e.message.c_str());
  return kExitBadConfig;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"tetcollided: collision service for deformable tetrahedral meshes over DDS"};
  app.set_version_flag("--version", "tetcollided " TC_VERSION);
  std::string config_file;
  std::optional<std::uint32_t> domain;
  std::string log_level;
  app.add_option("--config", config_file,
                 "Configuration file (YAML, version 1); "
                 "default: the embedded defaults")
      ->check(CLI::ExistingFile);
  app.add_option("--domain", domain, "DDS domain id (overrides dds.domain)")
      ->check(CLI::Range(0, 232));
  app.add_option("--log-level", log_level, "trace|debug|info|warn|error|off (overrides log.level)")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}));
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kExitUsage;
  }

  tc::daemon::DaemonConfig config;
  if (!config_file.empty()) {
    auto loaded = tc::daemon::load_config(config_file);
    if (!loaded) return fail_config(loaded.error());
    config = std::move(*loaded);
  }
  if (domain) config.domain = *domain;
  if (!log_level.empty()) config.log_level = log_level;
  if (tc::Status st = tc::daemon::check_config(config); !st) return fail_config(st.error());
  if (tc::Status st = tc::daemon::setup_logging(config.log_level, config.log_file); !st)
    return fail_config(st.error());

  // SIGINT and SIGTERM are blocked in every thread (DDS and TBB threads inherit the
  // mask) and taken by one thread that asks the service to stop.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  if (pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr) != 0) {
    spdlog::error("pthread_sigmask failed");
    return kExitFailure;
  }

  spdlog::info("tetcollided {} starting (config {}, domain {})", TC_VERSION,
               config_file.empty() ? std::string("embedded defaults") : config_file, config.domain);
  tc::daemon::Service service(config);
  if (tc::Status st = service.start(); !st) {
    spdlog::error("start failed: {}", st.error().message);
    return kExitFailure;
  }

  std::atomic<bool> done{false};
  std::thread signal_thread([&] {
    const timespec poll{0, 200'000'000};
    while (!done.load()) {
      const int sig = sigtimedwait(&stop_signals, nullptr, &poll);
      if (sig == SIGINT || sig == SIGTERM) {
        spdlog::info("received {}, stopping", sig == SIGINT ? "SIGINT" : "SIGTERM");
        service.stop();
        return;
      }
    }
  });
  const tc::Status st = service.run();
  done.store(true);
  signal_thread.join();
  if (!st) {
    spdlog::error("{}", st.error().message);
    return kExitFailure;
  }
  spdlog::info("tetcollided stopped");
  return 0;
}
