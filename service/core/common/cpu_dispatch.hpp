// Which copy of the vector kernels runs: a file that holds a baseline copy and an AVX2
// copy of its hot loops (TC_AVX2_REGION_BEGIN, target_clones.hpp; tet_overlap.cpp) asks
// use_avx2_kernels() once per call.
#pragma once

namespace tc {

/// True when the AVX2 copies are to run: they were built (TC_HAS_AVX2_REGION), this CPU
/// has AVX2 (checked once) and no test asked for the baseline.
bool use_avx2_kernels();

namespace detail {
/// Tests only: with `on`, every kernel runs its x86-64 baseline copy even on a CPU with
/// AVX2, so that one machine tests both copies (they give the same bits). Default off; set
/// it only while no other thread runs these kernels.
void use_baseline_kernels(bool on);
}  // namespace detail

}  // namespace tc
