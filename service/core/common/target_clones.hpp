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
