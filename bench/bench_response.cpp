// Micro-benchmarks of the response stage (service/core/response) on synthetic contact
// sets, serial unless named ParallelPath: a fine box A resting 0.05 m deep on a box B (16 x 16 x 4
// cells), half-space depths, contacts found by brute force during setup (not timed). Arg: A's cells
// per side (21: about 650 point contacts and 5000 segment pieces). Compare segment against point in
// the same run (the paper's Fig. 13 reports 36 s vs 28 s, 1.29x, for the whole collision process).
//
//   build/bin/bench_response --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <limits>
#include <map>
#include <memory>

#include "core/response/response.hpp"
#include "response_fixtures.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

struct Scene {
  test::TestObject a;
  test::TestObject b;
  PairContacts contacts;
};

const Scene& scene(int cells) {
  static std::map<int, std::unique_ptr<Scene>> cache;
  auto& slot = cache[cells];
  if (!slot) {
    const Eigen::Vector3d lo_a(0.1, 0.1, 0.45), hi_a(0.9, 0.9, 0.7);
    const Eigen::Vector3d lo_b(0, 0, 0), hi_b(1, 1, 0.5);
    slot = std::make_unique<Scene>(
        Scene{test::TestObject(test::structured_box(cells, cells, 2, lo_a, hi_a)),
              test::TestObject(test::structured_box(16, 16, 4, lo_b, hi_b)),
              {}});
    slot->a.set_depth([&](const Eigen::Vector3d& x) { return x.z() - lo_a.z(); });
    slot->b.set_depth([&](const Eigen::Vector3d& x) { return hi_b.z() - x.z(); });
    slot->contacts = test::brute_force_contacts(slot->a, slot->b);
  }
  return *slot;
}

constexpr std::size_t kSerial = std::numeric_limits<std::size_t>::max();

void run(benchmark::State& state, ResponseKind kind, StiffnessMode mode,
         std::size_t parallel_threshold = kSerial) {
  const Scene& s = scene(static_cast<int>(state.range(0)));
  ResponseOptions o;
  o.kind = kind;
  o.stiffness_mode = mode;
  o.parallel_threshold = parallel_threshold;
  ResponseAccumulator acc;
  PairResponse out;
  for (auto _ : state) {
    if (!acc.compute(s.a.view(), s.b.view(), s.contacts, o, out)) state.SkipWithError("compute");
    benchmark::DoNotOptimize(out.a.forces.data());
    benchmark::ClobberMemory();
  }
  const std::size_t contacts = out.stats.point_contacts + out.stats.segment_contacts;
  state.counters["contacts"] = static_cast<double>(contacts);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * contacts));
}

void BM_Point(benchmark::State& s) {
  run(s, ResponseKind::kPoint, StiffnessMode::kNone);
}
void BM_PointLumped(benchmark::State& s) {
  run(s, ResponseKind::kPoint, StiffnessMode::kLumped);
}
void BM_PointExact(benchmark::State& s) {
  run(s, ResponseKind::kPoint, StiffnessMode::kExact);
}
void BM_Segment(benchmark::State& s) {
  run(s, ResponseKind::kSegment, StiffnessMode::kNone);
}
void BM_SegmentLumped(benchmark::State& s) {
  run(s, ResponseKind::kSegment, StiffnessMode::kLumped);
}
void BM_SegmentExact(benchmark::State& s) {
  run(s, ResponseKind::kSegment, StiffnessMode::kExact);
}
/// The same work through the TBB path (per-contact results in parallel, then the
/// ordered sum), against the serial loop above.
void BM_PointParallelPath(benchmark::State& s) {
  run(s, ResponseKind::kPoint, StiffnessMode::kNone, 1);
}
void BM_SegmentParallelPath(benchmark::State& s) {
  run(s, ResponseKind::kSegment, StiffnessMode::kNone, 1);
}
/// kAuto: the density measure over the contact tets, then the chosen kinds.
void BM_Auto(benchmark::State& s) {
  run(s, ResponseKind::kAuto, StiffnessMode::kNone);
}

BENCHMARK(BM_Point)->Arg(21)->Arg(42)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PointLumped)->Arg(21)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PointExact)->Arg(21)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Segment)->Arg(21)->Arg(42)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SegmentLumped)->Arg(21)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SegmentExact)->Arg(21)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PointParallelPath)->Arg(21)->Arg(42)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_SegmentParallelPath)->Arg(21)->Arg(42)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Auto)->Arg(21)->Arg(42)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace tc

BENCHMARK_MAIN();
