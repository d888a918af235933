// Which copy of the vector kernels runs: a kernel built twice, for the x86-64 baseline and
// for AVX2 (a file included twice, once inside TC_AVX2_REGION_BEGIN/END, or an
// always_inline lane loop called from a plain function and from an AVX2 one;
// target_clones.hpp), asks use_avx2_kernels() which to run. Inline: some kernels ask once
// per call of a few hundred nanoseconds.
#pragma once

#include <atomic>

#include "core/common/target_clones.hpp"

namespace tc {

namespace detail {
/// Whether this CPU has AVX2 (__builtin_cpu_supports).
bool cpu_has_avx2();
/// Set by use_baseline_kernels().
extern std::atomic<bool> g_baseline_only;

/// Tests only: with `on`, every kernel runs its x86-64 baseline copy even on a CPU with
/// AVX2, so that one machine tests both copies (they give the same bits). Default off; set
/// it only while no other thread runs these kernels.
void use_baseline_kernels(bool on);
}  // namespace detail

/// True when the AVX2 copies are to run: they were built (TC_HAS_AVX2_REGION), this CPU
/// has AVX2 (checked once) and no test asked for the baseline.
inline bool use_avx2_kernels() {
#if TC_HAS_AVX2_REGION
  static const bool has = detail::cpu_has_avx2();
  return has && !detail::g_baseline_only.load(std::memory_order_relaxed);
#else
  return false;
#endif
}

/// `avx2` when use_avx2_kernels(), else `baseline`: the two copies of one kernel.
template <typename Kernel>
Kernel pick_kernel(Kernel baseline, Kernel avx2) {
  return use_avx2_kernels() ? avx2 : baseline;
}

}  // namespace tc
