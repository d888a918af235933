// bench/core_latency.hpp: the core-to-core probe the benchmarks print beside their
// 2-thread times (docs/BENCHMARKS.md, "Machines").
#include "core_latency.hpp"

#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>

#include <cmath>

namespace {

cpu_set_t affinity() {
  cpu_set_t set;
  CPU_ZERO(&set);
  pthread_getaffinity_np(pthread_self(), sizeof set, &set);
  return set;
}

TEST(CoreLatency, GivesAFiniteRoundTripOnTwoCpusAndNaNOnOne) {
  const cpu_set_t before = affinity();
  const double ns = tc::bench::core_round_trip_ns(500, 3);
  if (CPU_COUNT(&before) >= 2) {
    ASSERT_TRUE(std::isfinite(ns));
    EXPECT_GT(ns, 0.0);
    EXPECT_LT(ns, 1e6);  // a cache line, not a scheduler time slice
  } else {
    EXPECT_TRUE(std::isnan(ns));
  }
  // The caller's affinity mask is given back.
  cpu_set_t after = affinity();
  EXPECT_TRUE(CPU_EQUAL(&before, &after));
}

TEST(CoreLatency, IsNaNWhenTheProcessMayUseOneCpu) {
  const cpu_set_t saved = affinity();
  int first = 0;
  while (first < CPU_SETSIZE && !CPU_ISSET(first, &saved)) ++first;
  ASSERT_LT(first, CPU_SETSIZE);
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(first, &one);
  ASSERT_EQ(sched_setaffinity(0, sizeof one, &one), 0);
  const double ns = tc::bench::core_round_trip_ns(100, 1);
  sched_setaffinity(0, sizeof saved, &saved);
  EXPECT_TRUE(std::isnan(ns));
}

}  // namespace
