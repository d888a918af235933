// Depth maps (service/core/depth): per-frame time of CPFM (each queue), CFFM (each
// variant), the exact reference (one thread and all), the lazy update on a shallow
// contact, and the grid fast marching baseline, on
//  - box37: a structured 37^3-cell box (303,918 tets, 54,872 nodes) with interior
//    nodes jittered by 0.3 cell and node numbers shuffled (a file order with no
//    locality, the worst case for the march);
//  - the data meshes when present: data/meshes/generated/large.msh (the 300,941-tet
//    pawn, made by data/meshes/make_large.sh), large_box.msh, torus.msh, ball.msh.
// Counters: nodes; for lazy runs the settled fraction. Times are CPU time of the
// benchmark thread (robust to other processes on a shared machine).
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <filesystem>
#include <memory>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "core/depth/depth_solver.hpp"
#include "core/depth/grid_fast_marching.hpp"
#include "core/io/mesh_io.hpp"
#include "test_meshes.hpp"

namespace {

using tc::CffmVariant;
using tc::DepthMethod;
using tc::QueueKind;

struct Case {
  std::string name;
  tc::TetMesh mesh;
  tc::Topology topo;
};

std::unique_ptr<Case> make_box37() {
  auto c = std::make_unique<Case>();
  c->name = "box37";
  tc::TetMesh m = tc::test::structured_box(37, 37, 37, {0, 0, 0}, {1, 1, 1});
  // Shuffle node numbers (seeded).
  std::vector<tc::Index> p(static_cast<std::size_t>(m.num_nodes()));
  std::iota(p.begin(), p.end(), 0);
  std::mt19937 rng(1);
  std::shuffle(p.begin(), p.end(), rng);
  tc::Positions q(3, m.num_nodes());
  for (tc::Index i = 0; i < m.num_nodes(); ++i) q.col(p[i]) = m.positions.col(i);
  m.positions = q;
  for (tc::Tet& t : m.tets)
    for (tc::Index& v : t) v = p[v];
  const tc::Topology topo = tc::build_topology(m.tets, m.num_nodes());
  std::uniform_real_distribution<double> u(-0.3 / 37, 0.3 / 37);
  for (tc::Index i = 0; i < m.num_nodes(); ++i)
    if (!topo.is_boundary_node[i])
      for (int k = 0; k < 3; ++k) m.positions(k, i) += u(rng);
  c->mesh = std::move(m);
  c->topo = topo;
  return c;
}

std::unique_ptr<Case> load(const std::string& file) {
  // data_path("x") is <source>/tests/data/x.
  const auto path =
      tc::test::data_path("x").parent_path().parent_path().parent_path() / "data" / "meshes" / file;
  if (!std::filesystem::exists(path)) return nullptr;
  auto mesh = tc::read_mesh(path);
  if (!mesh) return nullptr;
  auto c = std::make_unique<Case>();
  c->name = std::filesystem::path(file).stem().string();
  c->mesh = std::move(*mesh);
  c->topo = tc::build_topology(c->mesh.tets, c->mesh.num_nodes());
  return c;
}

void full(benchmark::State& state, const Case* c, tc::DepthSolverOptions options) {
  tc::DepthSolver solver(c->mesh.tets, c->topo, options);
  for (auto _ : state) {
    if (!solver.compute(c->mesh.positions)) state.SkipWithError("compute failed");
    benchmark::DoNotOptimize(solver.depth().data());
  }
  state.counters["nodes"] = c->mesh.num_nodes();
}

void exact(benchmark::State& state, const Case* c, int threads) {
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(threads));
  full(state, c, {.method = DepthMethod::kExact});
}

// Shallow contact (docs/DEPTH_MAPS.md, "Lazy update"): the tets with a node less than
// `fraction` of the object's height above its lowest point, as if it sat that deep in
// a floor. With `press`, only those within `fraction` of the height of the lowest
// node: a small tool pressed into the bottom (issue 13).
void lazy(benchmark::State& state, const Case* c, tc::DepthSolverOptions options, double fraction,
          bool press = false) {
  const double lo = c->mesh.positions.row(2).minCoeff();
  const double hi = c->mesh.positions.row(2).maxCoeff();
  const double plane = lo + fraction * (hi - lo);
  tc::Index lowest = 0;
  c->mesh.positions.row(2).minCoeff(&lowest);
  const Eigen::Vector3d tip = c->mesh.positions.col(lowest);
  std::vector<tc::Index> marked;
  for (tc::Index t = 0; t < c->mesh.num_tets(); ++t)
    for (const tc::Index v : c->mesh.tets[t])
      if (c->mesh.positions(2, v) < plane &&
          (!press || (c->mesh.positions.col(v) - tip).norm() < fraction * (hi - lo))) {
        marked.push_back(t);
        break;
      }
  tc::DepthSolver solver(c->mesh.tets, c->topo, options);
  std::size_t settled = 0;
  for (auto _ : state) {
    auto s = solver.compute_lazy(c->mesh.positions, marked);
    if (!s) state.SkipWithError("compute_lazy failed");
    settled = s ? *s : 0;
  }
  state.counters["marked_tets"] = static_cast<double>(marked.size());
  state.counters["settled_frac"] =
      static_cast<double>(settled) / static_cast<double>(c->mesh.num_nodes());
  state.counters["rounds"] = solver.lazy_stats().rounds;
  state.counters["region_frac"] = static_cast<double>(solver.lazy_stats().region_nodes) /
                                  static_cast<double>(c->mesh.num_nodes());
}

void grid(benchmark::State& state, const Case* c, int n) {
  std::vector<tc::Index> nodes(static_cast<std::size_t>(c->mesh.num_nodes()));
  std::iota(nodes.begin(), nodes.end(), 0);
  std::vector<double> depth(nodes.size());
  tc::GridFastMarching<3> fm(c->topo.boundary_faces, n);
  for (auto _ : state) {
    fm.compute(c->mesh.positions, nodes, depth);
    benchmark::DoNotOptimize(depth.data());
  }
}

void register_case(const Case* c, bool big) {
  const std::string n = c->name;
  const auto reg = [](const std::string& name, auto&& fn) {
    return benchmark::RegisterBenchmark(name.c_str(), fn)->Unit(benchmark::kMillisecond);
  };
  for (const auto& [q, qn] :
       {std::pair{QueueKind::kBucket, "bucket"}, std::pair{QueueKind::kRadix, "radix"},
        std::pair{QueueKind::kBinaryHeap, "binary_heap"}})
    reg("cpfm/" + n + "/" + qn, [c, q = q](benchmark::State& s) {
      full(s, c, {.method = DepthMethod::kCpfm, .queue = q});
    });
  for (const auto& [v, vn] :
       {std::pair{CffmVariant::kDescent, "descent"}, std::pair{CffmVariant::kPaper, "paper"},
        std::pair{CffmVariant::kPaperDescent, "paper_descent"},
        std::pair{CffmVariant::kMultiStart, "multi"}, std::pair{CffmVariant::kNearStarts, "near"}})
    reg("cffm/" + n + "/" + vn,
        [c, v = v](benchmark::State& s) { full(s, c, {.method = DepthMethod::kCffm, .cffm = v}); });
  reg("exact/" + n + "/threads:1", [c](benchmark::State& s) {
    exact(s, c, 1);
  })->Iterations(big ? 3 : 20);
  reg("exact/" + n + "/threads:all", [c](benchmark::State& s) {
    exact(s, c, static_cast<int>(tbb::this_task_arena::max_concurrency()));
  })->Iterations(big ? 3 : 20);
  for (const auto& [region, rn] : {std::pair{tc::LazyRegion::kLocal, "local"},
                                   std::pair{tc::LazyRegion::kWholeBoundary, "whole"}})
    for (const auto m : {DepthMethod::kCpfm, DepthMethod::kCffm}) {
      const std::string prefix = "lazy/" + n + "/" + tc::depth_method_name(m) + "/";
      for (const double f : {0.1, 0.25})
        reg(prefix + "bottom_" + std::to_string(static_cast<int>(100 * f)) + "pct/" + rn,
            [c, m, f, r = region](benchmark::State& s) {
              lazy(s, c, {.method = m, .lazy_region = r}, f);
            });
      reg(prefix + "press_5pct/" + rn, [c, m, r = region](benchmark::State& s) {
        lazy(s, c, {.method = m, .lazy_region = r}, 0.05, true);
      });
    }
  if (!big)
    for (const int g : {32, 64})
      reg("grid_fm/" + n + "/N:" + std::to_string(g), [c, g](benchmark::State& s) {
        grid(s, c, g);
      })->Iterations(3);
}

}  // namespace

int main(int argc, char** argv) {
  static std::vector<std::unique_ptr<Case>> cases;
  cases.push_back(make_box37());
  register_case(cases.back().get(), true);
  for (const char* file :
       {"generated/large.msh", "generated/large_box.msh", "torus.msh", "ball.msh"}) {
    if (auto c = load(file)) {
      cases.push_back(std::move(c));
      register_case(cases.back().get(), std::string(file).starts_with("generated"));
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
