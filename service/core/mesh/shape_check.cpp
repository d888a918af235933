#include "core/mesh/shape_check.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include <emmintrin.h>  // SSE2 (x86-64 baseline): _mm_movemask_pd
#include <immintrin.h>  // AVX (the AVX2 copy only): _mm256_movemask_pd

#include "core/common/chunked.hpp"
#include "core/common/cpu_dispatch.hpp"
#include "core/common/parallel_chunks.hpp"
#include "core/common/target_clones.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/sorted_index_set.hpp"

namespace tc {
namespace {

/// Items per chunk of the parallel radius loops.
constexpr std::size_t kRadiusChunk = 4096;

/// Tets per call of detail::motion_radii_lanes().
constexpr std::size_t kRadiusLanes = 8;

/// Objects with more nodes take their shift, and first look for a busy state, from a sample:
/// runs of kSampleRun nodes, one every kSamplePeriod nodes. Runs rather than single nodes:
/// the sample then reads few cache lines it does not use (about a tenth of the pass's time
/// went to a sample of every 16th node, each on a line of its own).
constexpr std::size_t kSampleAbove = 8192;
constexpr std::size_t kSampleRun = 8;
constexpr std::size_t kSamplePeriod = 512;

/// More than one node in this many moved: check every tet (a rotation, a large step).
constexpr std::size_t kBusyFraction = 4;

/// States a fitted turn rests after one that did no better than the shift
/// (ShapeCheck::keep_fit_if_better).
constexpr std::size_t kFitPause = 8;

/// Nodes per step of detail::motion_pass().
constexpr std::size_t kPassStep = 4;

/// Where coordinate c of node i lies in the motion pass's copy of the reference
/// (ShapeCheck::blocks_: blocks of kPassStep nodes, coordinate by coordinate).
constexpr std::size_t block_slot(std::size_t i, std::size_t c) {
  return kPassStep * (3 * (i / kPassStep) + c) + i % kPassStep;
}

/// The chunks of the parallel motion pass: about kPassChunk nodes each, a multiple of
/// kPassSplit of them (so that two or four threads share them evenly: seven chunks on two
/// threads took 4/3.5 of the time), each a multiple of kPassStep nodes but the last. The
/// chunks depend on the number of nodes only; the pass's results do not depend on them.
constexpr std::size_t kPassChunk = 8192;
constexpr std::size_t kPassSplit = 4;

std::size_t pass_chunk(std::size_t n) {
  if (n <= kPassChunk) return kPassChunk;
  const std::size_t chunks = (detail::num_chunks(n, kPassChunk) + kPassSplit - 1) / kPassSplit;
  const std::size_t size = detail::num_chunks(n, chunks * kPassSplit);
  return detail::num_chunks(size, kPassStep) * kPassStep;
}

/// Squared motion of the node at x (3 coordinates; reference position r) once `shift` is
/// removed. The one expression of ShapeCheck::check's motion test, node by node and in
/// detail::motion_pass's lanes, so both give the same bits.
[[gnu::always_inline]] inline double motion2(const double* x, const double* r,
                                             const double* shift) {
  const double dx = x[0] - r[0] - shift[0];
  const double dy = x[1] - r[1] - shift[1];
  const double dz = x[2] - r[2] - shift[2];
  return dx * dx + dy * dy + dz * dz;
}

/// The same after a turn: the squared distance of x from R (r - p) + shift, with turn = R by
/// rows, then the pivot p. Computed as (x - shift) - R (r - p): both differences are of
/// nearby numbers, so the rounding is of the order of the object's size, not of its
/// distance from the origin (ShapeCheck::budget_ leaves room for it). The one expression of the
/// test after a rigid motion (ShapeCheck::check, detail::motion_pass).
[[gnu::always_inline]] inline double rigid_motion2(const double* x, const double* r,
                                                   const double* shift, const double* turn) {
  const double qx = r[0] - turn[9], qy = r[1] - turn[10], qz = r[2] - turn[11];
  const double dx = (x[0] - shift[0]) - (turn[0] * qx + turn[1] * qy + turn[2] * qz);
  const double dy = (x[1] - shift[1]) - (turn[3] * qx + turn[4] * qy + turn[5] * qz);
  const double dz = (x[2] - shift[2]) - (turn[6] * qx + turn[7] * qy + turn[8] * qz);
  return dx * dx + dy * dy + dz * dz;
}

/// A rigid motion x = R (r - p) + shift: turn holds R by rows (a proper rotation up to
/// rounding), then the pivot p. defect: ||R^T R - I|| (Frobenius, as computed).
struct Rigid {
  double turn[12];
  double shift[3];
  double defect;
};

constexpr double kEps = std::numeric_limits<double>::epsilon();

/// The squared radius of a node in no tet: the largest finite number, which a node in a
/// tet never has (its radius is below its first edge, under 1e66 when it has one).
constexpr double kNoTetRadius2 = std::numeric_limits<double>::max();

/// The room a computed squared distance d^2 must leave below a squared radius r^2 for the
/// exact distance to be within r, when the computed d can be off by `error` and every
/// radius is at most `rcap`: (d + error)^2 <= r^2 follows from d^2 + error (2 rcap + error)
/// <= r^2 when d <= rcap, and d > rcap is beyond anyway.
///
/// The certificate (certified_motion_radius()) is about the exact distance, and the test
/// takes differences of numbers that may be large: x - r - shift rounds at about
/// eps |shift|, (x - shift) - R (r - p) at about eps |r - p| (up to D, the reach of the
/// references from the pivot). A node in no tet parked far away dragged the pivot there,
/// and the rounding hid moved nodes (the fuzz target `mesh` found it). Twice the worst
/// case (docs/DETECTION.md, "Rounding of the motion test"):
///   after a shift:  error = eps |shift| + 4 eps rcap
///   after a turn:   error = (24 eps + 2 defect) D + 4 eps rcap
/// The squared radii are kept less the room for kBudgetReach eps of the reference's extent
/// (ShapeCheck::budget_), which covers a shift by up to 128 extents and any turn of a
/// defect up to 52 eps (a unit quaternion's is at most about 14 eps); a motion whose room
/// would be more is not used.
double rounding_slack(double error, double rcap) {
  return error * (2.0 * rcap + error);
}

/// The rounding the kept room covers, in eps times the reference's extent.
constexpr double kBudgetReach = 128.0;

/// The rounding of the motion test after a shift, and after a turn with the pivot `reach`
/// from every reference (rounding_slack()).
double shift_error(const double* shift, double rcap) {
  return kEps * std::sqrt(shift[0] * shift[0] + shift[1] * shift[1] + shift[2] * shift[2]) +
         4.0 * kEps * rcap;
}
double turn_error(double defect, double reach, double rcap) {
  return (24.0 * kEps + 2.0 * defect) * reach + 4.0 * kEps * rcap;
}

/// The rigid motion that maps the references r of the nodes sample(visit) visits onto their
/// positions x best in least squares: Horn's closed form (J. Opt. Soc. Am. A 4(4), 1987),
/// R from the unit eigenvector of the largest eigenvalue of a symmetric 4x4 matrix made from
/// the cross-covariance of the centred points, about the references' centroid (the pivot)
/// onto the positions' (the shift). One order of sums, so the same bits for the same
/// nodes. Nothing when a sum is not finite (a NaN or an infinite node) or the eigenvector
/// is not (a degenerate sample).
template <typename Sample>
std::optional<Rigid> fit_rigid(const double* x, const double* r, const Sample& sample) {
  double cx[3] = {}, cr[3] = {};
  std::size_t count = 0;
  sample([&](std::size_t i) {
    for (int c = 0; c < 3; ++c) {
      cx[c] += x[3 * i + c];
      cr[c] += r[3 * i + c];
    }
    ++count;
  });
  if (count == 0) return std::nullopt;
  for (int c = 0; c < 3; ++c) {
    cx[c] /= static_cast<double>(count);
    cr[c] /= static_cast<double>(count);
  }
  double h[3][3] = {};  // sum of (r - cr)(x - cx)^T
  sample([&](std::size_t i) {
    const double a[3] = {r[3 * i] - cr[0], r[3 * i + 1] - cr[1], r[3 * i + 2] - cr[2]};
    const double b[3] = {x[3 * i] - cx[0], x[3 * i + 1] - cx[1], x[3 * i + 2] - cx[2]};
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) h[j][k] += a[j] * b[k];
  });
  Eigen::Matrix4d n;
  n << h[0][0] + h[1][1] + h[2][2], h[1][2] - h[2][1], h[2][0] - h[0][2], h[0][1] - h[1][0],  //
      h[1][2] - h[2][1], h[0][0] - h[1][1] - h[2][2], h[0][1] + h[1][0], h[2][0] + h[0][2],   //
      h[2][0] - h[0][2], h[0][1] + h[1][0], -h[0][0] + h[1][1] - h[2][2], h[1][2] + h[2][1],  //
      h[0][1] - h[1][0], h[2][0] + h[0][2], h[1][2] + h[2][1], -h[0][0] - h[1][1] + h[2][2];
  if (!n.allFinite()) return std::nullopt;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eigen(n);
  if (eigen.info() != Eigen::Success) return std::nullopt;
  const Eigen::Vector4d q = eigen.eigenvectors().col(3);  // eigenvalues ascend
  const Eigen::Quaterniond turn(q[0], q[1], q[2], q[3]);
  if (!(turn.norm() > 0.5)) return std::nullopt;  // not finite, or not a unit vector
  const Eigen::Matrix3d rot = turn.normalized().toRotationMatrix();
  Rigid m;  // about the references' centroid, onto the positions'
  m.defect = (rot.transpose() * rot - Eigen::Matrix3d::Identity()).norm();  // (check()'s fits)
  for (int j = 0; j < 3; ++j) {
    for (int k = 0; k < 3; ++k) m.turn[3 * j + k] = rot(j, k);
    m.turn[9 + j] = cr[j];
    m.shift[j] = cx[j];
  }
  for (const double v : m.turn)
    if (!std::isfinite(v)) return std::nullopt;
  return m;
}

}  // namespace

namespace detail {

/// certified_motion_radius() of kRadiusLanes tets at once, in plain lane loops the compiler
/// vectorises (AVX2 and baseline copies, pick_kernel(); the same operations in the
/// same order in every copy and lane, so the same bits). The bound: see the header. q^2 = 432
/// (6V)^2 / l2^3 with l2 the sum of the six squared edge lengths, so the tet keeps q >= s while
/// sqrt(432) W(d) >= s L(d)^(3/2), W and L the bounds on 6V and l2 after each node moved
/// by d:
///   W(d) = v6 - grad d - 4 arms d^2 - 8 d^3,   L(d) = l2 + 4 lengths d + 24 d^2.
/// On [0, h] both are linear at worst: W(d) >= v6 - a d with a = grad + 4 arms h + 8 h^2,
/// and L^(3/2), convex, lies below its chord c0 + c1 d; the linear condition then gives d
/// in closed form. W > 0 needs d < v6 / grad; of a few h below that, the best is taken.
/// The margin on s (0.1% and 1e-6) is far above the rounding of this bound and of
/// tet_quality().
[[gnu::always_inline]] inline void motion_radii_lanes(const double* x, const Tet* tets,
                                                      double quality, double* out) {
  constexpr int L = static_cast<int>(kRadiusLanes);
  double p[4][3][L];
  for (int l = 0; l < L; ++l)
    for (int j = 0; j < 4; ++j)
      for (int c = 0; c < 3; ++c) p[j][c][l] = x[3 * static_cast<std::ptrdiff_t>(tets[l][j]) + c];
  const double s = 1.001 * quality + 1e-6;
  const double root432 = std::sqrt(432.0);
  for (int l = 0; l < L; ++l) {
    double e[3][3], f[3][3];  // edges from node 0; edges 1-2, 1-3, 2-3
    for (int c = 0; c < 3; ++c) {
      e[0][c] = p[1][c][l] - p[0][c][l];
      e[1][c] = p[2][c][l] - p[0][c][l];
      e[2][c] = p[3][c][l] - p[0][c][l];
      f[0][c] = p[2][c][l] - p[1][c][l];
      f[1][c] = p[3][c][l] - p[1][c][l];
      f[2][c] = p[3][c][l] - p[2][c][l];
    }
    // 6V = e1 . (e2 x e3); its gradient with respect to node i is g_i, g0 = -(g1+g2+g3).
    double g[4][3];
    for (int k = 0; k < 3; ++k) {
      const double* u = e[(k + 1) % 3];
      const double* v = e[(k + 2) % 3];
      g[k + 1][0] = u[1] * v[2] - u[2] * v[1];
      g[k + 1][1] = u[2] * v[0] - u[0] * v[2];
      g[k + 1][2] = u[0] * v[1] - u[1] * v[0];
    }
    for (int c = 0; c < 3; ++c) g[0][c] = -(g[1][c] + g[2][c] + g[3][c]);
    const double v6 = e[0][0] * g[1][0] + e[0][1] * g[1][1] + e[0][2] * g[1][2];
    double grad = 0.0, arms = 0.0, lengths = 0.0, l2 = 0.0;
    for (int k = 0; k < 4; ++k)
      grad += std::sqrt(g[k][0] * g[k][0] + g[k][1] * g[k][1] + g[k][2] * g[k][2]);
    for (int k = 0; k < 3; ++k) {
      const double a2 = e[k][0] * e[k][0] + e[k][1] * e[k][1] + e[k][2] * e[k][2];
      const double b2 = f[k][0] * f[k][0] + f[k][1] * f[k][1] + f[k][2] * f[k][2];
      arms += std::sqrt(a2);
      lengths += std::sqrt(b2);
      l2 += a2 + b2;
    }
    lengths += arms;
    const double c0 = l2 * std::sqrt(l2);  // L(0)^(3/2)
    const double top = v6 / grad;
    double best = 0.0;
    for (const double fraction : {1.0, 0.7, 0.5, 0.3}) {
      const double h = fraction * top;
      const double a = grad + h * (4.0 * arms + 8.0 * h);
      const double lh = l2 + h * (4.0 * lengths + 24.0 * h);
      const double c1 = (lh * std::sqrt(lh) - c0) / h;
      const double d = (root432 * v6 - s * c0) / (root432 * a + s * c1);
      const double r = h < d ? h : d;
      best = best < r ? r : best;
    }
    // Not good enough as it is, or of a size whose quality (here, or in tet_quality()) is
    // not computed without overflow or underflow: no radius. l2^1.5 in (1e-200, 1e200) is
    // edges of about 1e-67 m to 1e66 m (the squared gradients overflow at about 1e77 m);
    // the full check decides other tets as tet_quality() computes them.
    const bool good = v6 > 0.0 && grad > 0.0 && c0 > 1e-200 && c0 < 1e200 && root432 * v6 >= s * c0;
    out[l] = good ? best : -1.0;
  }
}

/// The two copies of motion_radii_lanes() (pick_kernel()).
void motion_radii_baseline(const double* x, const Tet* tets, double quality, double* out) {
  motion_radii_lanes(x, tets, quality, out);
}
TC_AVX2_TARGET void motion_radii_avx2(const double* x, const Tet* tets, double quality,
                                      double* out) {
  motion_radii_lanes(x, tets, quality, out);
}

/// Appends node k + l to `moved` for each bit l of mask, in order.
[[gnu::noinline]] void append_moved(std::vector<Index>& moved, std::size_t k, unsigned mask) {
  for (; mask != 0; mask &= mask - 1)
    moved.push_back(static_cast<Index>(k + static_cast<std::size_t>(std::countr_zero(mask))));
}

namespace baseline {
#define TC_MOTION_PASS_AVX2 0
#include "core/mesh/motion_pass.inc"
#undef TC_MOTION_PASS_AVX2
}  // namespace baseline

}  // namespace detail

#if TC_HAS_AVX2_REGION
TC_AVX2_REGION_BEGIN
namespace detail::avx2 {
#define TC_MOTION_PASS_AVX2 1
#include "core/mesh/motion_pass.inc"
#undef TC_MOTION_PASS_AVX2
}  // namespace detail::avx2
TC_AVX2_REGION_END
#endif

namespace detail {

/// The pass of the copy this CPU runs (motion_pass.inc).
void motion_pass(const double* x, const double* blocks, const double* rad2, const double* shift,
                 const double* turn, std::size_t begin, std::size_t end, std::vector<Index>& moved,
                 PointBox& box, double& within2) {
#if TC_HAS_AVX2_REGION
  if (use_avx2_kernels())
    return avx2::motion_pass(x, blocks, rad2, shift, turn, begin, end, moved, box, within2);
#endif
  baseline::motion_pass(x, blocks, rad2, shift, turn, begin, end, moved, box, within2);
}

}  // namespace detail

double certified_motion_radius(const Positions& positions, const Tet& tet, double quality) {
  Tet batch[kRadiusLanes];
  for (Tet& t : batch) t = tet;
  double out[kRadiusLanes];
  pick_kernel(detail::motion_radii_baseline, detail::motion_radii_avx2)(positions.data(), batch,
                                                                        quality, out);
  return out[0];
}

namespace {

/// The radii of order[begin, end), kRadiusLanes at a time, in parallel chunks.
template <typename PlaceOf>
void compute_radii(const Positions& x, const std::vector<Tet>& tets, double quality,
                   std::size_t count, const PlaceOf& place_of, std::vector<double>& radius) {
  const auto motion_radii = pick_kernel(detail::motion_radii_baseline, detail::motion_radii_avx2);
  detail::for_chunks(count, kRadiusChunk, [&](std::size_t begin, std::size_t end, std::size_t) {
    Tet batch[kRadiusLanes];
    double out[kRadiusLanes];
    for (std::size_t j = begin; j < end; j += kRadiusLanes) {
      const std::size_t lanes = std::min<std::size_t>(kRadiusLanes, end - j);
      for (std::size_t l = 0; l < kRadiusLanes; ++l)
        batch[l] = tets[place_of(j + std::min(l, lanes - 1))];
      motion_radii(x.data(), batch, quality, out);
      for (std::size_t l = 0; l < lanes; ++l) radius[place_of(j + l)] = out[l];
    }
  });
}

}  // namespace

ShapeCheck::ShapeCheck(const TetCheckOrder& order, const Csr& node_tets, Index num_nodes,
                       const ValidationOptions& options)
    : order_(order),
      node_tets_(node_tets),
      num_nodes_(num_nodes),
      options_(options),
      quality_(std::max(options.sliver_quality, options.degenerate_quality)) {
  if (node_tets.rows() != num_nodes)
    throw std::invalid_argument("ShapeCheck: node_tets has " + std::to_string(node_tets.rows()) +
                                " rows for " + std::to_string(num_nodes) + " nodes");
  if (order.index.size() != order.tets.size())
    throw std::invalid_argument("ShapeCheck: " + std::to_string(order.index.size()) +
                                " indices for " + std::to_string(order.tets.size()) + " tets");
  if (options.compute_min_quality)
    throw std::invalid_argument(
        "ShapeCheck: compute_min_quality needs every tet; use validate_positions()");
  position_of_.assign(order.tets.size(), 0);
  for (std::size_t k = 0; k < order.index.size(); ++k)
    position_of_[static_cast<std::size_t>(order.index[k])] = static_cast<Index>(k);
}

double ShapeCheck::node_radius2(Index node) const {
  const auto tets = node_tets_.row(node);
  if (tets.empty()) return kNoTetRadius2;  // only NaN moves it
  double r = std::numeric_limits<double>::infinity();
  for (const Index t : tets) r = std::min(r, radius_[static_cast<std::size_t>(position_of_[t])]);
  const double kept = r * r - budget_;  // less the room for rounding
  return r < 0.0 || !(kept >= 0.0) ? -1.0 : kept;
}

void ShapeCheck::set_block_node(Index node) {
  const auto i = static_cast<std::size_t>(node);
  for (std::size_t c = 0; c < 3; ++c)
    blocks_[block_slot(i, c)] = reference_(static_cast<Index>(c), node);
}

void ShapeCheck::cover(Index node) {
  if (node_tets_.row(node).empty()) return;  // an orphan: its motion changes no tet
  for (int c = 0; c < 3; ++c) {
    ref_lo_[c] = std::min(ref_lo_[c], reference_(c, node));
    ref_hi_[c] = std::max(ref_hi_[c], reference_(c, node));
  }
}

double ShapeCheck::reach(const double* pivot) const {
  if (!(ref_lo_[0] <= ref_hi_[0])) return 0.0;  // no node in a tet
  double sum = 0.0;
  for (int c = 0; c < 3; ++c) {
    const double far = std::max(ref_hi_[c] - pivot[c], pivot[c] - ref_lo_[c]);
    sum += far * far;
  }
  return std::sqrt(sum);
}

void ShapeCheck::rebuild(const Positions& positions) {
  reference_ = positions;
  blocks_.assign(
      3 * detail::num_chunks(static_cast<std::size_t>(num_nodes_), kPassStep) * kPassStep, 0.0);
  for (Index i = 0; i < num_nodes_; ++i) set_block_node(i);
  radius_.resize(order_.tets.size());
  compute_radii(
      reference_, order_.tets, quality_, radius_.size(), [](std::size_t k) { return k; }, radius_);
  // The room for rounding kept off the squared radii (rounding_slack()): for kBudgetReach
  // eps of the extent of the references of nodes in tets.
  rcap2_ = 0.0;
  for (const double t : radius_)
    if (t > 0.0) rcap2_ = std::max(rcap2_, t * t);  // (-1: no radius)
  for (int c = 0; c < 3; ++c) {
    ref_lo_[c] = std::numeric_limits<double>::infinity();
    ref_hi_[c] = -ref_lo_[c];
  }
  for (Index i = 0; i < num_nodes_; ++i) cover(i);
  double extent2 = 0.0;
  for (int c = 0; c < 3; ++c)
    if (ref_lo_[c] <= ref_hi_[c]) extent2 += (ref_hi_[c] - ref_lo_[c]) * (ref_hi_[c] - ref_lo_[c]);
  const double rcap = std::sqrt(rcap2_);
  budget_ = rounding_slack(kBudgetReach * kEps * std::sqrt(extent2) + 4.0 * kEps * rcap, rcap);
  radius2_.resize(static_cast<std::size_t>(num_nodes_));
  detail::for_chunks(radius2_.size(), kRadiusChunk,
                     [&](std::size_t begin, std::size_t end, std::size_t) {
                       for (std::size_t i = begin; i < end; ++i)
                         radius2_[i] = node_radius2(static_cast<Index>(i));
                     });
  last_.rebuilt = true;
  last_.bounded = true;  // every node at its reference, no shift
  last_.motion2 = 0.0;
  last_.shift.setZero();
  last_.rotated = false;
  last_.rotation.setIdentity();
  last_.pivot.setZero();
  turning_ = false;
  last_.version_after = ++version_;
}

MotionBound ShapeCheck::bound() const {
  MotionBound b;
  b.bounded = last_.bounded;
  b.rebuilt = last_.rebuilt;
  b.version_before = last_.version_before;
  b.version_after = last_.version_after;
  b.shift = last_.shift;
  b.rotated = last_.rotated;
  b.rotation = last_.rotation;
  b.pivot = last_.pivot;
  b.reference = &reference_;
  b.radius2 = radius2_;
  b.motion = b.bounded ? std::sqrt(last_.motion2) : std::numeric_limits<double>::infinity();
  if (b.version_after != b.version_before && !b.rebuilt) {
    b.moved = moved_;
    b.changed = nodes_;
  }
  return b;
}

ValidationReport ShapeCheck::check_all(const Positions& positions, bool rebuild_reference) {
  ValidationReport report = validate_positions(positions, order_, options_);
  last_.full = true;
  if (report.nonfinite_node.count == 0) last_.checked_tets = order_.tets.size();
  if (rebuild_reference && report.clean()) rebuild(positions);
  return report;
}

namespace {

/// Calls visit(i) for each node i of the sample of an object of n nodes that check() takes
/// its shift from: every node, or above kSampleAbove nodes runs of kSampleRun nodes, one
/// every kSamplePeriod nodes.
template <typename Visit>
void visit_sample(std::size_t n, const Visit& visit) {
  const bool sampled = n > kSampleAbove;
  const std::size_t run = sampled ? kSampleRun : 1, period = sampled ? kSamplePeriod : 1;
  for (std::size_t b = 0; b < n; b += period)
    for (std::size_t i = b; i < std::min(b + run, n); ++i) visit(i);
}

}  // namespace

/// The motion check() compares a state's nodes with their references after: the shift
/// (`rigid` turns by the identity), or, when `turned`, a turn and a shift (fit_rigid()).
struct ShapeCheck::Motion {
  Rigid rigid;
  bool turned = false;
};

ValidationReport ShapeCheck::check(const Positions& positions) {
  if (positions.cols() != num_nodes_)
    throw std::invalid_argument("ShapeCheck: " + std::to_string(positions.cols()) +
                                " positions for " + std::to_string(num_nodes_) + " nodes");
  last_ = {};
  last_.version_before = last_.version_after = version_;
  if (reference_.cols() == 0) return check_all(positions, true);

  // A translation changes no tet's shape: the displacements are compared after removing
  // one shift, the mean displacement of the nodes (of a sample on a large object: any
  // common shift is as sound).
  const std::size_t n = static_cast<std::size_t>(num_nodes_);
  const double* x = positions.data();
  const double* r = reference_.data();
  double sx = 0.0, sy = 0.0, sz = 0.0;
  std::size_t samples = 0;
  visit_sample(n, [&](std::size_t i) {
    sx += x[3 * i] - r[3 * i];
    sy += x[3 * i + 1] - r[3 * i + 1];
    sz += x[3 * i + 2] - r[3 * i + 2];
    ++samples;
  });
  const double count = static_cast<double>(std::max<std::size_t>(samples, 1));
  const double shift[3] = {sx / count, sy / count, sz / count};
  if (!(std::isfinite(shift[0]) && std::isfinite(shift[1]) && std::isfinite(shift[2])))
    return check_all(positions, false);  // a NaN or infinite coordinate: the full report
  Motion motion{{{1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0}, {shift[0], shift[1], shift[2]}, 0.0}, false};
  if (!compare_nodes(x, samples, motion)) return check_busy(positions);
  last_.moved_nodes = moved_.size();
  if (kBusyFraction * moved_.size() > n) return check_busy(positions);
  // Every node that is not finite is beyond its radius (orphans' radius is the largest
  // finite number): the full check reports those.
  for (const Index i : moved_)
    if (!positions.col(i).allFinite()) return check_all(positions, false);
  busy_streak_ = 0;

  ValidationReport report = check_moved_tets(positions);
  if (!report.clean()) return report;
  record_bound(motion);
  if (moved_.empty()) return report;
  accept_moved(positions, motion);
  return report;
}

ValidationReport ShapeCheck::check_busy(const Positions& positions) {
  ++busy_streak_;
  return check_all(positions, (busy_streak_ & (busy_streak_ - 1)) == 0);
}

bool ShapeCheck::fit_turn(const double* x, Motion& motion) {
  const std::size_t n = static_cast<std::size_t>(num_nodes_);
  const double* r = reference_.data();
  const double rcap = std::sqrt(rcap2_);
  // The fit takes the sampled nodes that are in a tet: a node in none does not count, however
  // it moves or wherever it is parked (far away, it would drag the pivot there).
  const auto visit_fit = [&](const auto& visit) {
    visit_sample(n, [&](std::size_t i) {
      if (radius2_[i] != kNoTetRadius2) visit(i);
    });
  };
  auto m = fit_rigid(x, r, visit_fit);
  const auto fits = [&](const Rigid& f) {
    return rounding_slack(turn_error(f.defect, reach(f.turn + 9), rcap), rcap) <= budget_;
  };
  if (m && !fits(*m)) m.reset();
  if (m) {
    // Fitted again to the nodes the first fit leaves within their radii: a few nodes
    // that moved far (a dent) pull a least-squares fit enough to leave their neighbours
    // beyond their radii too. (None beyond, as when the object only turned: the same
    // nodes, the same fit.)
    outside_.clear();
    visit_fit([&](std::size_t i) {
      if (!(rigid_motion2(x + 3 * i, r + 3 * i, m->shift, m->turn) <= radius2_[i]))
        outside_.push_back(i);
    });
    const auto visit_within = [&](const auto& visit) {  // those less outside_
      std::size_t next = 0;
      visit_fit([&](std::size_t i) {
        if (next < outside_.size() && outside_[next] == i)
          ++next;
        else
          visit(i);
      });
    };
    if (!outside_.empty())
      if (const auto second = fit_rigid(x, r, visit_within); second && fits(*second)) m = second;
  }
  if (m) motion.rigid = *m;
  motion.turned = m.has_value();
  return motion.turned;
}

// A turn, fast or slow, shows as nodes beyond their radii after the shift alone. A fitted
// turn is taken when it leaves clearly fewer beyond (an eighth fewer, at least one), or
// fewer than kBusyFraction where the shift left more. A dent stays with the shift, and the
// fit then rests for kFitPause states that the shift does not leave busy. Without this,
// an object turning a little each frame saw a few nodes beyond every frame, each made its
// own reference after the shift alone, and never enough to try a turn; the references,
// turned by different amounts, then left no fit that held. The pawn turning 0.05 degrees
// a frame cost 7.5 ms a frame, and 0.07 ms turning 0.2 degrees (docs/DETECTION.md,
// "Rigid motions in the shape check").
template <typename CountBeyond>
std::size_t ShapeCheck::keep_fit_if_better(const double* x, Motion& motion, std::size_t by_shift,
                                           const CountBeyond& count_beyond, std::size_t of) {
  const bool busy_by_shift = kBusyFraction * by_shift > of;
  if (fit_pause_ > 0 && !busy_by_shift) {  // (a busy state always tries the fit)
    --fit_pause_;
    return by_shift;
  }
  const Rigid shift_motion = motion.rigid;
  if (fit_turn(x, motion)) {
    const std::size_t by_fit = count_beyond();
    if (by_fit + std::max<std::size_t>(1, by_shift / 8) <= by_shift ||
        (busy_by_shift && kBusyFraction * by_fit <= of))
      return by_fit;
  }
  motion.rigid = shift_motion;
  motion.turned = false;
  fit_pause_ = kFitPause;
  return by_shift;
}

bool ShapeCheck::compare_nodes(const double* x, std::size_t samples, Motion& motion) {
  const std::size_t n = static_cast<std::size_t>(num_nodes_);
  const bool sampled = n > kSampleAbove;
  const double* r = reference_.data();
  // The motion is used only if its rounding fits the room kept off the radii (budget_,
  // rounding_slack()); a shift too far from the reference is fitted as a rigid motion
  // (about the centroids, whose rounding does not grow with the shift).
  const double rcap = std::sqrt(rcap2_);
  const bool shift_fits = rounding_slack(shift_error(motion.rigid.shift, rcap), rcap) <= budget_;
  // An object that was turning is compared after a turn straight away (a translation alone
  // would leave most of its nodes beyond their radii).
  if ((turning_ || !shift_fits) && !fit_turn(x, motion)) return false;
  if (sampled) {  // a rotation shows in the sample: no need to look at every node
    const auto beyond = [&](std::size_t i) {  // NaN: beyond
      const double d2 =
          motion.turned ? rigid_motion2(x + 3 * i, r + 3 * i, motion.rigid.shift, motion.rigid.turn)
                        : motion2(x + 3 * i, r + 3 * i, motion.rigid.shift);
      return !(d2 <= radius2_[i]);
    };
    const auto sample_beyond = [&] {
      std::size_t moved = 0;
      visit_sample(n, [&](std::size_t i) { moved += beyond(i) ? 1 : 0; });
      return moved;
    };
    std::size_t moved = sample_beyond();
    if (moved > 0 && !motion.turned)
      moved = keep_fit_if_better(x, motion, moved, sample_beyond, samples);
    if (kBusyFraction * moved > samples) return false;
  }
  pass_nodes(x, motion);
  // A small object has no sample: its pass tells, and a turn is tried after it (and the
  // shift's pass made again when the turn does not do better).
  if (!sampled && !motion.turned && !moved_.empty()) {
    bool passed_turned = false;
    const auto pass_beyond = [&] {
      pass_nodes(x, motion);
      passed_turned = true;
      return moved_.size();
    };
    keep_fit_if_better(x, motion, moved_.size(), pass_beyond, n);
    if (passed_turned && !motion.turned) pass_nodes(x, motion);
  }
  return true;
}

void ShapeCheck::pass_nodes(const double* x, const Motion& motion) {
  // The box of the positions on the way: the nodes are in cache, and the detection
  // then need not read them again. In chunks of nodes (pass_chunk(); one for a small
  // object), each with its own list and box, joined in chunk order: moved_ comes sorted, and
  // the box is the node-by-node box (a later chunk's extreme replaces the earlier one
  // only when strictly beyond it, as a later node's does).
  const std::size_t n = static_cast<std::size_t>(num_nodes_);
  const std::size_t chunk = pass_chunk(n);
  const std::size_t chunks = detail::num_chunks(n, chunk);
  detail::reset_parts(moved_parts_, chunks);
  pass_boxes_.assign(chunks, PointBox{});
  pass_within2_.assign(chunks, 0.0);
  const double* turn = motion.turned ? motion.rigid.turn : nullptr;
  detail::for_chunks(n, chunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
    PointBox box;
    double within2 = 0.0;
    detail::motion_pass(x, blocks_.data(), radius2_.data(), motion.rigid.shift, turn, begin, end,
                        moved_parts_[c], box, within2);
    pass_boxes_[c] = box;
    pass_within2_[c] = within2;
  });
  detail::concat_parts(moved_parts_, chunks, moved_);
  PointBox box;
  for (const PointBox& part : pass_boxes_) box.add(part);
  last_.motion2 = 0.0;  // (a maximum: the same whatever the chunks)
  for (const double w : pass_within2_) last_.motion2 = std::max(last_.motion2, w);
  last_.has_box = true;
  last_.box_lo = box.lo();
  last_.box_hi = box.hi();
}

ValidationReport ShapeCheck::check_moved_tets(const Positions& positions) {
  // The tets of the nodes that moved, in check order.
  places_.clear();
  {
    detail::SortedIndexSet set(place_bits_, order_.tets.size());
    for (const Index i : moved_)
      for (const Index t : node_tets_.row(i)) set.insert(position_of_[t]);
    set.drain(places_);
  }
  tets_.clear();
  index_.clear();
  for (const Index k : places_) {
    tets_.push_back(order_.tets[static_cast<std::size_t>(k)]);
    index_.push_back(order_.index[static_cast<std::size_t>(k)]);
  }
  ValidationReport report;
  report.min_quality = std::numeric_limits<double>::quiet_NaN();
  detail::check_tet_shapes(positions, tets_, index_, options_, report);
  last_.checked_tets = places_.size();
  return report;
}

void ShapeCheck::record_bound(const Motion& motion) {
  // Every node that did not move is within its radius of its reference (shifted, and
  // turned when `turned`); those that did are made their own reference (accept_moved()).
  last_.bounded = true;
  last_.shift =
      Eigen::Vector3d(motion.rigid.shift[0], motion.rigid.shift[1], motion.rigid.shift[2]);
  last_.rotated = motion.turned;
  for (int j = 0; j < 3; ++j)
    for (int k = 0; k < 3; ++k) last_.rotation(j, k) = motion.rigid.turn[3 * j + k];
  last_.pivot = Eigen::Vector3d(motion.rigid.turn[9], motion.rigid.turn[10], motion.rigid.turn[11]);
  turning_ = motion.turned;
}

void ShapeCheck::accept_moved(const Positions& positions, const Motion& motion) {
  // The nodes that moved join the reference (moved back by the shift and turned back, like
  // the rest of it), and the radii of their tets and of those tets' nodes are recomputed.
  const double* m = motion.rigid.turn;
  const double* shift = motion.rigid.shift;
  for (const Index i : moved_) {
    const double u[3] = {positions(0, i) - shift[0], positions(1, i) - shift[1],
                         positions(2, i) - shift[2]};
    for (int c = 0; c < 3; ++c)
      reference_(c, i) =
          motion.turned ? (m[c] * u[0] + m[3 + c] * u[1] + m[6 + c] * u[2]) + m[9 + c] : u[c];
    set_block_node(i);
    cover(i);
  }
  compute_radii(
      reference_, order_.tets, quality_, places_.size(),
      [&](std::size_t j) { return static_cast<std::size_t>(places_[j]); }, radius_);
  nodes_.clear();
  {
    detail::SortedIndexSet set(node_bits_, static_cast<std::size_t>(num_nodes_));
    for (const Tet& t : tets_)
      for (const Index v : t) set.insert(v);
    set.drain(nodes_);
  }
  detail::for_chunks(nodes_.size(), kRadiusChunk,
                     [&](std::size_t begin, std::size_t end, std::size_t) {
                       for (std::size_t j = begin; j < end; ++j)
                         radius2_[static_cast<std::size_t>(nodes_[j])] = node_radius2(nodes_[j]);
                     });
  for (const Index k : places_) {
    const double t = radius_[static_cast<std::size_t>(k)];
    if (t > 0.0) rcap2_ = std::max(rcap2_, t * t);
  }
  last_.version_after = ++version_;
}

}  // namespace tc
