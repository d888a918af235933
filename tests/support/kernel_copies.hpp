// Tests of the vector kernels built in two copies, AVX2 and the x86-64 baseline
// (use_avx2_kernels() in core/common/cpu_dispatch.hpp): a fixture that runs a test with
// each copy, so that one machine tests both.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "core/common/cpu_dispatch.hpp"

namespace tc::test {

/// Runs the test with the x86-64 baseline copy of every kernel when the parameter is true,
/// with the copy this CPU picks otherwise (and that copy again after the test, even when an
/// assertion failed). Instantiate with ::testing::Bool() and kernel_copy_name.
class BothKernels : public ::testing::TestWithParam<bool> {
 protected:
  void SetUp() override { detail::use_baseline_kernels(GetParam()); }
  void TearDown() override { detail::use_baseline_kernels(false); }
};

/// "ThisCpu" or "Baseline", for the test's name.
inline std::string kernel_copy_name(const ::testing::TestParamInfo<bool>& info) {
  return info.param ? "Baseline" : "ThisCpu";
}

}  // namespace tc::test
