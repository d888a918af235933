// CGAL's answer to "which tets of A overlap which tets of B" (issue 46, item 5): the boxes of
// every tet of both objects through CGAL::box_intersection_d (closed boxes, bipartite), then
// CGAL::do_intersect on each candidate pair of Tetrahedron_3 in the kernel K.
//
// With CGAL::Exact_predicates_inexact_constructions_kernel the test is exact: CGAL 5.5's
// Tetrahedron_3/Tetrahedron_3 do_intersect (Intersections_3/internal/
// Tetrahedron_3_Bounded_3_do_intersect.h) makes no new point, it only evaluates orientation
// and bounded-side predicates on the input corners (triangle-triangle tests of the faces and a
// corner-in-tet test), and those are filtered and exact. The tets are closed sets: two tets
// that only touch intersect for CGAL, while for tetcollide they overlap only when they
// penetrate by more than the tolerance (DetectOptions::relative_tolerance, 1e-9 of the pair's
// size; core/detect/tet_overlap.hpp).
#pragma once

#include <CGAL/Bbox_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Intersections_3/Tetrahedron_3_Tetrahedron_3.h>
#include <CGAL/box_intersection_d.h>

#include <algorithm>
#include <cstddef>
#include <span>
#include <vector>

#include "core/detect/contacts.hpp"
#include "core/mesh/tet_mesh.hpp"

namespace tc::peers {

/// A tet's box for box_intersection_d; ids: tets of A 0..m_a-1, tets of B m_a + tet.
struct CgalTetBox {
  using NT = double;
  using ID = std::size_t;
  CGAL::Bbox_3 box;
  std::size_t index = 0;
  static int dimension() { return 3; }
  [[nodiscard]] double min_coord(int d) const { return box.min(d); }
  [[nodiscard]] double max_coord(int d) const { return box.max(d); }
  [[nodiscard]] std::size_t id() const { return index; }
};

struct CgalResult {
  std::size_t candidates = 0;        ///< pairs of tets whose boxes intersect
  std::vector<TetPair> overlapping;  ///< sorted by (tet_a, tet_b)
};

/// The overlapping tet pairs of A and B by CGAL, kernel K (Epick by default: exact here).
template <class K = CGAL::Exact_predicates_inexact_constructions_kernel>
CgalResult cgal_overlapping(const Positions& pa, std::span<const Tet> ta, const Positions& pb,
                            std::span<const Tet> tb) {
  using Point = typename K::Point_3;
  using Tetrahedron = typename K::Tetrahedron_3;
  const auto tetrahedra = [](const Positions& x, std::span<const Tet> tets,
                             std::vector<Tetrahedron>& out, std::vector<CgalTetBox>& boxes,
                             std::size_t first_id) {
    out.clear();
    boxes.clear();
    out.reserve(tets.size());
    boxes.reserve(tets.size());
    for (std::size_t t = 0; t < tets.size(); ++t) {
      std::array<Point, 4> p;
      for (int k = 0; k < 4; ++k) {
        const auto c = x.col(tets[t][static_cast<std::size_t>(k)]);
        p[static_cast<std::size_t>(k)] = Point(c.x(), c.y(), c.z());
      }
      out.emplace_back(p[0], p[1], p[2], p[3]);
      boxes.push_back({out.back().bbox(), first_id + t});
    }
  };
  std::vector<Tetrahedron> tets_a, tets_b;
  std::vector<CgalTetBox> boxes_a, boxes_b;
  tetrahedra(pa, ta, tets_a, boxes_a, 0);
  tetrahedra(pb, tb, tets_b, boxes_b, ta.size());
  CgalResult r;
  const std::size_t m_a = ta.size();
  CGAL::box_intersection_d(
      boxes_a.begin(), boxes_a.end(), boxes_b.begin(), boxes_b.end(),
      [&](const CgalTetBox& x, const CgalTetBox& y) {
        // Bipartite: one box of each sequence; which argument is which is not assumed.
        const std::size_t ia = x.index < m_a ? x.index : y.index;
        const std::size_t ib = (x.index < m_a ? y.index : x.index) - m_a;
        ++r.candidates;
        if (CGAL::do_intersect(tets_a[ia], tets_b[ib]))
          r.overlapping.push_back({static_cast<Index>(ia), static_cast<Index>(ib)});
      });
  std::sort(r.overlapping.begin(), r.overlapping.end());
  return r;
}

/// The pairs of `x` that are not in `y` (both sorted).
inline std::vector<TetPair> pairs_missing(std::span<const TetPair> x, std::span<const TetPair> y) {
  std::vector<TetPair> out;
  std::set_difference(x.begin(), x.end(), y.begin(), y.end(), std::back_inserter(out));
  return out;
}

}  // namespace tc::peers
