// The soak's leak check, quick (docs/RELIABILITY.md "Soak"): service_load --soak without
// the streaming clients, 40 register/unregister cycles of a second each, judged from
// cycle 20 on. A healthy daemon passes; one started with the test-only
// TETCOLLIDED_TEST_LEAK_BYTES_PER_REMOVAL (keeping 2 x 32 KB per cycle) fails on the live
// heap, with the leak measured at about its size, and on nothing else.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "daemon_process.hpp"

namespace tc::itest {
namespace {

using namespace std::chrono_literals;

/// Runs the quick soak with `env` (VAR=value, or "") before it: its JSON summary.
nlohmann::json quick_soak(const std::string& env) {
  std::vector<std::string> argv;
  if (!env.empty()) argv = {"/usr/bin/env", env};
  argv.push_back(program_from_env("TC_SERVICE_LOAD"));
  for (const char* a : {"--soak", "--json", "--seconds", "40", "--cycles", "40", "--warmup-cycles",
                        "20", "--stream-clients", "0", "--daemon"})
    argv.emplace_back(a);
  argv.push_back(program_from_env("TC_DAEMON"));
  const RunResult r = run_program(argv, 150s);
  const auto out = nlohmann::json::parse(r.out, nullptr, false);
  EXPECT_FALSE(out.is_discarded()) << "exit " << r.exit_code << "\n" << r.out << r.err;
  if (out.is_discarded()) return nlohmann::json::object();
  EXPECT_EQ(r.exit_code, out.value("pass", false) ? 0 : 1) << r.err;
  return out;
}

TEST(SoakCheck, AHealthyDaemonKeepsNothingPerCycle) {
  const auto s = quick_soak("");
  EXPECT_EQ(s.value("failed_cycles", -1), 0);
  EXPECT_TRUE(s.value("heap_read", false));
  EXPECT_TRUE(s.value("heap_flat", false)) << s.dump(2);
  EXPECT_TRUE(s.value("fds_constant", false));
  EXPECT_TRUE(s.value("threads_constant", false));
  EXPECT_TRUE(s.value("pass", false)) << s.dump(2);
}

TEST(SoakCheck, ADaemonThatKeeps32KilobytesPerRemovalFails) {
  constexpr double kLeakPerCycle = 2 * 32768.0;  // two objects removed per cycle
  const auto s = quick_soak("TETCOLLIDED_TEST_LEAK_BYTES_PER_REMOVAL=32768");
  EXPECT_EQ(s.value("failed_cycles", -1), 0);
  EXPECT_TRUE(s.value("heap_read", false));
  EXPECT_FALSE(s.value("heap_flat", true)) << s.dump(2);
  EXPECT_FALSE(s.value("pass", true));
  // The leak is measured at its size (the healthy daemon's own few KB per cycle on top).
  const double slope = s.value("heap_slope_bytes_per_cycle", 0.0);
  EXPECT_GT(slope, 0.9 * kLeakPerCycle) << s.dump(2);
  EXPECT_LT(slope, 1.2 * kLeakPerCycle) << s.dump(2);
  // Nothing else is wrong with that daemon.
  EXPECT_TRUE(s.value("fds_constant", false));
  EXPECT_TRUE(s.value("threads_constant", false));
}

}  // namespace
}  // namespace tc::itest
