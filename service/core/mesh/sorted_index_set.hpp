// Internal to service/core: a sorted set of small indices without a sort (detection and
// the per-frame shape check).
#pragma once

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/mesh/tet_mesh.hpp"

namespace tc::detail {

/// A set of indices in [0, n) held in a caller-owned bitmap of ceil(n / 64) words that
/// is all zero between uses: members are inserted in any order (repeats cost nothing)
/// and drain() appends them in increasing order and clears the bitmap again. Cost
/// O(inserts + words between the smallest and the largest member), against
/// O(k log k) for sorting the k inserts and removing repeats, which it replaces
/// (the same list, tested in tests/unit/test_sorted_index_set.cpp).
class SortedIndexSet {
 public:
  /// @param[in,out] words  the bitmap, grown (with zeros) to ceil(n / 64) words if shorter;
  ///                       must be all zero
  /// @param[in] n          members are in [0, n)
  SortedIndexSet(std::vector<std::uint64_t>& words, std::size_t n) : words_(words) {
    const std::size_t count = (n + 63) / 64;
    if (words_.size() < count) words_.resize(count, 0);
  }
  SortedIndexSet(const SortedIndexSet&) = delete;
  SortedIndexSet& operator=(const SortedIndexSet&) = delete;
  /// Leaves the bitmap all zero even when drain() was not called.
  ~SortedIndexSet() {
    for (std::size_t w = lo_; w < hi_; ++w) words_[w] = 0;
  }

  /// Adds index i, 0 <= i < n.
  void insert(Index i) {
    const auto w = static_cast<std::size_t>(i) >> 6;
    words_[w] |= std::uint64_t{1} << (static_cast<unsigned>(i) & 63U);
    lo_ = std::min(lo_, w);
    hi_ = std::max(hi_, w + 1);
  }

  /// Appends the members to `out` in increasing order and empties the set.
  void drain(std::vector<Index>& out) {
    for (std::size_t w = lo_; w < hi_; ++w) {
      for (std::uint64_t x = words_[w]; x != 0; x &= x - 1)
        out.push_back(static_cast<Index>(w * 64 + static_cast<std::size_t>(std::countr_zero(x))));
      words_[w] = 0;
    }
    lo_ = std::numeric_limits<std::size_t>::max();
    hi_ = 0;
  }

 private:
  std::vector<std::uint64_t>& words_;
  std::size_t lo_ = std::numeric_limits<std::size_t>::max();  ///< first word in use
  std::size_t hi_ = 0;                                        ///< one past the last
};

}  // namespace tc::detail
