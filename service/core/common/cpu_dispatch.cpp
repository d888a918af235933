#include "core/common/cpu_dispatch.hpp"

namespace tc {

std::atomic<bool> detail::g_baseline_only{false};

bool detail::cpu_has_avx2() {
#if defined(__x86_64__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") != 0;
#else
  return false;
#endif
}

void detail::use_baseline_kernels(bool on) {
  g_baseline_only.store(on, std::memory_order_relaxed);
}

}  // namespace tc
