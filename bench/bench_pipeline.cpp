// Whole pipeline (service/core/pipeline): what the service runs, without DDS.
//
//   TorusInBox/<threads>/<depth_um>   Pipeline::run_frame of the service's scene
//       (bench/service_latency): data/meshes/box.msh static, data/meshes/torus.msh
//       resting depth_um micrometres deep on it and bobbing by +-2 mm (one state per
//       frame, the torus only; 1000 frames a run, two periods of the bob). Counters:
//       the stage split of FrameStats and, on 2 threads, the core-to-core round trip
//       before and after (core_rt_*_ns, bench/core_latency.hpp).
//   TurningTorusInBox/<threads>/<depth_um>   the same with the torus also turning about
//       its own vertical axis, 0.01 rad a frame.
//   Register/<cells>                  Pipeline::set_topology of a structured box of
//       cells^3 x 6 tets (37: 303,918 tets, the service's "300k-tet object").
//   BuildTopology/<cells>             build_topology alone on the same mesh.
//
// Results and commands: docs/BENCHMARKS.md (Detection).
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <optional>

#include "core/detect/self_detect.hpp"
#include "core/io/mesh_io.hpp"
#include "core/mesh/topology.hpp"
#include "core/pipeline/pipeline.hpp"
#include "core_latency.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

std::optional<TetMesh> data_mesh(const char* name) {
  const std::filesystem::path path = std::filesystem::path(TC_SOURCE_DIR) / "data/meshes" / name;
  auto mesh = read_mesh(path);
  if (!mesh) {
    std::fprintf(stderr, "bench_pipeline: %s\n", mesh.error().message.c_str());
    return std::nullopt;
  }
  return std::move(*mesh);
}

/// TorusInBox and TurningTorusInBox: the torus turning about its own axis by `turn` rad a
/// frame (0: not turning).
void torus_in_box(benchmark::State& state, double turn, bool self_contact = false) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(state.range(0)));
  const double depth = static_cast<double>(state.range(1)) * 1e-6;
  auto torus = data_mesh("torus.msh");
  auto box = data_mesh("box.msh");
  if (!torus || !box) {
    state.SkipWithError("mesh not available");
    return;
  }
  // As bench/service_latency: the torus' lowest point `depth` below the box top (z 0.15).
  torus->positions.row(2).array() += 0.15 + 0.1 - depth;
  Pipeline pipeline;
  ObjectParams floor;
  floor.is_static = true;
  if (!pipeline.set_topology("box", 1, *box, floor) ||
      !pipeline.set_topology("torus", 1, *torus, [&] {
        ObjectParams p;
        p.self_contact = self_contact;
        return p;
      }())) {
    state.SkipWithError("registration failed");
    return;
  }
  std::vector<FrameObjectInput> states(1);
  states[0].object = "torus";
  states[0].topology_version = 1;
  std::int64_t frame = 0;
  double broad = 0.0, narrow = 0.0, depth_ms = 0.0, response = 0.0, total = 0.0;
  std::size_t contacts = 0;
  const Eigen::Vector3d axis_at = torus->positions.rowwise().mean();
  const auto run = [&] {
    const double dz = 0.002 * std::sin(2.0 * std::numbers::pi * static_cast<double>(frame) / 500.0);
    if (turn == 0.0) {
      states[0].positions = torus->positions;
    } else {  // (about the vertical axis through the torus' middle)
      const Eigen::Matrix3d r =
          Eigen::AngleAxisd(turn * static_cast<double>(frame), Eigen::Vector3d::UnitZ())
              .toRotationMatrix();
      states[0].positions = (r * (torus->positions.colwise() - axis_at)).colwise() + axis_at;
    }
    states[0].positions.row(2).array() += dz;
    return pipeline.run_frame_taking(frame++, states);  // as the daemon: no copy
  };
  run();  // untimed: builds the trees, the static box's depth map, sizes the buffers
  const double core_rt_before = state.range(0) > 1 ? bench::core_round_trip_ns() : 0.0;
  for (auto _ : state) {
    const FrameOutput out = run();
    benchmark::DoNotOptimize(out.forces.data());
    broad += out.stats.broad_ms;
    narrow += out.stats.narrow_ms;
    depth_ms += out.stats.depth_ms;
    response += out.stats.response_ms;
    total += out.stats.total_ms;
    contacts = out.stats.contacts;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["broad_ms"] = broad / n;
  state.counters["narrow_ms"] = narrow / n;
  state.counters["depth_ms"] = depth_ms / n;
  state.counters["response_ms"] = response / n;
  state.counters["total_ms"] = total / n;
  state.counters["contacts"] = static_cast<double>(contacts);
  // Which kind of core pair the two threads ran on (bench/core_latency.hpp).
  if (state.range(0) > 1) bench::add_core_round_trips(state, core_rt_before);
}

/// Frames a run: two whole periods of the bob (500 frames), so that binaries of different
/// speed average over the same frames (with a minimum time, a faster one ran more frames,
/// at other depths of the bob, and its stage counters were not comparable).
constexpr benchmark::IterationCount kFramesPerRun = 1000;

void TorusInBox(benchmark::State& state) {
  torus_in_box(state, 0.0);
}

/// The same with the torus turning about its own (vertical) axis by 0.01 rad a frame, as a
/// tool turned by a hand: the same contact, every node moved.
void TurningTorusInBox(benchmark::State& state) {
  torus_in_box(state, 0.01);
}

/// SelfGate/<mesh>/<jitter_um>: SelfCollider::detect on an object that does not touch
/// itself, every node moved each frame by a seeded offset in [-jitter, jitter]: 1 um stays
/// within the gate's certificate (one pass over the boundary nodes), 2 mm does not (the
/// whole gate every frame). mesh 0: the torus (data/meshes/torus.msh), 1: the 303,918-tet
/// structured box, 2: the 2-layer tissue slab (data/meshes/slab.msh), 3: the slab sagged
/// into a bowl 10 cm deep.
void SelfGate(benchmark::State& state);

/// TorusSelfInBox/<threads>/<depth_um>/<self>: TorusInBox with the torus's self-contact off
/// (0) or on (1): what asking for it adds to a frame of a scene in contact (the torus does
/// not touch itself).
void TorusSelfInBox(benchmark::State& state) {
  torus_in_box(state, 0.0, state.range(2) != 0);
}

TetMesh large_box(int cells) {
  return test::structured_box(cells, cells, cells, Eigen::Vector3d::Zero(),
                              Eigen::Vector3d::Ones());
}

void Register(benchmark::State& state) {
  const TetMesh mesh = large_box(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    Pipeline pipeline;
    const Status st = pipeline.set_topology("large", 1, mesh, {});
    if (!st) state.SkipWithError(st.error().message.c_str());
    benchmark::ClobberMemory();
  }
  state.counters["tets"] = static_cast<double>(mesh.num_tets());
}

void BuildTopology(benchmark::State& state) {
  const TetMesh mesh = large_box(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    Topology topo = build_topology(mesh.tets, mesh.num_nodes());
    benchmark::DoNotOptimize(topo.edges.data());
  }
  state.counters["tets"] = static_cast<double>(mesh.num_tets());
}

/// Positions `x` moved by a seeded offset in [-m, m] per coordinate (frame `frame`).
Positions jittered(const Positions& x, double m, std::int64_t frame) {
  std::uint64_t h = 0x9e3779b97f4a7c15ULL * static_cast<std::uint64_t>(frame + 1);
  Positions out = x;
  for (Index i = 0; i < out.size(); ++i) {
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdULL;
    h ^= h >> 29;
    out.data()[i] += m * (static_cast<double>(h >> 11) * 0x1.0p-53 * 2.0 - 1.0);
  }
  return out;
}

void SelfGate(benchmark::State& state) {
  std::optional<TetMesh> mesh = state.range(0) == 0   ? data_mesh("torus.msh")
                                : state.range(0) == 1 ? std::optional<TetMesh>(large_box(37))
                                                      : data_mesh("slab.msh");  // 2, 3
  if (!mesh) {
    state.SkipWithError("mesh not available");
    return;
  }
  const Topology topo = build_topology(mesh->tets, mesh->num_nodes());
  SelfCollider collider(mesh->tets, topo, mesh->positions);
  std::vector<Positions> frames;
  const double jitter = static_cast<double>(state.range(1)) * 1e-6;
  Positions shape = mesh->positions;
  if (state.range(0) == 3)  // the slab sagged into a bowl 10 cm deep (the tissue under load)
    for (Index i = 0; i < shape.cols(); ++i)
      shape(2, i) -=
          0.1 * std::max(0.0, 1.0 - 4.0 * (shape(0, i) * shape(0, i) + shape(1, i) * shape(1, i)));
  for (std::int64_t f = 0; f < 8; ++f) frames.push_back(jittered(shape, jitter, f));
  SelfContacts out;
  SelfDetectStats st;
  std::size_t f = 0;
  for (auto _ : state) {
    collider.detect(frames[f++ % frames.size()], kDefaultRelativeTolerance, out, &st);
    benchmark::DoNotOptimize(out.parts.data());
  }
  state.counters["faces"] = static_cast<double>(topo.boundary_faces.size());
  state.counters["pairs_tested"] = static_cast<double>(st.surface_pairs);
  state.counters["crossing"] = static_cast<double>(st.crossing_pairs);
  state.counters["certificate_um"] = 1e6 * st.certificate;
}

/// SelfContactFrame/<mesh>/<self>: Pipeline::run_frame of one object alone (mesh as
/// SelfGate), every node moved each frame, with ObjectParams::self_contact off (0) or on
/// (1): what asking for self-contact adds to a frame of an object that does not touch
/// itself.
void SelfContactFrame(benchmark::State& state) {
  std::optional<TetMesh> mesh = state.range(0) == 0 ? data_mesh("torus.msh") : large_box(37);
  if (!mesh) {
    state.SkipWithError("mesh not available");
    return;
  }
  ObjectParams params;
  params.self_contact = state.range(1) != 0;
  Pipeline pipeline;
  if (!pipeline.set_topology("organ", 1, *mesh, params)) {
    state.SkipWithError("registration failed");
    return;
  }
  std::vector<Positions> frames;
  for (std::int64_t f = 0; f < 8; ++f) frames.push_back(jittered(mesh->positions, 1e-6, f));
  std::vector<FrameObjectInput> states(1);
  states[0].object = "organ";
  states[0].topology_version = 1;
  std::int64_t frame = 0;
  std::size_t forces = 0;
  for (auto _ : state) {
    state.PauseTiming();
    states[0].positions = frames[static_cast<std::size_t>(frame) % frames.size()];
    state.ResumeTiming();
    const FrameOutput out = pipeline.run_frame_taking(frame++, states);
    forces += out.forces.size() + out.errors.size();
  }
  state.counters["forces_or_errors"] = static_cast<double>(forces);
}

/// SelfFold/<overlap_um>: Pipeline::run_frame of data/meshes/fold_u.msh with its upper arm
/// sheared down (the tip `overlap_um` micrometres into the lower arm; no tet inverted) and
/// every node moved by 1e-6 m each frame, self-contact on (point response): what a frame
/// of self-contact costs against the contact it has.
void SelfFold(benchmark::State& state) {
  auto mesh = data_mesh("fold_u.msh");
  if (!mesh) {
    state.SkipWithError("mesh not available");
    return;
  }
  const double overlap = static_cast<double>(state.range(0)) * 1e-6;
  Positions bent = mesh->positions;
  for (Index i = 0; i < bent.cols(); ++i) {  // upper arm: z >= 0.02, x > 0.02
    const double x = bent(0, i), z = bent(2, i);
    if (z >= 0.02 - 1e-9 && x > 0.02) bent(2, i) -= (x - 0.02) / 0.08 * (0.01 + overlap);
  }
  ObjectParams params;
  params.self_contact = true;
  params.response = ResponseKind::kPoint;
  Pipeline pipeline;
  if (!pipeline.set_topology("fold", 1, *mesh, params)) {
    state.SkipWithError("registration failed");
    return;
  }
  std::vector<Positions> frames;
  for (std::int64_t f = 0; f < 8; ++f) frames.push_back(jittered(bent, 1e-6, f));
  std::vector<FrameObjectInput> states(1);
  states[0].object = "fold";
  states[0].topology_version = 1;
  std::int64_t frame = 0;
  FrameStats last;
  for (auto _ : state) {
    state.PauseTiming();
    states[0].positions = frames[static_cast<std::size_t>(frame) % frames.size()];
    state.ResumeTiming();
    const FrameOutput out = pipeline.run_frame_taking(frame++, states);
    last = out.stats;
    if (!out.errors.empty()) state.SkipWithError(out.errors.front().error.message.c_str());
  }
  state.counters["contacts"] = static_cast<double>(last.contacts);
  state.counters["overlapping"] = static_cast<double>(last.overlapping_pairs);
  state.counters["detect_ms"] = last.broad_ms + last.narrow_ms;
  state.counters["depth_ms"] = last.depth_ms;
  state.counters["response_ms"] = last.response_ms;
}

BENCHMARK(SelfFold)
    ->Arg(0)
    ->Arg(500)
    ->Arg(2000)
    ->Arg(5000)
    ->ArgName("overlap_um")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
/// OrganWithTool/<self>: the 303,918-tet box (1 m cube) and a 2 cm tool (a 4 x 4 x 4-cell
/// structured box, 384 tets) pressed 2 mm into its top face, every node of both moved by
/// 1e-6 m each frame, point response; the organ's self-contact off (0) or on (1).
void OrganWithTool(benchmark::State& state) {
  const TetMesh organ = large_box(37);
  const TetMesh tool = test::structured_box(4, 4, 4, Eigen::Vector3d(0.49, 0.49, 0.998),
                                            Eigen::Vector3d(0.51, 0.51, 1.018));
  ObjectParams params;
  params.response = ResponseKind::kPoint;
  ObjectParams organ_params = params;
  organ_params.self_contact = state.range(0) != 0;
  Pipeline pipeline;
  if (!pipeline.set_topology("organ", 1, organ, organ_params) ||
      !pipeline.set_topology("tool", 1, tool, params)) {
    state.SkipWithError("registration failed");
    return;
  }
  std::vector<std::array<Positions, 2>> frames;
  for (std::int64_t f = 0; f < 8; ++f)
    frames.push_back({jittered(organ.positions, 1e-6, f), jittered(tool.positions, 1e-6, f + 100)});
  std::vector<FrameObjectInput> states(2);
  states[0].object = "organ";
  states[1].object = "tool";
  states[0].topology_version = states[1].topology_version = 1;
  std::int64_t frame = 0;
  std::size_t contacts = 0;
  for (auto _ : state) {
    state.PauseTiming();
    for (std::size_t i = 0; i < 2; ++i)
      states[i].positions = frames[static_cast<std::size_t>(frame) % frames.size()][i];
    state.ResumeTiming();
    const FrameOutput out = pipeline.run_frame_taking(frame++, states);
    contacts = out.stats.contacts;
    if (!out.errors.empty()) state.SkipWithError(out.errors.front().error.message.c_str());
  }
  state.counters["contacts"] = static_cast<double>(contacts);
}

BENCHMARK(OrganWithTool)
    ->Arg(0)
    ->Arg(1)
    ->ArgName("self")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(SelfGate)
    ->Args({0, 1})
    ->Args({1, 1})
    ->Args({2, 1})
    ->Args({0, 2000})
    ->Args({1, 2000})
    ->Args({2, 2000})
    ->Args({3, 2000})
    ->ArgNames({"mesh", "jitter_um"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(SelfContactFrame)
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Args({1, 1})
    ->ArgNames({"mesh", "self"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(TorusInBox)
    ->Args({1, 5000})
    ->Args({2, 5000})
    ->Args({1, 10000})
    ->Args({2, 10000})
    ->ArgNames({"threads", "depth_um"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(kFramesPerRun);
BENCHMARK(TurningTorusInBox)
    ->Args({1, 5000})
    ->Args({2, 5000})
    ->ArgNames({"threads", "depth_um"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(kFramesPerRun);
BENCHMARK(TorusSelfInBox)
    ->Args({2, 5000, 0})
    ->Args({2, 5000, 1})
    ->ArgNames({"threads", "depth_um", "self"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(kFramesPerRun);
BENCHMARK(Register)
    ->Arg(37)
    ->ArgName("cells")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);
BENCHMARK(BuildTopology)
    ->Arg(37)
    ->ArgName("cells")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace
}  // namespace tc

BENCHMARK_MAIN();
