// Mesh file layer: reading a 303,918-tet box (38^3 nodes) from memory in each Gmsh
// format and from TetGen text, and writing it as .vtu. Baselines in the same run: a
// memchr pass over the 2.2 text (a floor: touch every byte once) and the same text
// parsed token by token with std::istringstream (the approach the readers avoid).
// The per-frame state check of the same box (validate_positions: finite coordinates,
// degenerate and inverted tets), its nodes in mesher order and shuffled, against the
// floor issue 13 sets for work outside the contact: reading the positions once; and what
// a contact frame reads of every node (NodePasses).
#include <benchmark/benchmark.h>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_reduce.h>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>
#include <string>

#include "core/common/cpu_dispatch.hpp"
#include "core/detect/detect.hpp"
#include "core/io/mesh_io.hpp"
#include "core/mesh/shape_check.hpp"
#include "core/mesh/topology.hpp"
#include "core/mesh/validate.hpp"
#include "test_meshes.hpp"

namespace {

const tc::TetMesh& box() {
  static const tc::TetMesh mesh = tc::test::structured_box(37, 37, 37, Eigen::Vector3d(0, 0, 0),
                                                           Eigen::Vector3d(1.3, 0.7, 2.9));
  return mesh;
}

const std::string& text(tc::GmshFormat format) {
  static std::string cache[3];
  std::string& s = cache[static_cast<int>(format)];
  if (s.empty()) s = *tc::format_gmsh(box(), format);
  return s;
}

void read_gmsh_format(benchmark::State& state, tc::GmshFormat format) {
  const std::string& data = text(format);
  for (auto _ : state) {
    auto mesh = tc::read_gmsh_buffer(data, "box.msh");
    if (!mesh || mesh->num_tets() != box().num_tets()) state.SkipWithError("read failed");
    benchmark::DoNotOptimize(mesh);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * data.size()));
  state.counters["tets"] = static_cast<double>(box().num_tets());
  state.counters["MB"] = static_cast<double>(data.size()) / 1e6;
}

void BM_ReadGmsh22Ascii(benchmark::State& state) {
  read_gmsh_format(state, tc::GmshFormat::kMsh22Ascii);
}
void BM_ReadGmsh41Ascii(benchmark::State& state) {
  read_gmsh_format(state, tc::GmshFormat::kMsh41Ascii);
}
void BM_ReadGmsh41Binary(benchmark::State& state) {
  read_gmsh_format(state, tc::GmshFormat::kMsh41Binary);
}

void BM_ReadTetGen(benchmark::State& state) {
  // TetGen text built from the same mesh, 1-based.
  std::string node = std::to_string(box().num_nodes()) + " 3 0 0\n";
  for (tc::Index i = 0; i < box().num_nodes(); ++i) {
    std::ostringstream line;
    line.precision(17);
    line << i + 1 << ' ' << box().positions(0, i) << ' ' << box().positions(1, i) << ' '
         << box().positions(2, i) << '\n';
    node += line.str();
  }
  std::string ele = std::to_string(box().num_tets()) + " 4 0\n";
  for (tc::Index t = 0; t < box().num_tets(); ++t) {
    const tc::Tet& tet = box().tets[static_cast<std::size_t>(t)];
    ele += std::to_string(t + 1) + ' ' + std::to_string(tet[0] + 1) + ' ' +
           std::to_string(tet[1] + 1) + ' ' + std::to_string(tet[2] + 1) + ' ' +
           std::to_string(tet[3] + 1) + '\n';
  }
  for (auto _ : state) {
    auto mesh = tc::read_tetgen_buffers(node, ele, "box");
    if (!mesh || mesh->num_tets() != box().num_tets()) state.SkipWithError("read failed");
    benchmark::DoNotOptimize(mesh);
  }
  state.SetBytesProcessed(
      static_cast<std::int64_t>(state.iterations() * (node.size() + ele.size())));
}

void BM_WriteVtu(benchmark::State& state) {
  const auto path = std::filesystem::temp_directory_path() / "tc_bench_io.vtu";
  for (auto _ : state) {
    if (!tc::write_vtu(path, box()).ok()) state.SkipWithError("write failed");
  }
  state.counters["MB"] = static_cast<double>(std::filesystem::file_size(path)) / 1e6;
  std::filesystem::remove(path);
}

void BM_Baseline_CountLines22(benchmark::State& state) {
  const std::string& data = text(tc::GmshFormat::kMsh22Ascii);
  for (auto _ : state) {
    std::size_t lines = 0;
    const char* p = data.data();
    const char* end = p + data.size();
    while ((p = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)))))
      ++lines, ++p;
    benchmark::DoNotOptimize(lines);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * data.size()));
}

void BM_Baseline_Istream22(benchmark::State& state) {
  // Every token of the 2.2 text through operator>>: numbers as double, the rest skipped.
  const std::string& data = text(tc::GmshFormat::kMsh22Ascii);
  for (auto _ : state) {
    std::istringstream in(data);
    std::string token;
    double sum = 0.0;
    while (in >> token)
      if (token[0] != '$') sum += std::stod(token);
    benchmark::DoNotOptimize(sum);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * data.size()));
}

/// The box with its nodes renumbered at random: the worst memory order a mesher could give.
const tc::TetMesh& shuffled_box() {
  static const tc::TetMesh mesh = [] {
    const tc::TetMesh& b = box();
    std::vector<tc::Index> perm(static_cast<std::size_t>(b.num_nodes()));
    std::iota(perm.begin(), perm.end(), tc::Index{0});
    std::shuffle(perm.begin(), perm.end(), std::mt19937(7));
    tc::TetMesh m = b;
    for (tc::Index i = 0; i < b.num_nodes(); ++i)
      m.positions.col(perm[static_cast<std::size_t>(i)]) = b.positions.col(i);
    for (tc::Tet& t : m.tets)
      for (tc::Index& v : t) v = perm[static_cast<std::size_t>(v)];
    return m;
  }();
  return mesh;
}

/// state.range(0): threads.
void validate(benchmark::State& state, const tc::TetMesh& mesh, bool min_quality) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(state.range(0)));
  tc::ValidationOptions options;
  options.compute_min_quality = min_quality;
  for (auto _ : state) {
    const tc::ValidationReport r = tc::validate_positions(mesh.positions, mesh.tets, options);
    if (!r.clean()) state.SkipWithError("the box is not clean");
    benchmark::DoNotOptimize(r);
  }
  state.counters["tets"] = static_cast<double>(mesh.num_tets());
}

/// The per-frame check as the pipeline runs it (no smallest quality).
void BM_ValidatePositions(benchmark::State& state) {
  validate(state, box(), false);
}
void BM_ValidatePositionsShuffled(benchmark::State& state) {
  validate(state, shuffled_box(), false);
}
/// The shuffled box with its tets stored along a Morton curve (what the pipeline does).
void BM_ValidatePositionsShuffledMorton(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(state.range(0)));
  const tc::TetMesh& mesh = shuffled_box();
  const tc::TetCheckOrder order = tc::make_tet_check_order(mesh.positions, mesh.tets);
  tc::ValidationOptions options;
  options.compute_min_quality = false;
  for (auto _ : state) {
    const tc::ValidationReport r = tc::validate_positions(mesh.positions, order, options);
    if (!r.clean()) state.SkipWithError("the box is not clean");
    benchmark::DoNotOptimize(r);
  }
  state.counters["tets"] = static_cast<double>(mesh.num_tets());
}
/// The same with the smallest quality (what `mesh info` reports): every tet's exact quality.
void BM_ValidatePositionsMinQuality(benchmark::State& state) {
  validate(state, box(), true);
}

/// The middle of the box's top face, where motion 2 presses.
Eigen::Vector3d dent_centre() {
  const tc::Positions& rest = box().positions;
  const Eigen::Vector3d lo = rest.rowwise().minCoeff(), hi = rest.rowwise().maxCoeff();
  return {0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), hi.z()};
}

/// The states of the box's frames for a kind of motion: 0 still, 1 every node jittered by
/// 1e-6 of the box, 2 a dent of ~1% of the nodes pressed in and out (a tool 0.14 of the
/// box wide, 0.02 of it deep, in the middle of the top face), 3 the whole box turned by
/// 0.01 rad a frame (64 states: 84 MB, read from memory), 4 the whole box turned about a
/// tilted axis through its middle by 0.01 rad a frame and carried along (4 states, in
/// the cache as motion 1's, to compare with the floors), 5 the whole box turned slowly,
/// 0.001 rad a frame about that axis (64 states, from memory): a shift alone leaves a few
/// nodes a frame beyond their radii, never a quarter of them.
std::vector<tc::Positions> box_states(long motion) {
  const tc::Positions& rest = box().positions;
  const Eigen::Vector3d lo = rest.rowwise().minCoeff(), hi = rest.rowwise().maxCoeff();
  const double size = (hi - lo).maxCoeff();
  std::vector<tc::Positions> states;
  if (motion == 0) states = {rest};
  if (motion == 1) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1e-6 * size, 1e-6 * size);
    for (int k = 0; k < 4; ++k) {
      tc::Positions x = rest;
      for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] += u(rng);
      states.push_back(std::move(x));
    }
  }
  if (motion == 2) {
    tc::Positions x = rest;
    const Eigen::Vector3d centre = dent_centre();
    for (tc::Index i = 0; i < x.cols(); ++i) {
      const double d = (x.col(i) - centre).norm() / (0.14 * size);
      if (d < 1.0) x(2, i) -= 0.02 * size * (1.0 - d) * (1.0 - d);
    }
    states = {rest, x};
  }
  if (motion == 3)
    for (int k = 1; k <= 64; ++k)
      states.push_back(Eigen::AngleAxisd(0.01 * k, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                       rest);
  if (motion == 4) {
    const Eigen::Vector3d middle = 0.5 * (lo + hi);
    const Eigen::Vector3d axis = Eigen::Vector3d(0.2, -0.3, 1.0).normalized();
    for (int k = 1; k <= 4; ++k) {
      const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.01 * k, axis).toRotationMatrix();
      const Eigen::Vector3d along = Eigen::Vector3d(0.001, 0.002, 0.0) * k * size;
      states.push_back((turn * (rest.colwise() - middle)).colwise() + (middle + along));
    }
  }
  if (motion == 5) {
    const Eigen::Vector3d middle = 0.5 * (lo + hi);
    const Eigen::Vector3d axis = Eigen::Vector3d(0.2, -0.3, 1.0).normalized();
    for (int k = 1; k <= 64; ++k)
      states.push_back(
          (Eigen::AngleAxisd(0.001 * k, axis).toRotationMatrix() * (rest.colwise() - middle))
              .colwise() +
          middle);
  }
  return states;
}

/// The box with what its per-frame shape check reads, the check, and the states of a
/// benchmark on state.range(0) threads with the motion state.range(1) (box_states()).
struct BoxCheck {
  explicit BoxCheck(const benchmark::State& state)
      : threads(tbb::global_control::max_allowed_parallelism,
                static_cast<std::size_t>(state.range(0))),
        states(box_states(state.range(1))) {}
  static tc::ValidationOptions frame_options() {
    tc::ValidationOptions o;
    o.compute_min_quality = false;
    return o;
  }
  const tc::TetMesh& mesh = box();
  tc::TetCheckOrder order = tc::make_tet_check_order(mesh.positions, mesh.tets);
  tc::Topology topology = tc::build_topology(mesh.tets, mesh.num_nodes());
  tc::ValidationOptions options = frame_options();
  tc::ShapeCheck check{order, topology.node_tets, mesh.num_nodes(), options};
  tbb::global_control threads;
  std::vector<tc::Positions> states;
};

/// The per-frame check of the pipeline (tc::ShapeCheck) over a sequence of states of the box.
/// state.range(0): threads; state.range(1): the motion between frames (box_states());
/// state.range(2): 1 = the baseline, validate_positions() of every tet on the same states.
void BM_ShapeCheck(benchmark::State& state) {
  BoxCheck f(state);
  const tc::TetMesh& mesh = f.mesh;
  tc::ShapeCheck& check = f.check;
  const std::vector<tc::Positions>& states = f.states;
  const tc::Positions& rest = mesh.positions;
  (void)check.check(rest);  // the first state: the reference
  const bool full = state.range(2) != 0;
  std::size_t frame = 0, checked = 0;
  for (auto _ : state) {
    const tc::Positions& x = states[frame++ % states.size()];
    const tc::ValidationReport r =
        full ? tc::validate_positions(x, f.order, f.options) : check.check(x);
    if (!r.clean()) state.SkipWithError("the box is not clean");
    checked += full ? f.order.tets.size() : check.last().checked_tets;
    benchmark::DoNotOptimize(r);
  }
  state.counters["tets"] = static_cast<double>(mesh.num_tets());
  state.counters["checked_tets"] =
      static_cast<double>(checked) / static_cast<double>(std::max<std::size_t>(frame, 1));
}

/// What a contact frame of the pipeline does with every node of a large object, outside
/// the contact: the shape check's pass (tc::ShapeCheck::check) and the detection's
/// comparison of the nodes with its references (tc::CollisionBody, the group boxes of its
/// cull), with a small region near the top asked each frame, as a tool in contact asks it.
/// state.range(0): threads; state.range(1): the motion (box_states()), 1 = every node
/// jittered (the passes alone: no node goes beyond its radius or reach), 2 = the dent
/// pressed in and out (with the work on the nodes that moved: their tets checked, radii
/// and group boxes made again), 4 = turned and carried along (the group boxes from the
/// check's turned references).
void BM_NodePasses(benchmark::State& state) {
  BoxCheck f(state);
  const tc::TetMesh& mesh = f.mesh;
  tc::ShapeCheck& check = f.check;
  const std::vector<tc::Positions>& states = f.states;
  tc::CollisionBody body(mesh.tets, f.topology);
  const tc::Positions& rest = mesh.positions;
  const Eigen::Vector3d centre = dent_centre();
  const double size = (rest.rowwise().maxCoeff() - rest.rowwise().minCoeff()).maxCoeff();
  const tc::Aabb region{centre - Eigen::Vector3d::Constant(0.03 * size), centre};
  std::vector<tc::Index> near;
  std::size_t frame = 0, bound = 0;
  const auto run = [&] {
    const tc::Positions& x = states[frame++ % states.size()];
    const tc::ValidationReport r = check.check(x);
    const tc::Aabb box{check.last().box_lo, check.last().box_hi};  // as the pipeline passes it
    body.set_positions(x, check.bound(), check.last().has_box ? &box : nullptr);
    bound += body.groups_from_bound() ? 1 : 0;
    body.tets_near(region, near);
    return r.clean();
  };
  for (int k = 0; k < 4; ++k) run();  // the references, the clusters
  bound = 0;
  for (auto _ : state) {
    if (!run()) state.SkipWithError("the box is not clean");
    benchmark::DoNotOptimize(near.data());
  }
  state.counters["nodes"] = static_cast<double>(rest.cols());
  state.counters["near_tets"] = static_cast<double>(near.size());
  state.counters["from_bound"] = static_cast<double>(bound) /
                                 static_cast<double>(std::max<std::int64_t>(state.iterations(), 1));
}

/// The sum of x[begin, end) in eight running sums (independent, so the loop runs at the
/// speed of the reads: one running sum is a chain of additions, 8x slower here). Not finite
/// when a coordinate is not.
double read_once(const double* x, std::size_t begin, std::size_t end) {
  double sums[8] = {};
  std::size_t i = begin;
  for (; i + 8 <= end; i += 8)
    for (std::size_t l = 0; l < 8; ++l) sums[l] += x[i + l];
  for (; i < end; ++i) sums[0] += x[i];
  double sum = 0.0;
  for (const double v : sums) sum += v;
  return sum;
}

/// Floor: every coordinate of the states of BM_NodePasses's motion 1 read once, one thread.
void BM_Baseline_ReadPositionsOnce(benchmark::State& state) {
  const std::vector<tc::Positions> states = box_states(1);
  std::size_t frame = 0;
  for (auto _ : state) {
    const tc::Positions& p = states[frame++ % states.size()];
    const double sum = read_once(p.data(), 0, static_cast<std::size_t>(p.size()));
    if (!std::isfinite(sum)) state.SkipWithError("not finite");
    benchmark::DoNotOptimize(sum);
  }
  state.counters["nodes"] = static_cast<double>(states[0].cols());
}

/// The same floor on state.range(0) threads: chunks of 8,192 nodes summed in parallel.
void BM_Baseline_ReadPositionsOnceParallel(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(state.range(0)));
  const std::vector<tc::Positions> states = box_states(1);
  std::size_t frame = 0;
  for (auto _ : state) {
    const tc::Positions& p = states[frame++ % states.size()];
    const double* x = p.data();
    const double sum = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, static_cast<std::size_t>(p.size()), 3 * 8192), 0.0,
        [x](const tbb::blocked_range<std::size_t>& r, double acc) {
          return acc + read_once(x, r.begin(), r.end());
        },
        std::plus<>());
    if (!std::isfinite(sum)) state.SkipWithError("not finite");
    benchmark::DoNotOptimize(sum);
  }
  state.counters["nodes"] = static_cast<double>(states[0].cols());
}

/// Lanes of four doubles and of four floats (GCC vector extensions: AVX2 in the AVX2 copy,
/// two SSE2 halves in the baseline one).
using Lanes4d = double __attribute__((vector_size(32)));
using Lanes4f = float __attribute__((vector_size(16)));

/// What the least per-node comparison reads, by blocks of four nodes (x x x x | y y y y |
/// z z z z, as the shape check keeps its reference): the positions of each state of
/// BM_NodePasses's motion 1, the rest positions as the reference in doubles and in floats,
/// and a squared radius a node in doubles and in floats.
struct CompareFloor {
  CompareFloor() {
    const std::vector<tc::Positions> states = box_states(1);
    const tc::Positions& rest = box().positions;
    nodes = static_cast<std::size_t>(rest.cols());
    lanes = (nodes + 3) / 4 * 4;  // the last block's spare lanes: 0 against 0, within
    const auto blocked = [this](const tc::Positions& p) {
      std::vector<double> b(3 * lanes, 0.0);
      for (std::size_t i = 0; i < nodes; ++i)
        for (std::size_t c = 0; c < 3; ++c)
          b[12 * (i / 4) + 4 * c + i % 4] =
              p(static_cast<Eigen::Index>(c), static_cast<Eigen::Index>(i));
      return b;
    };
    for (const tc::Positions& p : states) positions.push_back(blocked(p));
    reference = blocked(rest);
    reference_f.assign(reference.begin(), reference.end());
    const double size = (rest.rowwise().maxCoeff() - rest.rowwise().minCoeff()).maxCoeff();
    one_radius2 = (1e-3 * size) * (1e-3 * size);  // far beyond the jitter of 1e-6 of the box
    radius2.assign(lanes, one_radius2);
    radius2_f.assign(lanes, static_cast<float>(one_radius2));
  }
  std::size_t nodes = 0, lanes = 0;
  std::vector<std::vector<double>> positions;
  std::vector<double> reference, radius2;
  std::vector<float> reference_f, radius2_f;
  double one_radius2 = 0.0;
};

/// The nodes of blocks [begin, end) of `f` beyond their radius in the state `x`
/// (|x - q|^2 <= r^2 fails): kKind 0 reads a double reference and squared radius a node,
/// 1 a double reference and one radius for all, 2 a float reference and squared radius a
/// node (converted to doubles in the lanes). Built twice (compare_blocks_*).
template <int kKind>
[[gnu::always_inline]] inline std::size_t compare_lanes(const CompareFloor& f, const double* x,
                                                        std::size_t begin, std::size_t end) {
  using Mask = long long __attribute__((vector_size(32)));
  Mask within = {0, 0, 0, 0};  // minus the count of lanes within, by lane
  const Lanes4d one = {f.one_radius2, f.one_radius2, f.one_radius2, f.one_radius2};
  for (std::size_t b = begin; b < end; ++b) {
    Lanes4d px, py, pz, qx, qy, qz, r2 = one;
    std::memcpy(&px, x + 12 * b, sizeof px);
    std::memcpy(&py, x + 12 * b + 4, sizeof py);
    std::memcpy(&pz, x + 12 * b + 8, sizeof pz);
    if constexpr (kKind == 2) {
      Lanes4f fx, fy, fz, fr;
      std::memcpy(&fx, f.reference_f.data() + 12 * b, sizeof fx);
      std::memcpy(&fy, f.reference_f.data() + 12 * b + 4, sizeof fy);
      std::memcpy(&fz, f.reference_f.data() + 12 * b + 8, sizeof fz);
      std::memcpy(&fr, f.radius2_f.data() + 4 * b, sizeof fr);
      qx = __builtin_convertvector(fx, Lanes4d);
      qy = __builtin_convertvector(fy, Lanes4d);
      qz = __builtin_convertvector(fz, Lanes4d);
      r2 = __builtin_convertvector(fr, Lanes4d);
    } else {
      std::memcpy(&qx, f.reference.data() + 12 * b, sizeof qx);
      std::memcpy(&qy, f.reference.data() + 12 * b + 4, sizeof qy);
      std::memcpy(&qz, f.reference.data() + 12 * b + 8, sizeof qz);
      if constexpr (kKind == 0) std::memcpy(&r2, f.radius2.data() + 4 * b, sizeof r2);
    }
    const Lanes4d dx = px - qx, dy = py - qy, dz = pz - qz;
    within += (dx * dx + dy * dy + dz * dz) <= r2;
  }
  const long long inside = -(within[0] + within[1] + within[2] + within[3]);
  return 4 * (end - begin) - static_cast<std::size_t>(inside);
}

template <int kKind>
TC_AVX2_TARGET std::size_t compare_blocks_avx2(const CompareFloor& f, const double* x,
                                               std::size_t begin, std::size_t end) {
  return compare_lanes<kKind>(f, x, begin, end);
}
template <int kKind>
std::size_t compare_blocks_baseline(const CompareFloor& f, const double* x, std::size_t begin,
                                    std::size_t end) {
  return compare_lanes<kKind>(f, x, begin, end);
}

/// Floor of any check that compares every node with a reference of its own (goal 1 of
/// issue 13 asks that a frame outside the contact cost at most one read of the positions):
/// |x - q|^2 <= r^2 for every node of motion 1's states, and nothing else: no shift, no
/// box, no list of the nodes beyond (a count), and the positions handed over already in
/// the reference's blocks (the check gets them x y z a node, and shuffles). In chunks of
/// 8,192 nodes on state.range(0) threads, as the parallel read; state.range(1): the kind of
/// reference (compare_lanes()). The AVX2 copy where the shape check runs its own.
void BM_Baseline_CompareWithReferenceOnce(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(state.range(0)));
  static const CompareFloor f;
  const long kind = state.range(1);
  using Kernel = std::size_t (*)(const CompareFloor&, const double*, std::size_t, std::size_t);
  const Kernel kernels[3][2] = {{compare_blocks_baseline<0>, compare_blocks_avx2<0>},
                                {compare_blocks_baseline<1>, compare_blocks_avx2<1>},
                                {compare_blocks_baseline<2>, compare_blocks_avx2<2>}};
  const Kernel kernel = kernels[kind][tc::use_avx2_kernels() ? 1 : 0];
  std::size_t frame = 0;
  for (auto _ : state) {
    const double* x = f.positions[frame++ % f.positions.size()].data();
    const std::size_t beyond = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, f.lanes / 4, 8192 / 4), std::size_t{0},
        [&](const tbb::blocked_range<std::size_t>& r, std::size_t acc) {
          return acc + kernel(f, x, r.begin(), r.end());
        },
        std::plus<>());
    if (beyond != 0) state.SkipWithError("a node moved beyond its radius");
    benchmark::DoNotOptimize(beyond);
  }
  state.counters["nodes"] = static_cast<double>(f.nodes);
}

}  // namespace

BENCHMARK(BM_Baseline_ReadPositionsOnce)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Baseline_ReadPositionsOnceParallel)
    ->Arg(1)
    ->Arg(2)
    ->ArgName("threads")
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Baseline_CompareWithReferenceOnce)
    ->ArgsProduct({{1, 2}, {0, 1, 2}})
    ->ArgNames({"threads", "kind"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_ValidatePositions)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ValidatePositionsShuffled)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_ValidatePositionsShuffledMorton)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_ShapeCheck)
    ->ArgsProduct({{1, 2}, {0, 1, 2, 3, 4, 5}, {0, 1}})
    ->ArgNames({"threads", "motion", "full"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_NodePasses)
    ->ArgsProduct({{1, 2}, {1, 2, 4}})
    ->ArgNames({"threads", "motion"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_ValidatePositionsMinQuality)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_Baseline_CountLines22)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Baseline_Istream22)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadGmsh22Ascii)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadGmsh41Ascii)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadGmsh41Binary)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadTetGen)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_WriteVtu)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
