// Exact primitive tests of the narrow phase: tet-tet overlap (separating axes),
// point-in-tet with barycentric coordinates, and segment-vs-tet clipping.
//
// Tolerance (docs/DETECTION.md): every test takes an absolute distance tolerance in
// metres. Detection derives it from a relative one, tol = relative_tolerance * scale,
// where scale is the largest bounding-box extent of the primitives involved, so the
// answers do not change with translation (1e6 offsets) or scale (1e-6 objects).
// Touching never counts: two tets overlap only when they penetrate by more than tol.
// Every function is computed in coordinates relative to one corner of the inputs, never
// divides by a quantity that can be zero, and returns no NaN for finite input.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>

#include "core/mesh/tet_mesh.hpp"

namespace tc {

/// The four corners of a tet, in the tet's node order.
using TetCorners = std::array<Eigen::Vector3d, 4>;

/// Default relative tolerance of detection (times the local length scale).
inline constexpr double kDefaultRelativeTolerance = 1e-9;

/// Corners of tet `tet` (node indices into `positions`, 3 x n, metres).
inline TetCorners tet_corners(const Positions& positions, const Tet& tet) {
  return {positions.col(tet[0]), positions.col(tet[1]), positions.col(tet[2]),
          positions.col(tet[3])};
}

/// A tet with the derived geometry the tests below use, computed once per tet and frame
/// so that a tet tested against many others does not redo it.
struct TetGeometry {
  // Ordered by use, so that what a test reads is contiguous: the box (every pre-test);
  // what the face-plane tests read (lengths, normals by coordinate, inverses, corners);
  // the rest of the vectorised overlap test (arcs, edges; the unit normals are formed
  // from n and n_inv where they are used). Vectors are kept by coordinate only (x, y, z
  // apart; index = face k, corner i or edge j): they feed the vector lanes of
  // tets_overlap() and clip_segment_tet(), and the scalar reference functions read them
  // back through normal(), edge() and arc(), so both see the same bits. Nothing is
  // stored twice: a tet's geometry is written every frame by each thread that tests it
  // (detection keeps one copy per thread: a cache line that moves between cores costs
  // 30-320 ns here, docs/BENCHMARKS.md, "Machines").
  Eigen::Vector3d lo, hi;            ///< bounding box, m
  double scale = 0.0;                ///< largest box extent, m
  bool flat = true;                  ///< 6|V| <= 32 eps scale^3 (or non-finite)
  std::array<double, 4> n_len;       ///< |n|, m^2
  std::array<double, 4> nx, ny, nz;  ///< n[k] by coordinate, m^2
  std::array<double, 4> n_inv;       ///< 1 / |n| (0 when |n| = 0), 1/m^2
  TetCorners v;                      ///< corners, metres
  std::array<double, 4> lx, ly, lz;  ///< corners relative to the first: v[i] - v[0], m
  /// n[k] . (v[kTetFaces[k][0]] - v[0]) and n[k] . (v[k] - v[0]): where face k's plane and
  /// the opposite corner project on n[k], in coordinates relative to v[0], m^3.
  std::array<double, 4> plane, apex;
  std::array<double, 8> ax, ay, az;  ///< arc j by coordinate for j < 6; entries 6, 7 are 0
  std::array<double, 6> ex, ey, ez;  ///< edge j, v[b] - v[a] for kTetEdges[j] = (a, b), by
                                     ///< coordinate, m

  /// Face normal k (kTetFaces order, length 2 x area), outward unless flat, m^2.
  [[nodiscard]] Eigen::Vector3d normal(int k) const { return {nx[k], ny[k], nz[k]}; }
  /// Edge j (kTetEdges order), m.
  [[nodiscard]] Eigen::Vector3d edge(int j) const { return {ex[j], ey[j], ez[j]}; }
  /// Gauss-map arc of edge j (kTetEdges order): (unit normal of one adjacent face) x (unit
  /// normal of the other); unused when flat.
  [[nodiscard]] Eigen::Vector3d arc(int j) const { return {ax[j], ay[j], az[j]}; }
};

/// Derived geometry of a tet given by its corners.
TetGeometry make_tet_geometry(const TetCorners& t);
/// The same, written into `g` (every field), so that an array of them is filled in place.
void make_tet_geometry(const TetCorners& t, TetGeometry& g);

/// make_tet_geometry() of 4 tets at once (one per vector lane), written into *out[0..3]
/// (4 distinct TetGeometry anywhere): the same bits in every field as 4 single calls, for a
/// fraction of the instructions.
void make_tet_geometry4(const std::array<TetCorners, 4>& t, const std::array<TetGeometry*, 4>& out);

/// Largest extent of the bounding box of the corners of `a` and `b` (metres): the length
/// scale the tolerance of a tet pair is relative to.
double pair_scale(const TetCorners& a, const TetCorners& b);
inline double pair_scale(const TetGeometry& a, const TetGeometry& b) {
  return (a.hi.cwiseMax(b.hi) - a.lo.cwiseMin(b.lo)).maxCoeff();
}

/// Largest extent of the bounding box of a tet's corners (metres).
double tet_scale(const TetCorners& t);

/// Penetration depth of two tets measured by separating axes, metres.
///
/// For every candidate axis u (3 coordinate axes, 4 + 4 face normals, 36 edge-edge cross
/// products, plus fallbacks for parallel or zero-length edges and the centroid direction)
/// it takes the distance by which one tet must move along u to clear the other,
/// min(max_a - min_b, max_b - min_a) / |u|, and returns the minimum over the axes. For
/// non-degenerate tets this is the exact penetration depth (the Minkowski difference
/// has no other face normals); it is <= 0 when the tets are disjoint or touch.
double sat_penetration(const TetCorners& a, const TetCorners& b);

/// True when the tets penetrate by more than `tolerance` (metres, >= 0): the same as
/// sat_penetration(a, b) > tolerance, with early exits (a separating axis, or a corner of
/// one tet deeper than `tolerance` inside the other). Shared faces, coplanar faces on
/// opposite sides, and touching vertices or edges are not overlaps. A zero-volume tet
/// lying inside the other one is an overlap (it has to move to get out).
///
/// Computed 4 axes at a time (face normals, Gauss-map arc tests, corner projections),
/// with the same floating-point operations per axis as tets_overlap_reference(), so the
/// answer is that function's bit for bit; pairs with a flat tet go to the reference.
bool tets_overlap(const TetGeometry& a, const TetGeometry& b, double tolerance);
bool tets_overlap(const TetCorners& a, const TetCorners& b, double tolerance);

/// One candidate pair of tets_overlap_pairs(): the geometry of its two tets.
struct GeometryPair {
  const TetGeometry* a = nullptr;
  const TetGeometry* b = nullptr;
};

/// out[i] = tets_overlap(*pairs[i].a, *pairs[i].b, relative_tolerance * pair_scale(*pairs[i].a,
/// *pairs[i].b)) for every i (out.size() >= pairs.size()), bit for bit: the narrow phase's loop
/// over a run of candidate pairs in one call, with the test inline (no call, no register saves
/// per pair) and the geometry of B's tets asked for a few pairs ahead. Pairs go in blocks of
/// 32: the coordinate and face axes of each pair of the block first, without a branch on what
/// they find, then the edge axes, 4 at a time, of the pairs those left open.
void tets_overlap_pairs(std::span<const GeometryPair> pairs, double relative_tolerance,
                        std::span<bool> out);

/// A certificate of tets_overlap()'s answer for a pair of tets, found when the pair is
/// tested in full and checked again on the pair's geometry of a later frame for a fraction
/// of the test (docs/DETECTION.md, "Overlap hints"). Codes: 1 + k, face k of the first tet
/// is an axis along which the tets lie more than the tolerance apart; 5 + k, face k of the
/// second; 9 + 6 i + j, edge i of the first x edge j of the second; 45 + i, corner i of the
/// second tet lies deeper than twice the tolerance inside the first; 49 + i, corner i of
/// the first inside the second; 53 + g and 84 + g, point g of the second's (the first's)
/// grid of step 1/4 in barycentric weights, corners left out, inside the other likewise.
using OverlapHint = std::uint8_t;
/// Not looked for yet.
inline constexpr OverlapHint kOverlapHintUnknown = 0;
/// Looked for and none found (the pair lies within the margins): test in full.
inline constexpr OverlapHint kOverlapHintNone = 255;

/// What hint `hint` says about tets a and b now: 1 (overlap) or 0 (apart), either of which
/// is tets_overlap(a, b, relative_tolerance * pair_scale(a, b))'s answer (the narrow
/// phase's tolerance, tets_overlap_pairs()); -1 when the hint no longer holds (or is none,
/// or a tet is flat): test in full. Exact by margin: an axis must show a gap of more than
/// the tolerance (tets_overlap() separates at a gap above minus the tolerance), a point a
/// depth of more than twice it (it accepts above once), so rounding, some 10^-15 of the
/// scale where the tolerance is 10^-9 of it, cannot make the two disagree (a relative
/// tolerance below 10^-12 gets -1).
int check_overlap_hint(const TetGeometry& a, const TetGeometry& b, double relative_tolerance,
                       OverlapHint hint);

/// A hint for tets a and b, which tets_overlap() answered `overlap` at the tolerance
/// relative_tolerance * pair_scale(a, b): for an overlap a deep corner, else a deep grid
/// point; for tets apart a face axis, else an edge axis, with the margin
/// check_overlap_hint() asks for; kOverlapHintNone when there is none (or a tet is flat, or
/// the relative tolerance is below 10^-12).
OverlapHint find_overlap_hint(const TetGeometry& a, const TetGeometry& b, double relative_tolerance,
                              bool overlap);

/// The scalar separating-axis walk tets_overlap() reproduces (one axis at a time, in the
/// order documented there); kept for flat tets and as the reference in tests.
bool tets_overlap_reference(const TetGeometry& a, const TetGeometry& b, double tolerance);

/// Result of point_in_tet().
struct PointInTet {
  bool inside = false;
  /// Barycentric coordinates (weights of the tet's 4 corners, summing to 1); only set
  /// when inside. Each is >= -tolerance / (height of that corner over its opposite face).
  Eigen::Vector4d bary = Eigen::Vector4d::Zero();
};

/// Closed point-in-tet test: p is inside when its distance outside each face plane is at
/// most `tolerance` (metres). A point on a face shared by two tets is inside both. Flat
/// tets (TetGeometry::flat) contain no point. Works for either orientation of the tet.
PointInTet point_in_tet(const Eigen::Vector3d& p, const TetGeometry& t, double tolerance);
PointInTet point_in_tet(const Eigen::Vector3d& p, const TetCorners& t, double tolerance);

/// Result of clip_segment_tet().
struct SegmentClip {
  bool hit = false;
  /// The part of the segment inside the tet is x = p0 + lambda (p1 - p0) for lambda in
  /// [lambda_in, lambda_out], 0 <= lambda_in < lambda_out <= 1; only set on a hit.
  double lambda_in = 0.0;
  double lambda_out = 0.0;
};

/// Cyrus-Beck clipping of the segment [p0, p1] against the 4 face planes of the tet.
/// Endpoint distances within `tolerance` (metres) of a plane count as on it, so a segment
/// lying in a face is inside. A hit needs an inside part longer than `tolerance`:
/// segments that only touch a corner or an edge of the tet do not hit. Zero-length
/// segments and flat tets never hit.
SegmentClip clip_segment_tet(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                             const TetGeometry& t, double tolerance);
SegmentClip clip_segment_tet(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                             const TetCorners& t, double tolerance);

/// One tet of clip_segment_tets(): its geometry and the tolerance to clip with (metres).
struct ClipTarget {
  const TetGeometry* tet = nullptr;
  double tolerance = 0.0;
};

/// out[i] = clip_segment_tet(p0, p1, *targets[i].tet, targets[i].tolerance) for every i
/// (out.size() >= targets.size()), bit for bit: one call for the several tets a segment
/// is clipped against (the intrusion scans clip each edge against ~5), which sets the
/// segment up once and keeps the per-tet work inline instead of a call per tet.
void clip_segment_tets(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                       std::span<const ClipTarget> targets, std::span<SegmentClip> out);

/// clip_segment_tet() one face after the other (the 4 faces are lanes of one vector in
/// clip_segment_tet(), with the same result bit for bit); the reference in tests.
SegmentClip clip_segment_tet_reference(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                                       const TetGeometry& t, double tolerance);

}  // namespace tc
