// How long a cache line takes to go from one core to another and back, measured with two
// threads pinned to the first two CPUs this process may use (docs/BENCHMARKS.md,
// "Machines"). On a virtual machine the two vCPUs can sit on cores that share a cache or
// on cores that do not, and the host can move them while a benchmark runs: the same binary then
// measures ~60 ns here one minute and ~320 ns the next. Every 2-thread result moves with it,
// because every parallel loop hands data from one core to the other; the benchmarks report this
// probe beside their times so that a reader can tell the two cases apart.
#pragma once

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <limits>
#include <thread>
#include <vector>

namespace tc::bench {

namespace detail {

inline bool pin_to(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return pthread_setaffinity_np(pthread_self(), sizeof set, &set) == 0;
}

}  // namespace detail

/// Median round trip (ns) of one cache line between two threads pinned to the first two
/// CPUs of this process's affinity mask, over `batches` batches of `rounds` round trips.
/// NaN when fewer than two CPUs are available or pinning fails. Restores the calling
/// thread's affinity mask.
inline double core_round_trip_ns(int rounds = 4000, int batches = 5) {
  cpu_set_t mask;
  CPU_ZERO(&mask);
  if (sched_getaffinity(0, sizeof mask, &mask) != 0)
    return std::numeric_limits<double>::quiet_NaN();
  std::vector<int> cpus;
  for (int c = 0; c < CPU_SETSIZE && cpus.size() < 2; ++c)
    if (CPU_ISSET(c, &mask)) cpus.push_back(c);
  if (cpus.size() < 2) return std::numeric_limits<double>::quiet_NaN();

  cpu_set_t saved;
  CPU_ZERO(&saved);
  pthread_getaffinity_np(pthread_self(), sizeof saved, &saved);
  // The line both threads write, alone in its cache line.
  struct alignas(64) Line {
    std::atomic<long> value{0};
  } line;
  std::atomic<bool> pinned_ok{true};
  const long total = static_cast<long>(rounds) * batches;
  std::thread echo([&] {
    if (!detail::pin_to(cpus[1])) pinned_ok = false;
    for (long i = 0; i < total; ++i) {
      while (line.value.load(std::memory_order_acquire) != 2 * i + 1) {
        if (!pinned_ok.load(std::memory_order_relaxed)) return;
      }
      line.value.store(2 * i + 2, std::memory_order_release);
    }
  });
  std::vector<double> per_batch;
  if (!detail::pin_to(cpus[0])) pinned_ok = false;
  for (int b = 0; b < batches && pinned_ok; ++b) {
    const auto start = std::chrono::steady_clock::now();
    for (long i = static_cast<long>(b) * rounds; i < static_cast<long>(b + 1) * rounds; ++i) {
      line.value.store(2 * i + 1, std::memory_order_release);
      while (line.value.load(std::memory_order_acquire) != 2 * i + 2) {
        if (!pinned_ok.load(std::memory_order_relaxed)) break;
      }
    }
    per_batch.push_back(
        std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count() /
        rounds);
  }
  // A failed pin on either side stops both loops (they poll pinned_ok).
  echo.join();
  pthread_setaffinity_np(pthread_self(), sizeof saved, &saved);
  if (!pinned_ok) return std::numeric_limits<double>::quiet_NaN();
  std::sort(per_batch.begin(), per_batch.end());
  return per_batch[per_batch.size() / 2];
}

/// Adds the probe taken before a 2-thread benchmark's timed loop (`before`) and one taken
/// now to its counters as core_rt_before_ns and core_rt_after_ns (`State`: a Google
/// Benchmark state; a template so that this header needs no benchmark library).
template <typename State>
void add_core_round_trips(State& state, double before) {
  state.counters["core_rt_before_ns"] = before;
  state.counters["core_rt_after_ns"] = core_round_trip_ns();
}

}  // namespace tc::bench
