#include "core/detect/self_detect.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <utility>

#include "core/common/chunked.hpp"
#include "core/detect/edge_hits.hpp"
#include "core/mesh/geometry.hpp"

namespace tc {
namespace {

using Vec3 = Eigen::Vector3d;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// Leaves of the surface BVH hold at most this many triangles.
constexpr Index kLeafFaces = 4;
/// A patch whose normals lie within this half-angle of one axis (and that is connected)
/// is not tested against itself (below 90 degrees it cannot fold onto itself).
/// A patch is culled only when its certificate (how far its corners may move before its
/// cone could reach 90 degrees, SelfCollider::detect) is at least a fifth of near_gap_:
/// one just under the limit is looked into instead, and its smaller parts give more.
constexpr double kCullCone = 85.0 * std::numbers::pi / 180.0;
/// Chunk sizes of the parallel loops (fixed: the output does not depend on the threads).
constexpr std::size_t kFaceChunk = 2048;
constexpr std::size_t kTetChunk = 256;
constexpr std::size_t kFeatureChunk = 128;

double orient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).dot((c - a).cross(d - a));
}

/// 2D: the segment [p, q] meets triangle abc (closed, within eps of the cross products).
bool segment_meets_triangle_2d(const Eigen::Vector2d& p, const Eigen::Vector2d& q,
                               const std::array<Eigen::Vector2d, 3>& t, double eps) {
  const auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& u,
                        const Eigen::Vector2d& v) {
    return (u - o).x() * (v - o).y() - (u - o).y() * (v - o).x();
  };
  const double area = cross(t[0], t[1], t[2]);
  const double s = area >= 0.0 ? 1.0 : -1.0;
  const auto inside = [&](const Eigen::Vector2d& r) {
    return s * cross(t[0], t[1], r) >= -eps && s * cross(t[1], t[2], r) >= -eps &&
           s * cross(t[2], t[0], r) >= -eps;
  };
  if (inside(p) || inside(q)) return true;
  for (int k = 0; k < 3; ++k) {  // the segment crosses an edge of the triangle
    const Eigen::Vector2d& a = t[static_cast<std::size_t>(k)];
    const Eigen::Vector2d& b = t[static_cast<std::size_t>((k + 1) % 3)];
    const double d1 = cross(a, b, p), d2 = cross(a, b, q);
    const double d3 = cross(p, q, a), d4 = cross(p, q, b);
    if (((d1 >= -eps && d2 <= eps) || (d1 <= eps && d2 >= -eps)) &&
        ((d3 >= -eps && d4 <= eps) || (d3 <= eps && d4 >= -eps)))
      return true;
  }
  return false;
}

/// The segment [p, q] meets triangle abc, closed: touching within `eps` (6 x volumes,
/// m^3) counts. Coplanar input is decided in the plane (eps2, m^2).
bool segment_meets_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b,
                            const Vec3& c, double eps, double eps2) {
  const double sp = orient(a, b, c, p), sq = orient(a, b, c, q);
  if ((sp > eps && sq > eps) || (sp < -eps && sq < -eps)) return false;
  if (std::abs(sp) <= eps && std::abs(sq) <= eps) {  // in the plane: drop the normal's axis
    Eigen::Index axis = 0;
    (b - a).cross(c - a).cwiseAbs().maxCoeff(&axis);
    const int u = axis == 0 ? 1 : 0, v = axis == 2 ? 1 : 2;
    const auto flat = [&](const Vec3& r) { return Eigen::Vector2d(r[u], r[v]); };
    return segment_meets_triangle_2d(flat(p), flat(q), {flat(a), flat(b), flat(c)}, eps2);
  }
  const double s1 = orient(p, q, a, b), s2 = orient(p, q, b, c), s3 = orient(p, q, c, a);
  const bool neg = s1 < -eps || s2 < -eps || s3 < -eps;
  const bool pos = s1 > eps || s2 > eps || s3 > eps;
  return !(neg && pos);
}

/// Two triangles meet (closed, within the relative tolerance of their common box):
/// an edge of one meets the other. Computed relative to the first corner.
bool triangles_meet(const std::array<Vec3, 3>& s, const std::array<Vec3, 3>& t, double rel) {
  const Vec3 o = s[0];
  std::array<Vec3, 3> a, b;
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = -lo;
  for (int k = 0; k < 3; ++k) {
    a[static_cast<std::size_t>(k)] = s[static_cast<std::size_t>(k)] - o;
    b[static_cast<std::size_t>(k)] = t[static_cast<std::size_t>(k)] - o;
    lo = lo.cwiseMin(a[static_cast<std::size_t>(k)]).cwiseMin(b[static_cast<std::size_t>(k)]);
    hi = hi.cwiseMax(a[static_cast<std::size_t>(k)]).cwiseMax(b[static_cast<std::size_t>(k)]);
  }
  const double scale = (hi - lo).maxCoeff();
  // At least a few ulps of the products, so that exact contact is never lost to rounding.
  const double r = std::max(rel, 64.0 * std::numeric_limits<double>::epsilon());
  const double eps = r * scale * scale * scale, eps2 = r * scale * scale;
  // Most pairs: one triangle wholly on one side of the other's plane.
  const auto apart = [&](const std::array<Vec3, 3>& p, const std::array<Vec3, 3>& q) {
    const double d0 = orient(p[0], p[1], p[2], q[0]), d1 = orient(p[0], p[1], p[2], q[1]),
                 d2 = orient(p[0], p[1], p[2], q[2]);
    return (d0 > eps && d1 > eps && d2 > eps) || (d0 < -eps && d1 < -eps && d2 < -eps);
  };
  if (apart(a, b) || apart(b, a)) return false;
  for (int k = 0; k < 3; ++k) {
    const auto i = static_cast<std::size_t>(k), j = static_cast<std::size_t>((k + 1) % 3);
    if (segment_meets_triangle(a[i], a[j], b[0], b[1], b[2], eps, eps2)) return true;
    if (segment_meets_triangle(b[i], b[j], a[0], a[1], a[2], eps, eps2)) return true;
  }
  return false;
}

bool share_node(const std::array<Index, 3>& f, const std::array<Index, 3>& g) {
  for (const Index u : f)
    for (const Index v : g)
      if (u == v) return true;
  return false;
}

bool share_node(const Tet& s, const Tet& t) {
  for (const Index u : s)
    for (const Index v : t)
      if (u == v) return true;
  return false;
}

/// The box [slo, shi] meets [lo - tol, hi + tol] (the intrusion scans' box test).
bool meets_padded_box(const Vec3& slo, const Vec3& shi, const Vec3& lo, const Vec3& hi,
                      double tol) {
  return (slo.array() <= hi.array() + tol).all() && (shi.array() >= lo.array() - tol).all();
}

/// The largest gap between two boxes along an axis (> 0 when they are apart), metres.
double box_gap(const Aabb& a, const Aabb& b) {
  return std::max(0.0, ((a.lo - b.hi).cwiseMax(b.lo - a.hi)).maxCoeff());
}

/// A lower bound of the distance between two triangles: the largest gap between their
/// projections on the separating axes of two triangles (both normals, the 9 edge-edge
/// cross products, and each normal crossed with its triangle's edges for coplanar ones), 0
/// when none separates. A plane of one triangle that keeps the other `enough` away ends
/// the search there.
double separation(const std::array<Vec3, 3>& s, const std::array<Vec3, 3>& t, double enough) {
  const Vec3 o = s[0];
  std::array<Vec3, 3> a, b;
  for (std::size_t k = 0; k < 3; ++k) {
    a[k] = s[k] - o;
    b[k] = t[k] - o;
  }
  double best = 0.0;
  const auto axis = [&](const Vec3& u) {
    const double len = u.norm();
    if (!(len > 0.0) || !std::isfinite(len)) return;
    double lo_a = std::numeric_limits<double>::infinity(), hi_a = -lo_a, lo_b = lo_a, hi_b = -lo_a;
    for (std::size_t k = 0; k < 3; ++k) {
      const double pa = a[k].dot(u), pb = b[k].dot(u);
      lo_a = std::min(lo_a, pa);
      hi_a = std::max(hi_a, pa);
      lo_b = std::min(lo_b, pb);
      hi_b = std::max(hi_b, pb);
    }
    best = std::max(best, std::max(lo_b - hi_a, lo_a - hi_b) / len);
  };
  const Vec3 na = (a[1] - a[0]).cross(a[2] - a[0]);
  const Vec3 nb = (b[1] - b[0]).cross(b[2] - b[0]);
  axis(na);
  axis(nb);
  if (best >= enough) return best;       // a plane keeps them apart by enough
  for (std::size_t i = 0; i < 3; ++i) {  // in-plane axes: what separates coplanar triangles
    axis(na.cross(a[(i + 1) % 3] - a[i]));
    axis(nb.cross(b[(i + 1) % 3] - b[i]));
  }
  for (std::size_t i = 0; i < 3; ++i)
    for (std::size_t j = 0; j < 3; ++j) axis((a[(i + 1) % 3] - a[i]).cross(b[(j + 1) % 3] - b[j]));
  return best;
}

/// Smallest cone holding two cones (unit axes, half-angles in radians); a half-angle of
/// pi or more means "no cone".
std::pair<Vec3, double> merge_cones(const Vec3& a1, double t1, const Vec3& a2, double t2) {
  constexpr double kNone = std::numbers::pi;
  if (t1 >= kNone || t2 >= kNone) return {a1, kNone};
  const double phi = std::acos(std::clamp(a1.dot(a2), -1.0, 1.0));
  if (phi + t2 <= t1) return {a1, t1};
  if (phi + t1 <= t2) return {a2, t2};
  const double t = 0.5 * (phi + t1 + t2);
  if (t >= kNone) return {a1, kNone};
  const double sin_phi = std::sin(phi);
  if (!(sin_phi > 1e-12)) return {a1, std::max(t1, t2)};
  const double turn = t - t1;  // rotate a1 towards a2 by this much
  const Vec3 axis = (std::sin(phi - turn) * a1 + std::sin(turn) * a2) / sin_phi;
  const double norm = axis.norm();
  if (!(norm > 0.0) || !std::isfinite(norm)) return {a1, kNone};
  return {axis / norm, t};
}

/// One direction of a part: the tets of X in its overlaps (sorted) and, per such tet, the
/// tets of Y it overlaps (sorted).
struct Rows {
  std::vector<Index> tets;
  std::vector<Index> offsets;
  std::vector<Index> items;
  /// Builds from (x tet, y tet) pairs, sorted and unique.
  void build(std::vector<std::pair<Index, Index>>& pairs) {
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    tets.clear();
    offsets.assign(1, 0);
    items.clear();
    for (const auto& [x, y] : pairs) {
      if (tets.empty() || tets.back() != x) {
        if (!tets.empty()) offsets.push_back(static_cast<Index>(items.size()));
        tets.push_back(x);
      }
      items.push_back(y);
    }
    if (!tets.empty()) offsets.push_back(static_cast<Index>(items.size()));
  }
  [[nodiscard]] std::span<const Index> row_of(Index t) const {
    const auto it = std::lower_bound(tets.begin(), tets.end(), t);
    if (it == tets.end() || *it != t) return {};
    const auto r = static_cast<std::size_t>(it - tets.begin());
    return {items.data() + offsets[r], static_cast<std::size_t>(offsets[r + 1] - offsets[r])};
  }
};

}  // namespace

struct SelfCollider::SurfaceNode {
  Aabb box;
  Vec3 axis = Vec3::UnitZ();       ///< normal cone axis (unit)
  double cone = std::numbers::pi;  ///< normal cone half-angle, radians (pi: none)
  Index begin = 0, end = 0;        ///< its faces: items_[begin, end)
  Index right = -1;                ///< right child; -1 for a leaf
  bool connected = false;          ///< its faces form one patch (through corners)
  /// min over its faces of |e1 x e2| / (16 L) (L the longest edge): a corner displacement
  /// of at most this times sin(a) turns no face normal by more than a.
  double reach = 0.0;
  [[nodiscard]] bool leaf() const { return right < 0; }
};

SelfCollider::SelfCollider(std::span<const Tet> tets, const Topology& topology,
                           const Positions& rest)
    : tets_(tets), topology_(topology) {
  // Tet edges: ids into topology.edges (sorted (a, b), a < b).
  tet_edges_.resize(tets.size());
  std::vector<std::pair<Index, Index>> edge_tet;
  edge_tet.reserve(tets.size() * 6);
  for (std::size_t t = 0; t < tets.size(); ++t) {
    for (std::size_t j = 0; j < kTetEdges.size(); ++j) {
      Index a = tets[t][static_cast<std::size_t>(kTetEdges[j][0])];
      Index b = tets[t][static_cast<std::size_t>(kTetEdges[j][1])];
      if (a > b) std::swap(a, b);
      const std::array<Index, 2> key{a, b};
      const auto it = std::lower_bound(topology.edges.begin(), topology.edges.end(), key);
      const auto id = static_cast<Index>(it - topology.edges.begin());
      tet_edges_[t][j] = id;
      edge_tet.emplace_back(id, static_cast<Index>(t));
    }
  }
  edge_tets_ = csr_from_pairs(static_cast<Index>(topology.edges.size()), edge_tet);
  build_surface_tree(rest);
  double sum = 0.0;
  for (const auto& tri : topology.boundary_faces)
    for (int k = 0; k < 3; ++k)
      sum += (rest.col(tri[static_cast<std::size_t>(k)]) -
              rest.col(tri[static_cast<std::size_t>((k + 1) % 3)]))
                 .norm();
  const auto edges = 3 * topology.boundary_faces.size();
  near_gap_ = edges > 0 ? 0.05 * sum / static_cast<double>(edges) : 0.0;
}

SelfCollider::~SelfCollider() = default;

void SelfCollider::build_surface_tree(const Positions& rest) {
  const auto& faces = topology_.boundary_faces;
  const auto k = static_cast<Index>(faces.size());
  items_.resize(faces.size());
  for (Index f = 0; f < k; ++f) items_[static_cast<std::size_t>(f)] = f;
  nodes_.clear();
  if (k == 0) return;
  std::vector<Vec3> centre(faces.size()), normal(faces.size());
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const Vec3 a = rest.col(faces[f][0]), b = rest.col(faces[f][1]), c = rest.col(faces[f][2]);
    centre[f] = (a + b + c) / 3.0;
    const Vec3 n = (b - a).cross(c - a);
    normal[f] = n.norm() > 0.0 ? Vec3(n.normalized()) : Vec3::Zero();
  }
  // Recursive median split on the longest axis of the centres' box, pre-order.
  struct Todo {
    Index begin, end, parent;
  };
  nodes_.reserve(static_cast<std::size_t>(2 * (k / kLeafFaces + 1)));
  const auto build = [&](const auto& self, Index begin, Index end) -> Index {
    const auto id = static_cast<Index>(nodes_.size());
    nodes_.emplace_back();
    nodes_.back().begin = begin;
    nodes_.back().end = end;
    if (end - begin <= kLeafFaces) return id;
    // Faces facing apart (the two sides of a thin sheet, opposite faces of a box) are split
    // by their normals first: each side is then a patch the cones cull, and two sides a
    // box gap apart. Else the median of the centres along the box's longest axis.
    Aabb box, normals;
    for (Index i = begin; i < end; ++i) {
      box.extend(centre[static_cast<std::size_t>(items_[i])]);
      normals.extend(normal[static_cast<std::size_t>(items_[i])]);
    }
    Eigen::Index axis = 0, turn = 0;
    (box.hi - box.lo).maxCoeff(&axis);
    Index mid = begin;
    if ((normals.hi - normals.lo).maxCoeff(&turn) > 1.0) {  // at the middle of the range:
      const double half = 0.5 * (normals.lo[turn] + normals.hi[turn]);  // groups, not a median
      mid = static_cast<Index>(
          std::stable_partition(
              items_.begin() + begin, items_.begin() + end,
              [&](Index f) { return normal[static_cast<std::size_t>(f)][turn] < half; }) -
          items_.begin());
    }
    if (mid == begin || mid == end) {
      mid = begin + (end - begin) / 2;
      std::nth_element(items_.begin() + begin, items_.begin() + mid, items_.begin() + end,
                       [&](Index u, Index v) {
                         const double cu = centre[static_cast<std::size_t>(u)][axis];
                         const double cv = centre[static_cast<std::size_t>(v)][axis];
                         return cu < cv || (cu == cv && u < v);
                       });
    }
    self(self, begin, mid);
    const Index right = self(self, mid, end);
    nodes_[static_cast<std::size_t>(id)].right = right;
    return id;
  };
  build(build, 0, k);
  // Which nodes hold one connected patch (faces connected through shared corners): a
  // flood over the faces around each corner that stays in the node's range.
  const Csr& around = topology_.node_boundary_faces;
  std::vector<Index> position(faces.size());
  for (Index i = 0; i < k; ++i) position[static_cast<std::size_t>(items_[i])] = i;
  std::vector<std::uint32_t> seen(faces.size(), 0);
  std::uint32_t stamp = 0;
  std::vector<Index> queue;
  for (SurfaceNode& node : nodes_) {
    ++stamp;
    queue.assign(1, items_[node.begin]);
    seen[static_cast<std::size_t>(items_[node.begin])] = stamp;
    for (std::size_t q = 0; q < queue.size(); ++q)
      for (const Index v : faces[static_cast<std::size_t>(queue[q])])
        for (const Index g : around.row(v)) {
          const Index at = position[static_cast<std::size_t>(g)];
          if (at < node.begin || at >= node.end || seen[static_cast<std::size_t>(g)] == stamp)
            continue;
          seen[static_cast<std::size_t>(g)] = stamp;
          queue.push_back(g);
        }
    node.connected = static_cast<Index>(queue.size()) == node.end - node.begin;
  }
  // Borders.
  std::vector<std::pair<Index, Index>> border;  // (tree node, corner)
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const SurfaceNode& node = nodes_[i];
    for (Index j = node.begin; j < node.end; ++j)
      for (const Index v : faces[static_cast<std::size_t>(items_[j])])
        for (const Index g : topology_.node_boundary_faces.row(v)) {
          const Index at = position[static_cast<std::size_t>(g)];
          if (at < node.begin || at >= node.end) {
            border.emplace_back(static_cast<Index>(i), v);
            break;
          }
        }
  }
  borders_ = csr_from_pairs(static_cast<Index>(nodes_.size()), border);
}

bool SelfCollider::adjacent(Index a, Index b) const {
  const auto u = borders_.row(a), v = borders_.row(b);
  std::size_t i = 0, j = 0;
  while (i < u.size() && j < v.size()) {
    if (u[i] == v[j]) return true;
    if (u[i] < v[j])
      ++i;
    else
      ++j;
  }
  return false;
}

bool SelfCollider::surface_gate(const Positions& x, double rel, SelfDetectStats& st) {
  crossing_.clear();
  if (nodes_.empty()) return false;
  measure_faces(x);
  refit_surface_tree();
  const double cert = traverse_surface(x, rel, st);
  std::sort(crossing_.begin(), crossing_.end());
  st.crossing_pairs = crossing_.size();
  keep_certificate(x, cert, st);
  return !crossing_.empty();
}

void SelfCollider::measure_faces(const Positions& x) {
  const auto& faces = topology_.boundary_faces;
  face_boxes_.resize(faces.size());
  face_normals_.resize(faces.size());
  face_reach_.resize(faces.size());
  detail::for_chunks(
      faces.size(), kFaceChunk, [&](std::size_t begin, std::size_t end, std::size_t) {
        for (std::size_t f = begin; f < end; ++f) {
          const Vec3 a = x.col(faces[f][0]), b = x.col(faces[f][1]), c = x.col(faces[f][2]);
          Aabb box;
          box.extend(a);
          box.extend(b);
          box.extend(c);
          face_boxes_[f] = box;
          const Vec3 n = (b - a).cross(c - a);
          const double len = n.norm();
          face_normals_[f] = len > 0.0 && std::isfinite(len) ? Vec3(n / len) : Vec3::Zero();
          const double longest =
              std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
          face_reach_[f] = longest > 0.0 ? len / (16.0 * std::sqrt(longest)) : 0.0;
        }
      });
}

void SelfCollider::refit_surface_tree() {
  // Bottom-up: children follow their parent in pre-order.
  for (std::size_t i = nodes_.size(); i-- > 0;) {
    SurfaceNode& node = nodes_[i];
    if (node.leaf()) {
      Aabb box;
      Vec3 sum = Vec3::Zero();
      bool degenerate = false;
      for (Index j = node.begin; j < node.end; ++j) {
        const auto f = static_cast<std::size_t>(items_[j]);
        box.extend(face_boxes_[f]);
        degenerate = degenerate || face_normals_[f].isZero();
        sum += face_normals_[f];
      }
      node.box = box;
      node.reach = std::numeric_limits<double>::infinity();
      for (Index j = node.begin; j < node.end; ++j)
        node.reach = std::min(node.reach, face_reach_[static_cast<std::size_t>(items_[j])]);
      const double len = sum.norm();
      if (degenerate || !(len > 0.0)) {
        node.cone = std::numbers::pi;
        continue;
      }
      node.axis = sum / len;
      double lowest = 1.0;
      for (Index j = node.begin; j < node.end; ++j)
        lowest =
            std::min(lowest, node.axis.dot(face_normals_[static_cast<std::size_t>(items_[j])]));
      node.cone = std::acos(std::clamp(lowest, -1.0, 1.0));
    } else {
      const SurfaceNode& l = nodes_[i + 1];
      const SurfaceNode& r = nodes_[static_cast<std::size_t>(node.right)];
      node.box = l.box;
      node.box.extend(r.box);
      node.reach = std::min(l.reach, r.reach);
      const auto [axis, cone] = merge_cones(l.axis, l.cone, r.axis, r.cone);
      node.axis = axis;
      node.cone = cone;
    }
  }
}

double SelfCollider::traverse_surface(const Positions& x, double rel, SelfDetectStats& st) {
  const auto& faces = topology_.boundary_faces;
  // Self-traversal. `cert`: how far every corner may move (after a common translation)
  // with every decision below unchanged.
  double cert = std::numeric_limits<double>::infinity();
  const auto cone_slack = [](double cone, double reach) {
    return reach * std::sin(std::max(0.0, 0.5 * std::numbers::pi - cone));
  };
  const auto test = [&](Index fi, Index gi) {
    const auto f = static_cast<std::size_t>(fi), g = static_cast<std::size_t>(gi);
    if (share_node(faces[f], faces[g])) return;
    const std::array<Vec3, 3> s{x.col(faces[f][0]), x.col(faces[f][1]), x.col(faces[f][2])};
    const std::array<Vec3, 3> t{x.col(faces[g][0]), x.col(faces[g][1]), x.col(faces[g][2])};
    // Once a crossing is found there is no certificate to measure.
    const bool measure = crossing_.empty();
    if (!face_boxes_[f].overlaps(face_boxes_[g])) {  // boxes that nearly touch: the triangles'
      const double gap = box_gap(face_boxes_[f], face_boxes_[g]);  // own gap, if larger
      if (measure)
        cert = std::min(
            cert, 0.5 * (gap >= near_gap_ ? gap : std::max(gap, separation(s, t, near_gap_))));
      return;
    }
    ++st.surface_pairs;
    if (triangles_meet(s, t, rel))
      crossing_.push_back({std::min(fi, gi), std::max(fi, gi)});
    else if (measure)
      cert = std::min(cert, 0.5 * separation(s, t, near_gap_));
  };
  std::vector<std::pair<Index, Index>> stack;
  stack.emplace_back(0, 0);
  while (!stack.empty()) {
    const auto [i, j] = stack.back();
    stack.pop_back();
    const SurfaceNode& a = nodes_[static_cast<std::size_t>(i)];
    if (i == j) {
      if (a.connected && a.cone < kCullCone &&  // a patch that cannot fold onto itself
          cone_slack(a.cone, a.reach) >= 0.2 * near_gap_) {
        cert = std::min(cert, cone_slack(a.cone, a.reach));
        continue;
      }
      if (a.leaf()) {
        for (Index u = a.begin; u < a.end; ++u)
          for (Index v = u + 1; v < a.end; ++v) test(items_[u], items_[v]);
        continue;
      }
      stack.emplace_back(i + 1, i + 1);
      stack.emplace_back(a.right, a.right);
      stack.emplace_back(i + 1, a.right);
      continue;
    }
    const SurfaceNode& b = nodes_[static_cast<std::size_t>(j)];
    const double gap = a.box.overlaps(b.box) ? 0.0 : box_gap(a.box, b.box);
    if (gap >= near_gap_) {
      cert = std::min(cert, 0.5 * gap);
      continue;
    }
    // (Boxes that touch or nearly do: the finer nodes say how far apart they are.)
    // Two patches that meet at a corner and whose normals together fit in a cone below 90
    // degrees are one patch that cannot fold onto itself.
    if (a.connected && b.connected && a.cone < kCullCone && b.cone < kCullCone) {
      const double cone = merge_cones(a.axis, a.cone, b.axis, b.cone).second;
      const double slack = cone_slack(cone, std::min(a.reach, b.reach));
      if (cone < kCullCone && slack >= 0.2 * near_gap_ && adjacent(i, j)) {
        cert = std::min(cert, slack);
        continue;
      }
    }
    if (a.leaf() && b.leaf()) {
      for (Index u = a.begin; u < a.end; ++u)
        for (Index v = b.begin; v < b.end; ++v) test(items_[u], items_[v]);
      continue;
    }
    if (b.leaf() || (!a.leaf() && a.end - a.begin >= b.end - b.begin)) {
      stack.emplace_back(i + 1, j);
      stack.emplace_back(a.right, j);
    } else {
      stack.emplace_back(i, j + 1);
      stack.emplace_back(i, b.right);
    }
  }
  return cert;
}

void SelfCollider::keep_certificate(const Positions& x, double cert, SelfDetectStats& st) {
  // A certificate only where nothing crosses, from these positions.
  cert_ = crossing_.empty() && std::isfinite(cert) ? cert : 0.0;
  st.certificate = cert_;
  synced_ = false;
  if (cert_ > 0.0) {
    const auto& nodes = topology_.boundary_nodes;
    cert_x_.resize(nodes.size());
    cert_scale_ = 0.0;
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      cert_x_[k] = x.col(nodes[k]);
      cert_scale_ = std::max(cert_scale_, cert_x_[k].cwiseAbs().maxCoeff());
    }
  }
}

namespace {

/// A bound the certificate can use: every node within `motion` of its reference after a
/// shift alone (not a turn).
bool shift_bound(const MotionBound* bound) {
  return bound != nullptr && bound->bounded && !bound->rotated && bound->reference != nullptr &&
         std::isfinite(bound->motion);
}

}  // namespace

bool SelfCollider::within_bound(const MotionBound* bound) {
  // (A rebuilt reference is new at every node: offset_ no longer holds.)
  if (!(synced_ && shift_bound(bound) && !bound->rebuilt &&
        bound->version_before == sync_version_)) {
    synced_ = false;
    return false;
  }
  // The nodes that moved beyond their radii got new references: how far those are from
  // the certificate's positions.
  const auto& nodes = topology_.boundary_nodes;
  for (const Index v : bound->moved) {
    const auto it = std::lower_bound(nodes.begin(), nodes.end(), v);
    if (it == nodes.end() || *it != v) continue;
    const auto k = static_cast<std::size_t>(it - nodes.begin());
    offset_ = std::max(offset_, (bound->reference->col(v) + sync_shift_ - cert_x_[k]).norm());
  }
  sync_version_ = bound->version_after;
  // Each boundary node k, after the translation shift - sync_shift_: |x_k - cert_x_k - t|
  // <= |x_k - shift - ref_k| + |ref_k + sync_shift_ - cert_x_k| <= motion + offset_. The
  // slack covers the rounding of both (a few eps of the coordinates and shifts).
  const double slack = 1e-12 * (cert_scale_ + bound->shift.cwiseAbs().maxCoeff() +
                                sync_shift_.cwiseAbs().maxCoeff());
  return (bound->motion + offset_) * (1.0 + 1e-12) + slack <= cert_;
}

void SelfCollider::sync_bound(const MotionBound* bound, bool pass) {
  synced_ = cert_ > 0.0 && shift_bound(bound);
  if (!synced_) return;
  sync_version_ = bound->version_after;
  sync_shift_ = bound->shift;
  if (!pass) {  // cert_x_ are these positions: each within motion of its reference + shift
    offset_ = bound->motion;
    return;
  }
  const auto& nodes = topology_.boundary_nodes;
  offset_ = 0.0;
  for (std::size_t k = 0; k < nodes.size(); ++k)
    offset_ =
        std::max(offset_, (bound->reference->col(nodes[k]) + sync_shift_ - cert_x_[k]).norm());
}

bool SelfCollider::within_certificate(const Positions& x, const MotionBound* bound,
                                      SelfDetectStats& st) {
  if (!(cert_ > 0.0)) return false;
  if (within_bound(bound)) {
    st.certified_by_bound = true;
    return true;
  }
  const auto& nodes = topology_.boundary_nodes;
  const double limit2 = cert_ * cert_;
  // Most frames: every node within the certificate as it is.
  bool inside = true;
  Vec3 mean = Vec3::Zero();
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    const Vec3 d = x.col(nodes[k]) - cert_x_[k];
    mean += d;
    inside = inside && d.squaredNorm() <= limit2;
  }
  if (!inside) {
    // A translation of the whole boundary changes no crossing: remove the mean displacement.
    mean /= static_cast<double>(std::max<std::size_t>(1, nodes.size()));
    for (std::size_t k = 0; k < nodes.size(); ++k)
      if (!((x.col(nodes[k]) - cert_x_[k] - mean).squaredNorm() <= limit2)) return false;
  }
  if (!synced_) sync_bound(bound, true);  // (once: the next frames need no pass)
  return true;
}

Aabb SelfCollider::flood_region(const Positions& x, double rel, SelfDetectStats& st) {
  const auto m = tets_.size();
  tet_boxes_.resize(m);
  detail::for_chunks(m, kFaceChunk, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t t = begin; t < end; ++t) {
      Aabb box;
      for (const Index v : tets_[t]) box.extend(x.col(v));
      tet_boxes_[t] = box;
    }
  });
  if (!tet_tree_built_) {
    tet_tree_.build(tet_boxes_);
    tet_tree_built_ = true;
  } else {
    tet_tree_.refit(tet_boxes_);
  }
  Aabb region;
  for (const auto& pair : crossing_)
    for (const Index f : pair) region.extend(face_boxes_[static_cast<std::size_t>(f)]);
  // The boundary nodes inside another tet of the object, flooded over the boundary from
  // the crossing triangles: the caps of the surface that went inside.
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(topology_.num_nodes), 0);
  std::vector<Index> queue;
  for (const auto& pair : crossing_)
    for (const Index f : pair)
      for (const Index v : topology_.boundary_faces[static_cast<std::size_t>(f)])
        if (seen[static_cast<std::size_t>(v)] == 0) {
          seen[static_cast<std::size_t>(v)] = 1;
          queue.push_back(v);
        }
  std::sort(queue.begin(), queue.end());
  std::vector<Index> found;
  const double pad = rel * (tet_tree_.root_box().hi - tet_tree_.root_box().lo).maxCoeff();
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const Index v = queue[q];
    const Vec3 p = x.col(v);
    Aabb probe{p.array() - pad, p.array() + pad};
    found.clear();
    tet_tree_.query(probe, tet_boxes_, found);
    bool inside = false;
    for (const Index t : found) {
      const Tet& tet = tets_[static_cast<std::size_t>(t)];
      if (std::find(tet.begin(), tet.end(), v) != tet.end()) continue;
      const TetCorners c = tet_corners(x, tet);
      if (point_in_tet(p, c, rel * tet_scale(c)).inside) {
        inside = true;
        break;
      }
    }
    if (!inside) continue;
    ++st.flooded_nodes;
    region.extend(p);
    for (const Index f : topology_.node_boundary_faces.row(v))
      for (const Index w : topology_.boundary_faces[static_cast<std::size_t>(f)])
        if (seen[static_cast<std::size_t>(w)] == 0) {
          seen[static_cast<std::size_t>(w)] = 1;
          queue.push_back(w);
        }
  }
  const double grow = rel * (region.hi - region.lo).maxCoeff();
  region.lo.array() -= grow;
  region.hi.array() += grow;
  return region;
}

void SelfCollider::tet_stage(const Positions& x, const Aabb& region, double rel, SelfContacts& out,
                             SelfDetectStats& st) {
  const auto m = tets_.size();
  std::vector<Index> near;
  tet_tree_.query(region, tet_boxes_, near);
  std::sort(near.begin(), near.end());
  st.region_tets = near.size();
  std::vector<std::uint8_t> in_region(m, 0);
  for (const Index t : near) in_region[static_cast<std::size_t>(t)] = 1;
  // Candidate pairs (lower, higher), each found from one tet of the region.
  detail::ChunkBuffers<std::pair<Index, Index>> parts;
  const std::size_t chunks = detail::num_chunks(near.size(), kTetChunk);
  detail::reset_parts(parts, chunks);
  detail::for_chunks(
      near.size(), kTetChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
        std::vector<Index> hits;
        for (std::size_t k = begin; k < end; ++k) {
          const Index i = near[k];
          hits.clear();
          tet_tree_.query(tet_boxes_[static_cast<std::size_t>(i)], tet_boxes_, hits);
          for (const Index j : hits) {
            if (j == i || (j < i && in_region[static_cast<std::size_t>(j)] != 0)) continue;
            if (share_node(tets_[static_cast<std::size_t>(i)], tets_[static_cast<std::size_t>(j)]))
              continue;
            parts[c].emplace_back(std::min(i, j), std::max(i, j));
          }
        }
      });
  std::vector<std::pair<Index, Index>> candidates;
  detail::concat_parts(parts, chunks, candidates);
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  st.candidates = candidates.size();
  // Geometry of every tet of a candidate pair, by slot.
  std::vector<Index> slot_tets;
  for (const auto& [i, j] : candidates) {
    slot_tets.push_back(i);
    slot_tets.push_back(j);
  }
  std::sort(slot_tets.begin(), slot_tets.end());
  slot_tets.erase(std::unique(slot_tets.begin(), slot_tets.end()), slot_tets.end());
  std::vector<TetGeometry> geometry(slot_tets.size());
  detail::for_chunks(
      slot_tets.size(), kTetChunk, [&](std::size_t begin, std::size_t end, std::size_t) {
        for (std::size_t s = begin; s < end; ++s)
          make_tet_geometry(tet_corners(x, tets_[static_cast<std::size_t>(slot_tets[s])]),
                            geometry[s]);
      });
  const auto geom = [&](Index t) -> const TetGeometry& {
    const auto it = std::lower_bound(slot_tets.begin(), slot_tets.end(), t);
    return geometry[static_cast<std::size_t>(it - slot_tets.begin())];
  };
  std::vector<std::uint8_t> overlaps(candidates.size(), 0);
  detail::for_chunks(candidates.size(), kTetChunk,
                     [&](std::size_t begin, std::size_t end, std::size_t) {
                       for (std::size_t k = begin; k < end; ++k) {
                         const TetGeometry& a = geom(candidates[k].first);
                         const TetGeometry& b = geom(candidates[k].second);
                         overlaps[k] = tets_overlap(a, b, rel * pair_scale(a, b)) ? 1 : 0;
                       }
                     });
  // Overlapping pairs by pair of components, oriented as two objects would be.
  std::map<std::pair<Index, Index>, std::vector<TetPair>> by_part;
  const auto& component = topology_.tet_component;
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    if (overlaps[k] == 0) continue;
    ++st.overlapping;
    const auto [i, j] = candidates[k];
    const Index ci = component[static_cast<std::size_t>(i)];
    const Index cj = component[static_cast<std::size_t>(j)];
    if (ci <= cj)
      by_part[{ci, cj}].push_back({i, j});
    else
      by_part[{cj, ci}].push_back({j, i});
    out.marked.push_back(i);
    out.marked.push_back(j);
  }
  std::sort(out.marked.begin(), out.marked.end());
  out.marked.erase(std::unique(out.marked.begin(), out.marked.end()), out.marked.end());

  // The nodes and edges of one direction: X's marked tets (rows.tets) and the tets of Y
  // each overlaps (rows). As Detector::intruding_nodes / intruding_edges.
  const auto scan_nodes = [&](const Rows& rows, std::vector<IntrudingNode>& list) {
    std::vector<Index> features;
    for (const Index t : rows.tets)
      for (const Index v : tets_[static_cast<std::size_t>(t)]) features.push_back(v);
    std::sort(features.begin(), features.end());
    features.erase(std::unique(features.begin(), features.end()), features.end());
    detail::ChunkBuffers<IntrudingNode> found;
    const std::size_t count = detail::num_chunks(features.size(), kFeatureChunk);
    detail::reset_parts(found, count);
    detail::for_chunks(features.size(), kFeatureChunk,
                       [&](std::size_t begin, std::size_t end, std::size_t c) {
                         std::vector<Index> tested;
                         for (std::size_t f = begin; f < end; ++f) {
                           const Index v = features[f];
                           const Vec3 p = x.col(v);
                           Index best = std::numeric_limits<Index>::max();
                           Eigen::Vector4d bary = Eigen::Vector4d::Zero();
                           tested.clear();
                           for (const Index t : topology_.node_tets.row(v))
                             for (const Index s : rows.row_of(t)) {
                               if (s >= best) break;
                               if (std::find(tested.begin(), tested.end(), s) != tested.end())
                                 continue;
                               tested.push_back(s);
                               const TetGeometry& g = geom(s);
                               const double tol = rel * g.scale;
                               if (!meets_padded_box(p, p, g.lo, g.hi, tol)) continue;
                               const PointInTet hit = point_in_tet(p, g, tol);
                               if (hit.inside) {
                                 best = s;
                                 bary = hit.bary;
                                 break;
                               }
                             }
                           if (best != std::numeric_limits<Index>::max())
                             found[c].push_back({v, best, bary});
                         }
                       });
    detail::concat_parts(found, count, list);
  };
  const auto scan_edges = [&](const Rows& rows, std::vector<IntrudingEdge>& list) {
    std::vector<Index> features;
    for (const Index t : rows.tets)
      for (const Index e : tet_edges_[static_cast<std::size_t>(t)]) features.push_back(e);
    std::sort(features.begin(), features.end());
    features.erase(std::unique(features.begin(), features.end()), features.end());
    detail::ChunkBuffers<IntrudingEdge> found;
    const std::size_t count = detail::num_chunks(features.size(), kFeatureChunk);
    detail::reset_parts(found, count);
    detail::for_chunks(
        features.size(), kFeatureChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
          std::vector<Index> tested;
          std::vector<detail::EdgeHit> hits;
          for (std::size_t f = begin; f < end; ++f) {
            const Index e = features[f];
            const auto& ends = topology_.edges[static_cast<std::size_t>(e)];
            const Vec3 p0 = x.col(ends[0]), p1 = x.col(ends[1]);
            const Vec3 lo = p0.cwiseMin(p1), hi = p0.cwiseMax(p1);
            const double length = (p1 - p0).norm();
            tested.clear();
            hits.clear();
            for (const Index t : edge_tets_.row(e))
              for (const Index s : rows.row_of(t)) {
                if (std::find(tested.begin(), tested.end(), s) != tested.end()) continue;
                tested.push_back(s);
                const TetGeometry& g = geom(s);
                const double tol = rel * std::max(g.scale, length);
                if (!meets_padded_box(lo, hi, g.lo, g.hi, tol)) continue;
                const SegmentClip clip = clip_segment_tet(p0, p1, g, tol);
                if (clip.hit)
                  hits.push_back({{e, s, clip.lambda_in, clip.lambda_out}, tol / length});
              }
            if (hits.empty()) continue;
            std::sort(hits.begin(), hits.end(),
                      [](const detail::EdgeHit& u, const detail::EdgeHit& v) {
                        return u.edge.tet < v.edge.tet;
                      });
            detail::append_edge_hits(hits, found[c]);
          }
        });
    detail::concat_parts(found, count, list);
  };

  for (auto& [key, overlapping] : by_part) {
    SelfContactPart part;
    part.component_a = key.first;
    part.component_b = key.second;
    PairContacts& pc = part.contacts;
    std::sort(overlapping.begin(), overlapping.end());
    pc.overlapping = std::move(overlapping);
    std::vector<std::pair<Index, Index>> ab, ba;
    for (const TetPair& p : pc.overlapping) {
      ab.emplace_back(p.tet_a, p.tet_b);
      ba.emplace_back(p.tet_b, p.tet_a);
    }
    if (key.first == key.second) {  // one component against itself: both ways, one list
      ab.insert(ab.end(), ba.begin(), ba.end());
      ba.clear();
    }
    Rows rows_ab, rows_ba;
    rows_ab.build(ab);
    rows_ba.build(ba);
    if (key.first == key.second) {
      pc.marked_a = rows_ab.tets;
      pc.marked_b = rows_ab.tets;
    } else {
      pc.marked_a = rows_ab.tets;
      pc.marked_b = rows_ba.tets;
    }
    scan_nodes(rows_ab, pc.nodes_a_in_b);
    scan_edges(rows_ab, pc.edges_a_in_b);
    scan_nodes(rows_ba, pc.nodes_b_in_a);
    scan_edges(rows_ba, pc.edges_b_in_a);
    out.parts.push_back(std::move(part));
  }
}

void SelfCollider::detect(const Positions& positions, double relative_tolerance, SelfContacts& out,
                          SelfDetectStats* stats, const MotionBound* bound) {
  out.clear();
  SelfDetectStats st;
  const double rel = relative_tolerance > 0.0 ? relative_tolerance : 0.0;
  const auto t0 = Clock::now();
  if (within_certificate(positions, bound, st)) {
    st.certified = true;
    st.surface_ms = ms_since(t0);
    if (stats != nullptr) *stats = st;
    return;
  }
  const bool crossing = surface_gate(positions, rel, st);
  sync_bound(bound, false);  // (no certificate when crossing)
  st.surface_ms = ms_since(t0);
  if (crossing) {
    const auto t1 = Clock::now();
    const Aabb region = flood_region(positions, rel, st);
    tet_stage(positions, region, rel, out, st);
    st.tets_ms = ms_since(t1);
  }
  if (stats != nullptr) *stats = st;
}

}  // namespace tc
