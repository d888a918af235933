// TC_TARGET_CLONES_AVX2: one AVX2 copy and one x86-64 baseline copy of a function, picked
// at load time by an ifunc resolver. Left out under ThreadSanitizer: the dynamic loader
// runs the resolver before the TSan runtime is initialised, and the resolver is
// instrumented (every TSan program linking such a function crashed at start-up). Left out
// off x86-64 too.
#pragma once

#if defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define TC_NO_TARGET_CLONES 1
#endif
#endif
#if defined(__SANITIZE_THREAD__) || !defined(__x86_64__)
#define TC_NO_TARGET_CLONES 1
#endif

#if defined(TC_NO_TARGET_CLONES)
#define TC_TARGET_CLONES_AVX2
#else
#define TC_TARGET_CLONES_AVX2 __attribute__((target_clones("avx2", "default")))
#endif

// TC_AVX2_REGION_BEGIN ... TC_AVX2_REGION_END: every function defined between them is built
// for AVX2 (GCC: #pragma GCC target; Clang: #pragma clang attribute), inline helpers
// included, so a file can hold a second, AVX2 copy of its vector code and pick one at run
// time (tet_overlap.cpp, use_avx2_kernels() in cpu_dispatch.hpp). Unlike target_clones, helpers
// defined inside the region get the AVX2 forms of their operations too. Only where
// TC_HAS_AVX2_REGION is 1: the same places as target_clones (not under TSan, where the baseline
// copy is picked anyway, nor off x86-64).
#if defined(TC_NO_TARGET_CLONES)
#define TC_HAS_AVX2_REGION 0
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
