// service/daemon/registry: versions, cuts, pipeline verdicts and fallbacks.
#include "registry.hpp"

#include <gtest/gtest.h>

namespace tc::daemon {
namespace {

using Match = SceneRegistry::Match;

TEST(Registry, SubmitAndMatch) {
  SceneRegistry r;
  EXPECT_EQ(r.match("a", 1), Match::kUnknown);
  EXPECT_TRUE(r.submit("a", {1, 10, false}));
  EXPECT_EQ(r.match("a", 1), Match::kCurrent);
  EXPECT_EQ(r.match("a", 2), Match::kUnknown);  // may still arrive
  ASSERT_NE(r.current("a"), nullptr);
  EXPECT_EQ(r.current("a")->nodes, 10);
  EXPECT_FALSE(r.submit("a", {1, 10, false}));  // re-delivered sample
}

TEST(Registry, CutMakesOldVersionStale) {
  SceneRegistry r;
  r.submit("a", {1, 10, false});
  r.confirm("a", 1, true);
  r.submit("a", {2, 12, false});
  EXPECT_EQ(r.match("a", 1), Match::kStale);
  EXPECT_EQ(r.match("a", 2), Match::kCurrent);
  EXPECT_EQ(r.current("a")->nodes, 12);
}

TEST(Registry, FailedCutFallsBackToConfirmed) {
  SceneRegistry r;
  r.submit("a", {1, 10, false});
  r.confirm("a", 1, true);
  r.submit("a", {2, 12, false});
  r.confirm("a", 2, false);
  ASSERT_NE(r.current("a"), nullptr);
  EXPECT_EQ(r.current("a")->version, 1u);
  EXPECT_EQ(r.current("a")->nodes, 10);
  EXPECT_EQ(r.match("a", 1), Match::kCurrent);
}

TEST(Registry, FailedFirstVersionForgetsObject) {
  SceneRegistry r;
  r.submit("a", {1, 10, false});
  r.confirm("a", 1, false);
  EXPECT_EQ(r.current("a"), nullptr);
  EXPECT_TRUE(r.empty());
}

TEST(Registry, FailureOfOlderInFlightVersionKeepsNewer) {
  SceneRegistry r;
  r.submit("a", {1, 10, false});
  r.submit("a", {2, 12, false});
  r.confirm("a", 1, false);
  EXPECT_EQ(r.current("a")->version, 2u);
  r.confirm("a", 2, true);
  EXPECT_EQ(r.current("a")->version, 2u);
}

TEST(Registry, FailedNewestFallsBackToOlderInFlight) {
  SceneRegistry r;
  r.submit("a", {1, 10, false});
  r.submit("a", {2, 12, false});
  r.confirm("a", 2, false);  // verdicts come in job order; this one came first here
  EXPECT_EQ(r.current("a")->version, 1u);
}

TEST(Registry, ExpectedSkipsStaticAndIsSorted) {
  SceneRegistry r;
  r.submit("zeta", {1, 4, false});
  r.submit("floor", {1, 4, true});
  r.submit("alpha", {1, 4, false});
  EXPECT_EQ(r.expected(), (std::vector<std::string>{"alpha", "zeta"}));
  r.remove("alpha");
  EXPECT_EQ(r.expected(), (std::vector<std::string>{"zeta"}));
  EXPECT_EQ(r.size(), 2u);
}

TEST(Registry, LowerVersionReplacesToo) {
  // A restarted simulator may start again at version 1.
  SceneRegistry r;
  r.submit("a", {5, 10, false});
  EXPECT_TRUE(r.submit("a", {1, 8, false}));
  EXPECT_EQ(r.current("a")->version, 1u);
  EXPECT_EQ(r.match("a", 5), Match::kStale);
}

}  // namespace
}  // namespace tc::daemon
