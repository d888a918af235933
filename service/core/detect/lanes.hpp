// Internal to service/core/detect: four doubles per vector for the exact tests
// (tet_overlap.cpp) and the broad phase's clipped boxes (broad_phase.cpp). One AVX
// register where the function is an AVX2 clone (TC_TARGET_CLONES_AVX2), two SSE2
// registers on baseline x86-64; arithmetic and comparisons act lane by lane and are
// IEEE-exact like the scalar code they reproduce. Both files are built with
// -ffp-contract=off (no fused multiply-add, whatever -march is given), so a lane gives
// the bits of the scalar expression it mirrors. Everything here has internal linkage:
// the 32-byte vectors never cross a translation unit (the ABI change GCC and Clang warn
// about for them without AVX, -Wpsabi, cannot matter).
#pragma once

#include <emmintrin.h>  // SSE2 (x86-64 baseline): _mm_movemask_pd

#include <cstdint>
#include <cstring>

namespace tc {
namespace {  // internal linkage on purpose (see above)

#define TC_INLINE [[gnu::always_inline]] inline

/// Four doubles in one vector; lane masks are -1 or 0.
using V4 = double __attribute__((vector_size(32)));
using M4 = std::int64_t __attribute__((vector_size(32)));

TC_INLINE V4 load4(const double* p) {
  V4 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
TC_INLINE V4 splat(double x) {
  return V4{x, x, x, x};
}
/// std::min(a, b) and std::max(a, b) lane by lane (same lane chosen for NaN and +-0; the
/// form of the x86 min/max instructions, and of Eigen's cwiseMin/cwiseMax(a, b)).
TC_INLINE V4 vmin(V4 a, V4 b) {
  return b < a ? b : a;
}
TC_INLINE V4 vmax(V4 a, V4 b) {
  return a < b ? b : a;
}
/// dot3 lane by lane, same order: (x X + y Y) + z Z.
TC_INLINE V4 vdot(V4 x, V4 y, V4 z, V4 X, V4 Y, V4 Z) {
  return x * X + y * Y + z * Z;
}
/// Bit k set when lane k of m is set.
TC_INLINE unsigned lanes(M4 m) {
  const V4 d = reinterpret_cast<V4>(m);
  const __m128d lo = __builtin_shufflevector(d, d, 0, 1), hi = __builtin_shufflevector(d, d, 2, 3);
  return static_cast<unsigned>(_mm_movemask_pd(lo) | _mm_movemask_pd(hi) << 2);
}

}  // namespace
}  // namespace tc
