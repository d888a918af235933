// Internal to service/core/detect: four doubles per vector for the exact tests
// (tet_overlap.cpp) and the broad phase's clipped boxes (clipped_box.cpp). One AVX
// register where the function is built for AVX2 (target_clones.hpp), two SSE2
// registers on baseline x86-64 (an AVX2 copy still gets the baseline's splat and lane
// mask from these helpers: lane_ops.inc says how a file gets the AVX2 forms of them
// too); arithmetic and comparisons act lane by lane and are
// IEEE-exact like the scalar code they reproduce. Both files are built with
// -ffp-contract=off (no fused multiply-add, whatever -march is given), so a lane gives
// the bits of the scalar expression it mirrors. Everything here has internal linkage:
// the 32-byte vectors never cross a translation unit (the ABI change GCC and Clang warn
// about for them without AVX, -Wpsabi, cannot matter).
#pragma once

#include <emmintrin.h>  // SSE2 (x86-64 baseline): _mm_movemask_pd
#include <immintrin.h>  // AVX: _mm256_movemask_pd, where lane_ops.inc is built for AVX2

#include <cstdint>
#include <cstring>

namespace tc {
namespace {  // internal linkage on purpose (see above)

#define TC_INLINE [[gnu::always_inline]] inline

/// Four doubles in one vector; lane masks are -1 or 0.
using V4 = double __attribute__((vector_size(32)));
using M4 = std::int64_t __attribute__((vector_size(32)));

#define TC_LANE_OPS_AVX2 0
#include "core/detect/lane_ops.inc"  // load4, splat, vmin, vmax, vdot, lanes
#undef TC_LANE_OPS_AVX2

}  // namespace
}  // namespace tc
