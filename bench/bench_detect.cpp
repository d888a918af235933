// Detection stage (service/core/detect): whole per-frame detection (set_positions of both
// objects + Detector::detect, no file I/O) for each broad phase at 1 and 2 threads.
//
//   TorusBox/<broad>/<threads>/<sink_um>   data/meshes/torus.msh (6,947 tets) lying flat
//       on the top face of data/meshes/box.msh (3,276 tets), sunk by sink_um micrometres
//       (the torus tube has radius 0.1 m; the box top is z = 0.15 m)
//   LargeBoxes/<broad>/<threads>           two structured boxes of 37^3 x 6 = 303,918 tets
//       ([0,1]^3), B shifted by 0.9 m along x (10% overlap) and by a fraction of a cell
//       along y and z so that no faces coincide
//   NarrowPairs/<fast>/<sink_um>           the exact tet-tet test alone on the torus/box
//       pairs whose tet boxes overlap (what the broad phase hands over), per pair:
//       fast = 0 tets_overlap_reference (scalar), 1 tets_overlap (vectorised), 2
//       tets_overlap_pairs over runs of 256 pairs (the narrow phase's call)
//   CoreRoundTrip                          one cache line between two pinned threads and
//       back (bench/core_latency.hpp): which kind of core pair this machine gives now
//
// Time is wall-clock (UseRealTime); counters give the candidate and overlapping pairs,
// the broad/narrow split and, on 2 threads, the core-to-core round trip before and after
// (core_rt_*_ns, bench/core_latency.hpp). Results and commands: docs/BENCHMARKS.md.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <vector>

#include "core/detect/detect.hpp"
#include "core/detect/tet_overlap.hpp"
#include "core/io/mesh_io.hpp"
#include "core/mesh/topology.hpp"
#include "core_latency.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

struct Object {
  TetMesh mesh;
  Topology topo;
};

std::unique_ptr<Object> make_object(TetMesh mesh) {
  auto o = std::make_unique<Object>();
  o->mesh = std::move(mesh);
  o->topo = build_topology(o->mesh.tets, o->mesh.num_nodes());
  return o;
}

const Object* data_mesh(const char* name) {
  const std::filesystem::path path = std::filesystem::path(TC_SOURCE_DIR) / "data/meshes" / name;
  auto mesh = read_mesh(path);
  if (!mesh) {
    std::fprintf(stderr, "bench_detect: %s\n", mesh.error().message.c_str());
    return nullptr;
  }
  return make_object(std::move(*mesh)).release();
}

const Object* torus() {
  static const Object* o = data_mesh("torus.msh");
  return o;
}
const Object* box() {
  static const Object* o = data_mesh("box.msh");
  return o;
}

constexpr int kLargeCells = 37;  // 37^3 cubes x 6 = 303,918 tets

const Object* large_a() {
  static const Object* o =
      make_object(test::structured_box(kLargeCells, kLargeCells, kLargeCells,
                                       Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()))
          .release();
  return o;
}
const Object* large_b() {
  static const Object* o = [] {
    const double h = 1.0 / kLargeCells;
    const Eigen::Vector3d lo(0.9, 0.31 * h, 0.17 * h);
    return make_object(test::structured_box(kLargeCells, kLargeCells, kLargeCells, lo,
                                            lo + Eigen::Vector3d::Ones()))
        .release();
  }();
  return o;
}

/// Runs frames of detection between a and b (b translated by move_b).
void run_frames(benchmark::State& state, const Object* a, const Object* b,
                const Eigen::Vector3d& move_b) {
  if (a == nullptr || b == nullptr) {
    state.SkipWithError("mesh not available");
    return;
  }
  const auto kind = static_cast<BroadPhaseKind>(state.range(0));
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(state.range(1)));
  Positions pb = b->mesh.positions;
  pb.colwise() += move_b;
  DetectOptions options;
  options.broad_phase = kind;
  CollisionBody body_a(a->mesh.tets, a->topo);
  CollisionBody body_b(b->mesh.tets, b->topo);
  Detector detector(options);
  PairContacts contacts;
  DetectStats stats;
  // One untimed frame: builds the per-topology AABB trees (kBvh), sizes the buffers.
  body_a.set_positions(a->mesh.positions);
  body_b.set_positions(pb);
  detector.detect(body_a, body_b, contacts, &stats);
  const double core_rt_before = state.range(1) > 1 ? bench::core_round_trip_ns() : 0.0;
  double broad = 0.0, narrow = 0.0, bounds = 0.0, intrusion = 0.0;
  for (auto _ : state) {
    body_a.set_positions(a->mesh.positions);
    body_b.set_positions(pb);
    detector.detect(body_a, body_b, contacts, &stats);
    benchmark::DoNotOptimize(contacts.overlapping.data());
    broad += stats.broad_ms;
    narrow += stats.narrow_ms;
    bounds += stats.bounds_ms;
    intrusion += stats.intrusion_ms;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["candidates"] = static_cast<double>(stats.candidates);
  state.counters["overlapping"] = static_cast<double>(stats.overlapping);
  state.counters["edges"] =
      static_cast<double>(contacts.edges_a_in_b.size() + contacts.edges_b_in_a.size());
  state.counters["broad_ms"] = broad / n;
  state.counters["narrow_ms"] = narrow / n;
  state.counters["bounds_ms"] = bounds / n;
  state.counters["intrusion_ms"] = intrusion / n;
  // Which kind of core pair the two threads ran on (bench/core_latency.hpp).
  if (state.range(1) > 1) bench::add_core_round_trips(state, core_rt_before);
  state.SetLabel(std::string(broad_phase_name(kind)));
}

void TorusBox(benchmark::State& state) {
  // Torus centre at z = 0.15 + 0.1 - sink: its lowest point is `sink` below the box top.
  const double sink = static_cast<double>(state.range(2)) * 1e-6;
  run_frames(state, box(), torus(), Eigen::Vector3d(0.0, 0.0, 0.25 - sink));
}

void LargeBoxes(benchmark::State& state) {
  run_frames(state, large_a(), large_b(), Eigen::Vector3d::Zero());
}

/// Geometry of every tet (metres) and the (tet of a, tet of b) pairs whose boxes overlap.
struct PairSet {
  std::vector<TetGeometry> a, b;
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
};

PairSet box_pairs(const Object& a, const Object& b, const Eigen::Vector3d& move_b) {
  PairSet s;
  Positions pb = b.mesh.positions;
  pb.colwise() += move_b;
  for (const Tet& t : a.mesh.tets)
    s.a.push_back(make_tet_geometry(tet_corners(a.mesh.positions, t)));
  for (const Tet& t : b.mesh.tets) s.b.push_back(make_tet_geometry(tet_corners(pb, t)));
  for (std::size_t i = 0; i < s.a.size(); ++i)
    for (std::size_t j = 0; j < s.b.size(); ++j)
      if ((s.a[i].lo.array() <= s.b[j].hi.array()).all() &&
          (s.b[j].lo.array() <= s.a[i].hi.array()).all())
        s.pairs.emplace_back(i, j);
  return s;
}

void NarrowPairs(benchmark::State& state) {
  const Object *a = box(), *b = torus();
  if (a == nullptr || b == nullptr) {
    state.SkipWithError("mesh not available");
    return;
  }
  const double sink = static_cast<double>(state.range(1)) * 1e-6;
  const PairSet s = box_pairs(*a, *b, Eigen::Vector3d(0.0, 0.0, 0.25 - sink));
  using Test = bool (*)(const TetGeometry&, const TetGeometry&, double);
  const Test test = state.range(0) == 1 ? Test{&tets_overlap} : Test{&tets_overlap_reference};
  const double rel = kDefaultRelativeTolerance;
  std::size_t overlapping = 0;
  // fast = 2: the narrow phase's call, tets_overlap_pairs() over runs of 256 pairs.
  constexpr std::size_t kRun = 256;
  std::vector<GeometryPair> batch;
  for (const auto& [i, j] : s.pairs) batch.push_back({&s.a[i], &s.b[j]});
  std::array<bool, kRun> hits{};
  for (auto _ : state) {
    overlapping = 0;
    if (state.range(0) == 2) {
      for (std::size_t begin = 0; begin < batch.size(); begin += kRun) {
        const std::size_t n = std::min(kRun, batch.size() - begin);
        tets_overlap_pairs({batch.data() + begin, n}, rel, {hits.data(), n});
        for (std::size_t k = 0; k < n; ++k) overlapping += hits[k] ? 1 : 0;
      }
    } else {
      for (const auto& [i, j] : s.pairs)
        overlapping += test(s.a[i], s.b[j], rel * pair_scale(s.a[i], s.b[j])) ? 1 : 0;
    }
    benchmark::DoNotOptimize(overlapping);
  }
  state.counters["pairs"] = static_cast<double>(s.pairs.size());
  state.counters["overlapping"] = static_cast<double>(overlapping);
  state.counters["ns_per_pair"] = benchmark::Counter(
      static_cast<double>(s.pairs.size()),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.SetLabel(state.range(0) == 2   ? "vectorised, runs of pairs"
                 : state.range(0) == 1 ? "vectorised"
                                       : "reference");
}

/// One cache line between two threads pinned to two cores and back, per round trip
/// (bench/core_latency.hpp); an iteration is a batch of 2,000 round trips. With
/// --benchmark_repetitions it shows how often the two vCPUs of a virtual machine sit on
/// cores that share a cache (~60 ns here) and how often not (~320 ns).
void CoreRoundTrip(benchmark::State& state) {
  for (auto _ : state) {
    const double ns = bench::core_round_trip_ns(2000, 1);
    if (std::isnan(ns)) {
      state.SkipWithError("needs two CPUs this process may pin threads to");
      return;
    }
    state.SetIterationTime(ns * 1e-9);
  }
}

void torus_args(benchmark::internal::Benchmark* b) {
  for (const int kind : {0, 1, 2, 3})
    for (const int threads : {1, 2}) b->Args({kind, threads, 10000});
  for (const int sink : {5000, 20000, 50000})
    for (const int threads : {1, 2}) b->Args({3, threads, sink});
}

void large_args(benchmark::internal::Benchmark* b) {
  for (const int kind : {0, 1, 2, 3})
    for (const int threads : {1, 2}) b->Args({kind, threads});
}

BENCHMARK(TorusBox)
    ->Apply(torus_args)
    ->ArgNames({"broad", "threads", "sink_um"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(0.5);
BENCHMARK(NarrowPairs)
    ->ArgsProduct({{0, 1, 2}, {5000, 10000}})
    ->ArgNames({"fast", "sink_um"})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime()
    ->MinTime(0.5);
BENCHMARK(CoreRoundTrip)->Unit(benchmark::kNanosecond)->UseManualTime()->Iterations(20);
BENCHMARK(LargeBoxes)
    ->Apply(large_args)
    ->ArgNames({"broad", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2.0);

}  // namespace
}  // namespace tc

BENCHMARK_MAIN();
