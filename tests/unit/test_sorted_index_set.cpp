// service/core/mesh/sorted_index_set.hpp: the bitmap set gives the list a sort and
// unique of its inserts give, and leaves its bitmap all zero for the next use.
#include "core/mesh/sorted_index_set.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

namespace tc::detail {
namespace {

std::vector<Index> sorted_unique(std::vector<Index> v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

bool all_zero(const std::vector<std::uint64_t>& words) {
  return std::all_of(words.begin(), words.end(), [](std::uint64_t w) { return w == 0; });
}

struct Case {
  std::size_t n;       ///< universe [0, n)
  std::size_t count;   ///< inserts
  std::size_t window;  ///< inserts drawn from [base, base + window)
};

class SortedIndexSetCases : public ::testing::TestWithParam<Case> {};

TEST_P(SortedIndexSetCases, DrainIsTheSortedUniqueInsertsAndClearsTheBitmap) {
  const Case c = GetParam();
  std::mt19937_64 rng(1234 + c.n * 7 + c.count);
  std::vector<std::uint64_t> words;  // reused across rounds, as detection does
  for (int round = 0; round < 20; ++round) {
    const std::size_t window = std::min(c.window, c.n);
    const std::size_t base = std::uniform_int_distribution<std::size_t>(0, c.n - window)(rng);
    std::uniform_int_distribution<std::size_t> pick(base, base + window - 1);
    std::vector<Index> inserts;
    for (std::size_t k = 0; k < c.count; ++k) inserts.push_back(static_cast<Index>(pick(rng)));
    // Word boundaries and the ends of the universe.
    if (round % 4 == 0) {
      inserts.push_back(0);
      inserts.push_back(static_cast<Index>(c.n - 1));
      if (c.n > 64) inserts.push_back(63), inserts.push_back(64);
    }
    std::vector<Index> got = {-7};  // drain appends
    {
      SortedIndexSet set(words, c.n);
      for (const Index i : inserts) set.insert(i);
      set.drain(got);
      ASSERT_TRUE(all_zero(words)) << "round " << round;
      // A drained set is empty and reusable.
      const Index one = static_cast<Index>(c.n / 2);
      set.insert(one);
      std::vector<Index> again;
      set.drain(again);
      ASSERT_EQ(again, std::vector<Index>{one});
    }
    std::vector<Index> want = {-7};
    for (const Index i : sorted_unique(inserts)) want.push_back(i);
    ASSERT_EQ(got, want) << "round " << round;
    ASSERT_EQ(words.size(), (c.n + 63) / 64);
  }
}

INSTANTIATE_TEST_SUITE_P(Sizes, SortedIndexSetCases,
                         ::testing::Values(Case{1, 3, 1}, Case{64, 10, 64}, Case{65, 200, 65},
                                           Case{1000, 0, 1000}, Case{1000, 5, 1000},
                                           Case{10000, 3000, 10000}, Case{10000, 3000, 200},
                                           Case{300000, 5000, 300000}));

TEST(SortedIndexSet, DestructorClearsAnUndrainedSet) {
  std::vector<std::uint64_t> words;
  {
    SortedIndexSet set(words, 500);
    set.insert(3);
    set.insert(499);
    set.insert(130);
  }
  EXPECT_TRUE(all_zero(words));
  EXPECT_EQ(words.size(), 8U);
}

}  // namespace
}  // namespace tc::detail
