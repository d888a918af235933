#include "core/common/cpu_dispatch.hpp"

#include <atomic>

#include "core/common/target_clones.hpp"

namespace tc {
namespace {
std::atomic<bool> g_baseline_only{false};
}  // namespace

bool use_avx2_kernels() {
#if TC_HAS_AVX2_REGION
  static const bool has = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return has && !g_baseline_only.load(std::memory_order_relaxed);
#else
  return false;
#endif
}

void detail::use_baseline_kernels(bool on) {
  g_baseline_only.store(on, std::memory_order_relaxed);
}

}  // namespace tc
