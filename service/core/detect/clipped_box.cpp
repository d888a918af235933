// clipped_tet_box() and clipped_tet_boxes4() (declared in broad_phase.hpp): the box of the
// part of a tet inside the two objects' overlap box, one tet or 4 at once in vector lanes.
// Its own file, built with -ffp-contract=off: the lanes reproduce the scalar function's
// bits whatever -march is given, and the rest of the broad phase keeps its own code
// generation (the tree query is sensitive to what else its file holds).
#include <array>
#include <limits>

#include "core/common/cpu_dispatch.hpp"
#include "core/common/target_clones.hpp"
#include "core/detect/broad_phase.hpp"
#include "core/detect/lanes.hpp"
#include "core/mesh/geometry.hpp"

namespace tc {

using Eigen::Vector3d;

namespace {

/// The last step of clipped_tet_box(): a non-empty box padded by `pad` and cut to the
/// region padded the same; an empty box as it is.
TC_INLINE Aabb padded_in_region(Aabb box, const Aabb& region, double pad) {
  if (box.empty()) return box;
  box.lo.array() -= pad;
  box.hi.array() += pad;
  return box.intersection(Aabb{region.lo.array() - pad, region.hi.array() + pad});
}

}  // namespace

Aabb clipped_tet_box(const TetCorners& t, const Aabb& region, int axis, double pad) {
  Aabb box;
  const double lo = region.lo[axis], hi = region.hi[axis];
  for (const Vector3d& p : t)
    if (p[axis] >= lo && p[axis] <= hi) box.extend(p);
  for (const auto& e : kTetEdges) {
    const Vector3d& p = t[e[0]];
    const Vector3d& q = t[e[1]];
    for (const double plane : {lo, hi}) {
      const double dp = p[axis] - plane, dq = q[axis] - plane;
      if ((dp < 0.0) == (dq < 0.0) || dp == dq) continue;  // no crossing (or NaN)
      Vector3d x = p + (dp / (dp - dq)) * (q - p);
      x[axis] = plane;
      box.extend(x);
    }
  }
  return padded_in_region(box, region, pad);
}

namespace {

// clipped_tet_box() of 4 tets, one per lane, each lane with its operations in its order:
// the corners in the slab, then each edge's crossing of the low and the high plane, each
// taken into the box by Aabb::extend's cwiseMin/cwiseMax (vmin/vmax, same operand order:
// a NaN coordinate is dropped the same way), the crossing point as Eigen forms p + r (q -
// p) per coordinate, then the pad and the padded region. Kept apart from the
// multiversioned entry point (clang rejects a 4-double vector passed from its baseline
// copy).
TC_INLINE void clipped_box_lanes(const std::array<TetCorners, 4>& t, const Aabb& region, int axis,
                                 const std::array<double, 4>& pad, std::array<Aabb, 4>& out) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  V4 p[4][3];  // corner i, coordinate c; lane j = tet j
#pragma GCC unroll 12
  for (int i = 0; i < 4; ++i)
#pragma GCC unroll 12
    for (int c = 0; c < 3; ++c) p[i][c] = V4{t[0][i][c], t[1][i][c], t[2][i][c], t[3][i][c]};
  const double lo = region.lo[axis], hi = region.hi[axis];
  V4 blo[3], bhi[3];
#pragma GCC unroll 12
  for (int c = 0; c < 3; ++c) blo[c] = splat(kInf), bhi[c] = splat(-kInf);
#pragma GCC unroll 12
  for (int i = 0; i < 4; ++i) {
    const M4 in = (p[i][axis] >= splat(lo)) & (p[i][axis] <= splat(hi));
#pragma GCC unroll 12
    for (int c = 0; c < 3; ++c) {
      blo[c] = in ? vmin(blo[c], p[i][c]) : blo[c];
      bhi[c] = in ? vmax(bhi[c], p[i][c]) : bhi[c];
    }
  }
  const V4 zero = splat(0.0);
#pragma GCC unroll 12
  for (const auto& e : kTetEdges) {
    const V4(&a)[3] = p[e[0]];
    const V4(&b)[3] = p[e[1]];
#pragma GCC unroll 12
    for (const double plane : {lo, hi}) {
      const V4 dp = a[axis] - splat(plane), dq = b[axis] - splat(plane);
      // Crossing: !((dp < 0) == (dq < 0) || dp == dq).
      const M4 cross = ~(((dp < zero) == (dq < zero)) | (dp == dq));
      if (lanes(cross) == 0) continue;
      const V4 r = dp / (dp - dq);
#pragma GCC unroll 12
      for (int c = 0; c < 3; ++c) {
        const V4 x = c == axis ? splat(plane) : a[c] + r * (b[c] - a[c]);
        blo[c] = cross ? vmin(blo[c], x) : blo[c];
        bhi[c] = cross ? vmax(bhi[c], x) : bhi[c];
      }
    }
  }
#pragma GCC unroll 12
  for (int j = 0; j < 4; ++j)
    out[j] = padded_in_region(
        {Vector3d(blo[0][j], blo[1][j], blo[2][j]), Vector3d(bhi[0][j], bhi[1][j], bhi[2][j])},
        region, pad[j]);
}

/// clipped_box_lanes() built for AVX2.
TC_AVX2_TARGET void clipped_boxes_avx2(const std::array<TetCorners, 4>& t, const Aabb& region,
                                       int axis, const std::array<double, 4>& pad,
                                       std::array<Aabb, 4>& out) {
  clipped_box_lanes(t, region, axis, pad, out);
}

}  // namespace

void clipped_tet_boxes4(const std::array<TetCorners, 4>& t, const Aabb& region, int axis,
                        const std::array<double, 4>& pad, std::array<Aabb, 4>& out) {
  if (use_avx2_kernels()) return clipped_boxes_avx2(t, region, axis, pad, out);
  clipped_box_lanes(t, region, axis, pad, out);
}

}  // namespace tc
