// Two copies of the vector kernels, one built for AVX2 and one for the x86-64 baseline,
// with the same operations in the same order (so the same bits); use_avx2_kernels()
// (cpu_dispatch.hpp) picks one at run time, and tests run both. (The name is that of the
// GCC attribute the kernels used before, target_clones: its ifunc picked the AVX2 copy on
// every machine the tests ran on, so the baseline copy was never tested.)
//
// No AVX2 copies under ThreadSanitizer (its programs had crashed at start-up with
// target_clones' ifunc resolvers; the baseline copy runs there) nor off x86-64.
#pragma once

#if defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define TC_NO_TARGET_CLONES 1
#endif
#endif
#if defined(__SANITIZE_THREAD__) || !defined(__x86_64__)
#define TC_NO_TARGET_CLONES 1
#endif

// Two ways to build the AVX2 copy:
// - TC_AVX2_REGION_BEGIN ... TC_AVX2_REGION_END: every function defined between them is
//   built for AVX2 (GCC: #pragma GCC target; Clang: #pragma clang attribute), inline
//   helpers included, so a file can include its vector code a second time there
//   (fast_sat.inc, motion_pass.inc). Helpers defined inside the region get the AVX2 forms
//   of their operations too.
// - An always_inline lane loop called from a plain function and from one with
//   __attribute__((target("avx2"))): the loop is inlined into both and built for each.
// Only where TC_HAS_AVX2_REGION is 1 (not under TSan, nor off x86-64). TC_AVX2_TARGET is the
// attribute of the second way's AVX2 copy; where there is no AVX2 copy it is empty, the copy
// is a second baseline copy, and use_avx2_kernels() never picks it.
#if defined(TC_NO_TARGET_CLONES)
#define TC_HAS_AVX2_REGION 0
#define TC_AVX2_TARGET
#else
#define TC_AVX2_TARGET __attribute__((target("avx2")))
#endif
#if defined(TC_NO_TARGET_CLONES)
#elif defined(__clang__)
#define TC_HAS_AVX2_REGION 1
#define TC_AVX2_REGION_BEGIN \
  _Pragma("clang attribute push(__attribute__((target(\"avx2\"))), apply_to = function)")
#define TC_AVX2_REGION_END _Pragma("clang attribute pop")
#else
#define TC_HAS_AVX2_REGION 1
#define TC_AVX2_REGION_BEGIN _Pragma("GCC push_options") _Pragma("GCC target(\"avx2\")")
#define TC_AVX2_REGION_END _Pragma("GCC pop_options")
#endif
