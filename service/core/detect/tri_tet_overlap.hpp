// Exact triangle-tet overlap (separating axes), for surface objects against tet objects
// (paper Fig. 14; docs/DETECTION.md, "Triangle-tet overlap").
//
// The conventions are those of tets_overlap() (tet_overlap.hpp): a tolerance in metres
// that detection derives from a relative one times the pair's length scale; touching is
// not overlapping (a triangle lying in a face of the tet, or meeting it in a corner or
// along an edge, does not overlap it); coordinates relative to the tet's first corner;
// no division by a quantity that can be zero; no NaN for finite input; built without
// fused multiply-add, so the bits do not depend on -march.
#pragma once

#include <Eigen/Core>
#include <array>

#include "core/detect/tet_overlap.hpp"

namespace tc {

/// The three corners of a triangle, metres.
using TriangleCorners = std::array<Eigen::Vector3d, 3>;

/// Largest extent of the bounding box of the corners of `t` and `k` (metres): the length
/// scale the tolerance of a triangle-tet pair is relative to.
double pair_scale(const TriangleCorners& t, const TetCorners& k);

/// Penetration depth of a triangle and a tet measured by separating axes, metres: the
/// smallest distance the triangle must move, along any direction, to clear the tet.
///
/// Axes: the 3 coordinate axes, the tet's 4 face normals, the triangle's normal and the
/// 18 cross products of a triangle edge with a tet edge: the normals of every facet of
/// the Minkowski difference when both are non-degenerate, so the minimum over them is the
/// exact penetration depth. When the triangle is degenerate (|n| <= 32 eps L^2) or the
/// tet flat, it also tests, from each corner of one to each edge line of the other, the
/// perpendicular direction, the corner-to-corner directions, and two directions
/// perpendicular to each edge: a set that separates any disjoint pair of points,
/// segments, triangles and polygons, and gives 0 for coplanar and collinear contacts.
/// Every axis only ever over-estimates the depth, so extra axes never make it wrong.
/// <= 0 when disjoint or touching (its negative values are not distances).
double triangle_tet_penetration(const TriangleCorners& t, const TetCorners& k);

/// True when the triangle and the tet penetrate by more than `tolerance` (metres, >= 0):
/// triangle_tet_penetration(t, k) > tolerance, with early exits (a separating axis, or
/// a triangle corner deeper than `tolerance` inside the tet). A triangle inside the tet,
/// or crossing it, overlaps; one lying in a face of the tet or touching it does not.
/// `k` is the tet's make_tet_geometry(); a tet with a non-finite corner (or a triangle
/// with one) overlaps nothing.
bool triangle_tet_overlap(const TriangleCorners& t, const TetGeometry& k, double tolerance);
bool triangle_tet_overlap(const TriangleCorners& t, const TetCorners& k, double tolerance);

}  // namespace tc
