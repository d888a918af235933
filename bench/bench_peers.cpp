// tetcollide against its peers (issue 46, items 2 and 5), on the heavy-contact scenes of
// bench/peer_scenes.hpp (box on box, torus deep in the box, two balls of radius 0.2 and 1), every
// timed frame a deforming one: every node of both objects moved by a seeded offset in [-1e-6, 1e-6]
// m per axis, the offsets of `tetcollide respond --jitter 1e-6` (made outside the timed parts).
//
//   Frame/<scene>/<threads>   [FCL] one frame of each, on the same positions, in turn (the
//       order swapped every frame):
//       ours  Pipeline::run_frame_taking with the point response, set up as `tetcollide
//             respond A B --response point` does (tools/cli/cmd_respond.cpp: objects "a"
//             and "b", stiffness 1e4, CPFM, nearest-face depth, local lazy maps, default
//             broad phase), TBB limited to <threads>
//       FCL   the boundary triangles of each object in an fcl::BVHModel, refitted to the
//             frame's positions (beginUpdateModel / updateVertex / endUpdateModel, bottom-up
//             refit), then fcl::collide with enable_contact off and room for every triangle
//             pair: the list of intersecting triangle pairs, no depth, no normal, no force;
//             once with AABB trees and once with OBBRSS trees; one thread
//       Time column: our frame (manual time, wall clock). Counters, medians over the frames
//       of the repetition: ours_ms (wall), ours_detect_ms (FrameStats broad + narrow, as
//       `respond --json` stage_ms.detect), fcl_aabb_ms, fcl_obbrss_ms, ours_per_fcl_aabb and
//       ours_per_fcl_obbrss (ratio of the medians); of the last frame: contacts (point
//       contacts that made a force), overlapping (tet pairs), fcl_aabb_pairs and
//       fcl_obbrss_pairs (intersecting triangle pairs).
//   Cgal/<scene>/<threads>    [CGAL] the overlapping tet pairs four ways on the same
//       positions, in this order:
//       pairs       our detection per frame with DetectOptions intruding_nodes and
//                   intruding_edges off: the pair list alone, what CGAL computes
//                   (CollisionBody::set_positions + Detector::detect, bodies and detector
//                   kept across frames as in the pipeline)
//       detect      the same with default DetectOptions (also the intruding nodes and
//                   edges), other bodies and detector
//       detect_pair our one-off tc::detect_pair, default options (bodies built in the call)
//       CGAL        box_intersection_d over every tet's box, then do_intersect of
//                   Tetrahedron_3 pairs (Epick: exact here, bench/peer_cgal.hpp); one thread
//       Time column: CGAL (manual). Counters, medians over the frames of the repetition:
//       cgal_ms, ours_pairs_ms, ours_detect_ms, ours_detect_pair_ms and the ratios
//       cgal_per_pairs, cgal_per_detect, cgal_per_detect_pair (CGAL time / ours); of the last
//       frame: pairs, cgal_candidates, ours_candidates; mismatches: pairs in one list and not
//       the other, summed over every frame and our three lists (must be 0; each is printed
//       to stderr), over frames_checked frames.
//
// [FCL] needs libfcl-dev, [CGAL] libcgal-dev (bench/CMakeLists.txt). Run with repetitions and
// read the medians (docs/BENCHMARKS.md, "Peers (CGAL, FCL)"):
//   build/bin/bench_peers --benchmark_repetitions=10 --benchmark_out=peers.json
//   python3 bench/peers_table.py peers.json
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/detect/detect.hpp"
#include "core/pipeline/pipeline.hpp"
#include "peer_scenes.hpp"

#if TC_HAVE_FCL
#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/math/bv/AABB.h>
#include <fcl/math/bv/OBBRSS.h>
#include <fcl/narrowphase/collision.h>
#endif
#if TC_HAVE_CGAL
#include "peer_cgal.hpp"
#endif

namespace tc::peers {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2 == 1) return *mid;
  return 0.5 * (*mid + *std::max_element(v.begin(), mid));
}

const Scene* scene(std::size_t i) {
  static std::array<std::optional<Scene>, kScenes.size()> cache;
  static std::array<bool, kScenes.size()> tried{};
  if (!tried[i]) {
    tried[i] = true;
    std::string error;
    cache[i] = load_scene(kScenes[i], std::filesystem::path(TC_SOURCE_DIR) / "data/meshes", error);
    if (!cache[i])
      std::fprintf(stderr, "bench_peers: %s\n", error.c_str());
    else
      std::fprintf(stderr, "bench_peers: %s is %s\n", kScenes[i].name,
                   respond_command(kScenes[i]).c_str());
  }
  return cache[i] ? &*cache[i] : nullptr;
}

/// The positions of frame `frame`: both objects jittered as `respond --jitter 1e-6`.
void frame_positions(const Scene& s, std::int64_t frame, Positions& xa, Positions& xb) {
  jitter_positions(s.a.mesh.positions, kJitter, frame, 0, xa);
  jitter_positions(s.b.mesh.positions, kJitter, frame, 1, xb);
}

#if TC_HAVE_FCL
/// One object's boundary triangles as an FCL BVH, refitted to each frame's positions.
template <class BV>
class FclSurface {
 public:
  FclSurface(const Positions& x, const Topology& topo) : nodes_(topo.boundary_nodes) {
    std::vector<int> local(static_cast<std::size_t>(topo.num_nodes), -1);
    for (std::size_t i = 0; i < nodes_.size(); ++i)
      local[static_cast<std::size_t>(nodes_[i])] = static_cast<int>(i);
    std::vector<fcl::Triangle> tris;
    tris.reserve(topo.boundary_faces.size());
    for (const auto& f : topo.boundary_faces)
      tris.emplace_back(local[static_cast<std::size_t>(f[0])],
                        local[static_cast<std::size_t>(f[1])],
                        local[static_cast<std::size_t>(f[2])]);
    std::vector<fcl::Vector3d> points;
    points.reserve(nodes_.size());
    for (const Index n : nodes_) points.emplace_back(x.col(n));
    model_ = std::make_shared<fcl::BVHModel<BV>>();
    model_->beginModel(static_cast<int>(tris.size()), static_cast<int>(points.size()));
    model_->addSubModel(points, tris);
    model_->endModel();
  }
  /// Moves the vertices to `x` and refits the tree bottom-up.
  void refit(const Positions& x) {
    model_->beginUpdateModel();
    for (const Index n : nodes_) model_->updateVertex(x.col(n));
    model_->endUpdateModel(true, true);
  }
  [[nodiscard]] const fcl::BVHModel<BV>* model() const { return model_.get(); }
  [[nodiscard]] std::size_t triangles() const { return static_cast<std::size_t>(model_->num_tris); }

 private:
  std::vector<Index> nodes_;
  std::shared_ptr<fcl::BVHModel<BV>> model_;
};

/// A refit of both surfaces and fcl::collide: the intersecting triangle pairs, all of them.
template <class BV>
std::size_t fcl_frame(FclSurface<BV>& a, FclSurface<BV>& b, const Positions& xa,
                      const Positions& xb, fcl::CollisionResultd& result) {
  a.refit(xa);
  b.refit(xb);
  // Room for every pair (FCL stops at num_max_contacts); no contact points or depths.
  const fcl::CollisionRequestd request(a.triangles() * b.triangles(), false);
  result.clear();
  return fcl::collide(a.model(), fcl::Transform3d::Identity(), b.model(),
                      fcl::Transform3d::Identity(), request, result);
}

void Frame(benchmark::State& state) {
  const Scene* s = scene(static_cast<std::size_t>(state.range(0)));
  if (s == nullptr) {
    state.SkipWithError("mesh not available");
    return;
  }
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(state.range(1)));
  // As `tetcollide respond A B --response point` (tools/cli/cmd_respond.cpp).
  ObjectParams params;
  params.stiffness = 1e4;
  params.response = ResponseKind::kPoint;
  params.depth = DepthMethod::kCpfm;
  PipelineConfig config;
  config.evaluation = DepthEvaluation::kNearestFace;
  config.lazy_region = LazyRegion::kLocal;
  Pipeline pipeline(config);
  if (!pipeline.set_topology("a", 0, s->a.mesh, params) ||
      !pipeline.set_topology("b", 0, s->b.mesh, params)) {
    state.SkipWithError("registration failed");
    return;
  }
  std::vector<FrameObjectInput> states(2);
  states[0].object = "a";
  states[1].object = "b";
  FclSurface<fcl::AABBd> aabb_a(s->a.mesh.positions, s->a.topo),
      aabb_b(s->b.mesh.positions, s->b.topo);
  FclSurface<fcl::OBBRSSd> obb_a(s->a.mesh.positions, s->a.topo),
      obb_b(s->b.mesh.positions, s->b.topo);
  fcl::CollisionResultd result;
  Positions xa, xb;
  std::int64_t frame = 0;
  FrameOutput out;
  std::size_t aabb_pairs = 0, obb_pairs = 0;
  double t_ours = 0.0, t_aabb = 0.0, t_obb = 0.0;
  const auto run = [&] {
    frame_positions(*s, frame, xa, xb);
    states[0].positions = xa;  // the pipeline takes these matrices (run_frame_taking)
    states[1].positions = xb;
    const auto ours = [&] {
      const auto t0 = Clock::now();
      out = pipeline.run_frame_taking(frame, states);
      t_ours = ms_since(t0);
    };
    const auto fcl = [&] {
      auto t0 = Clock::now();
      aabb_pairs = fcl_frame(aabb_a, aabb_b, xa, xb, result);
      t_aabb = ms_since(t0);
      t0 = Clock::now();
      obb_pairs = fcl_frame(obb_a, obb_b, xa, xb, result);
      t_obb = ms_since(t0);
    };
    if (frame % 2 == 0) {
      ours();
      fcl();
    } else {
      fcl();
      ours();
    }
    ++frame;
  };
  run();  // untimed: trees, buffers, the first depth maps
  std::vector<double> ours_ms, detect_ms, aabb_ms, obb_ms;
  for (auto _ : state) {
    run();
    benchmark::DoNotOptimize(out.forces.data());
    state.SetIterationTime(t_ours * 1e-3);
    ours_ms.push_back(t_ours);
    detect_ms.push_back(out.stats.broad_ms + out.stats.narrow_ms);
    aabb_ms.push_back(t_aabb);
    obb_ms.push_back(t_obb);
  }
  for (const ObjectError& e : out.errors) {
    state.SkipWithError(e.error.message.c_str());
    return;
  }
  const double ours = median(ours_ms), aabb = median(aabb_ms), obb = median(obb_ms);
  state.counters["ours_ms"] = ours;
  state.counters["ours_detect_ms"] = median(detect_ms);
  state.counters["fcl_aabb_ms"] = aabb;
  state.counters["fcl_obbrss_ms"] = obb;
  state.counters["ours_per_fcl_aabb"] = aabb > 0.0 ? ours / aabb : 0.0;
  state.counters["ours_per_fcl_obbrss"] = obb > 0.0 ? ours / obb : 0.0;
  state.counters["contacts"] = static_cast<double>(out.stats.contacts);
  state.counters["overlapping"] = static_cast<double>(out.stats.overlapping_pairs);
  state.counters["fcl_aabb_pairs"] = static_cast<double>(aabb_pairs);
  state.counters["fcl_obbrss_pairs"] = static_cast<double>(obb_pairs);
  state.SetLabel(kScenes[static_cast<std::size_t>(state.range(0))].name);
}
#endif  // TC_HAVE_FCL

#if TC_HAVE_CGAL
void Cgal(benchmark::State& state) {
  const Scene* s = scene(static_cast<std::size_t>(state.range(0)));
  if (s == nullptr) {
    state.SkipWithError("mesh not available");
    return;
  }
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(state.range(1)));
  const char* name = kScenes[static_cast<std::size_t>(state.range(0))].name;
  /// Bodies and a detector kept across frames, as the pipeline keeps them.
  struct Kept {
    Kept(const Scene& sc, const DetectOptions& options)
        : a(sc.a.mesh.tets, sc.a.topo), b(sc.b.mesh.tets, sc.b.topo), detector(options) {}
    CollisionBody a, b;
    Detector detector;
    PairContacts contacts;
    DetectStats stats;
    double ms = 0.0;
    void detect(const Positions& xa, const Positions& xb) {
      const auto t0 = Clock::now();
      a.set_positions(xa);
      b.set_positions(xb);
      detector.detect(a, b, contacts, &stats);
      ms = ms_since(t0);
    }
  };
  DetectOptions pairs_only;
  pairs_only.intruding_nodes = false;
  pairs_only.intruding_edges = false;
  Kept pairs(*s, pairs_only);
  Kept full(*s, DetectOptions{});
  Positions xa, xb;
  std::int64_t frame = 0;
  CgalResult cgal;
  PairContacts one_off;
  std::size_t mismatches = 0;
  double t_pair = 0.0, t_cgal = 0.0;
  const auto check = [&](const std::vector<TetPair>& ours, const char* which) {
    const std::vector<TetPair> only_ours = pairs_missing(ours, cgal.overlapping);
    const std::vector<TetPair> only_cgal = pairs_missing(cgal.overlapping, ours);
    for (const TetPair& p : only_ours)
      std::fprintf(stderr, "bench_peers: %s frame %lld: %s has (%lld, %lld), CGAL not\n", name,
                   static_cast<long long>(frame), which, static_cast<long long>(p.tet_a),
                   static_cast<long long>(p.tet_b));
    for (const TetPair& p : only_cgal)
      std::fprintf(stderr, "bench_peers: %s frame %lld: CGAL has (%lld, %lld), %s not\n", name,
                   static_cast<long long>(frame), static_cast<long long>(p.tet_a),
                   static_cast<long long>(p.tet_b), which);
    mismatches += only_ours.size() + only_cgal.size();
  };
  const auto run = [&] {
    frame_positions(*s, frame, xa, xb);
    pairs.detect(xa, xb);
    full.detect(xa, xb);
    auto t0 = Clock::now();
    one_off = detect_pair(xa, s->a.mesh.tets, s->a.topo, xb, s->b.mesh.tets, s->b.topo);
    t_pair = ms_since(t0);
    t0 = Clock::now();
    cgal = cgal_overlapping(xa, s->a.mesh.tets, xb, s->b.mesh.tets);
    t_cgal = ms_since(t0);
    check(pairs.contacts.overlapping, "Detector::detect (pairs only)");
    check(full.contacts.overlapping, "Detector::detect");
    check(one_off.overlapping, "detect_pair");
    ++frame;
  };
  run();  // untimed: trees, buffers
  std::vector<double> pairs_ms, detect_ms, pair_ms, cgal_ms;
  for (auto _ : state) {
    run();
    state.SetIterationTime(t_cgal * 1e-3);
    pairs_ms.push_back(pairs.ms);
    detect_ms.push_back(full.ms);
    pair_ms.push_back(t_pair);
    cgal_ms.push_back(t_cgal);
  }
  const double cg = median(cgal_ms);
  const auto ratio = [cg](double ours) { return ours > 0.0 ? cg / ours : 0.0; };
  state.counters["cgal_ms"] = cg;
  state.counters["ours_pairs_ms"] = median(pairs_ms);
  state.counters["ours_detect_ms"] = median(detect_ms);
  state.counters["ours_detect_pair_ms"] = median(pair_ms);
  state.counters["cgal_per_pairs"] = ratio(median(pairs_ms));
  state.counters["cgal_per_detect"] = ratio(median(detect_ms));
  state.counters["cgal_per_detect_pair"] = ratio(median(pair_ms));
  state.counters["pairs"] = static_cast<double>(cgal.overlapping.size());
  state.counters["cgal_candidates"] = static_cast<double>(cgal.candidates);
  state.counters["ours_candidates"] = static_cast<double>(pairs.stats.candidates);
  state.counters["mismatches"] = static_cast<double>(mismatches);
  state.counters["frames_checked"] = static_cast<double>(frame);
  state.SetLabel(name);
}
#endif  // TC_HAVE_CGAL

void scene_args(benchmark::internal::Benchmark* b) {
  b->ArgNames({"scene", "threads"});
  for (std::int64_t i = 0; i < static_cast<std::int64_t>(kScenes.size()); ++i)
    for (const std::int64_t threads : {2, 1}) b->Args({i, threads});
}

#if TC_HAVE_FCL
BENCHMARK(Frame)->Apply(scene_args)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(50);
#endif
#if TC_HAVE_CGAL
BENCHMARK(Cgal)->Apply(scene_args)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(10);
#endif

}  // namespace
}  // namespace tc::peers

BENCHMARK_MAIN();
