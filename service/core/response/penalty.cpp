#include "core/response/penalty.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/depth/point_simplex_distance.hpp"
#include "core/mesh/geometry.hpp"
#include "core/response/tet_frame.hpp"

namespace tc {

const char* response_kind_name(ResponseKind kind) {
  switch (kind) {
    case ResponseKind::kPoint:
      return "point";
    case ResponseKind::kSegment:
      return "segment";
    case ResponseKind::kAuto:
      return "auto";
  }
  return "unknown";
}

std::optional<ResponseKind> parse_response_kind(std::string_view name) {
  for (const ResponseKind k : {ResponseKind::kPoint, ResponseKind::kSegment, ResponseKind::kAuto})
    if (name == response_kind_name(k)) return k;
  return std::nullopt;
}

namespace {

using Vec3 = Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Mat3 = Eigen::Matrix3d;

/// Clamps negative weights to 0 and rescales to sum 1. False when nothing is left.
bool normalize_weights(Vec4& w) {
  if (!w.allFinite()) return false;
  w = w.cwiseMax(0.0);
  const double sum = w.sum();
  if (!(sum > 0.0) || !std::isfinite(sum)) return false;
  w /= sum;
  return true;
}

/// Positions, depth values and frame of one tet of the penetrated object.
struct TetData {
  std::array<Vec3, 4> x;
  Vec4 d;
  TetFrame frame;
  bool finite = false;
};

TetData load_tet(const ResponseObject& y, Index t) {
  TetData td;
  const Tet& tet = y.tets[static_cast<std::size_t>(t)];
  bool finite = true;
  for (int k = 0; k < 4; ++k) {
    td.x[k] = y.positions->col(tet[k]);
    td.d[k] = y.depth[static_cast<std::size_t>(tet[k])];
    finite = finite && td.x[k].allFinite() && std::isfinite(td.d[k]);
  }
  td.finite = finite;
  if (finite) td.frame = make_tet_frame(td.x[0], td.x[1], td.x[2], td.x[3]);
  return td;
}

Vec3 velocity(const ResponseObject& o, Index node) {
  if (o.velocities == nullptr) return Vec3::Zero();
  const Vec3 v = o.velocities->col(node);
  return v.allFinite() ? v : Vec3::Zero();
}

/// Smoothed Coulomb friction at one contact point (docs/RESPONSE.md, "Friction").
struct Friction {
  Vec3 force = Vec3::Zero();  ///< on the intruder, N
  Mat3 dv = Mat3::Zero();     ///< the secant df/dv with the push held fixed, N s/m
};

/// The friction on an intruding point pushed with magnitude `push` (N) along the unit
/// direction n, moving at v (m/s) relative to the penetrated object:
///     F = -mu push f1(|v_t| / eps) v_t / |v_t|,  v_t = (I - n n^T) v,
///     f1(y) = 2y - y^2 for y < 1, 1 beyond,
/// C1 in v_t and a viscous stick (slope 2 mu push / eps) below eps; F.v <= 0: friction
/// never adds energy. `dv` is the secant (lagged viscous) matrix
///     D = -mu push g(|v_t|) P,  g(y) = f1(y / eps) / y,  P = I - n n^T,
/// so that F = D v exactly: symmetric, negative semi-definite, equal to the derivative at
/// rest, and never letting an implicit step reverse the slip (docs/RESPONSE.md).
Friction friction_at(double mu, double eps, double push, const Vec3& n, const Vec3& v) {
  Friction out;
  const Mat3 tangent = Mat3::Identity() - n * n.transpose();
  const Vec3 vt = tangent * v;
  const double y = vt.norm();
  if (!std::isfinite(y)) return out;
  const double g = y >= eps ? 1.0 / y : (2.0 - y / eps) / eps;  // f1(y / eps) / y
  out.dv = -mu * push * g * tangent;
  out.force = out.dv * v;
  return out;
}

/// The push-out direction of a contact at point x in tet t of the penetrated object,
/// and, on the nearest-face path, the depth there.
struct Direction {
  Vec3 n = Vec3::UnitZ();        ///< unit push-out direction of the intruder
  Vec3 gradient = Vec3::Zero();  ///< grad d (gradient path only)
  double gamma = 1.0;            ///< |grad d| for the blocks; 1 off the gradient path
  Fallback fallback = Fallback::kNone;
  bool from_face = false;  ///< depth and direction from the nearest boundary face
  bool forced = false;     ///< the pair direction of a symmetric overlap's separating pass
};

/// The nearest boundary face of Y to a point, among the candidates of a tet.
struct FaceHit {
  double sq_dist = std::numeric_limits<double>::infinity();
  Index face = -1;
  Vec3 closest = Vec3::Zero();
  Vec3 normal = Vec3::Zero();  ///< the face's outward unit normal (set by face_direction)
};

/// The neighbourhood of a self-contact's intruding node(s) that its face search leaves
/// out (SelfContactView); empty for a contact between two objects.
struct Exclusion {
  const ResponseObject* y = nullptr;  ///< null: nothing is left out
  Index component = -1;               ///< the intruding nodes' component
  std::vector<Index> near;            ///< nodes within `rings` edges of them, sorted

  /// For a contact of `intruder`'s nodes a and b (b = -1 for a point) in `target`: a
  /// self-contact (both sides one object with a SelfContactView) leaves their
  /// neighbourhood out.
  static Exclusion of(const ResponseObject& intruder, const ResponseObject& target, Index a,
                      Index b) {
    Exclusion e;
    if (target.self == nullptr || intruder.positions != target.positions) return e;
    e.y = &target;
    e.component = target.self->node_component[static_cast<std::size_t>(a)];
    const Index seeds[2] = {a, b};
    e.near = nodes_within_rings(*target.topology, std::span<const Index>(seeds, b >= 0 ? 2 : 1),
                                target.self->rings);
    return e;
  }

  [[nodiscard]] bool excludes(Index f) const {
    if (y == nullptr) return false;
    const Topology& topo = *y->topology;
    const auto owner =
        static_cast<std::size_t>(topo.boundary_face_tet[static_cast<std::size_t>(f)]);
    if (topo.tet_component[owner] != component) return false;
    const auto& tri = topo.boundary_faces[static_cast<std::size_t>(f)];
    for (const Index w : tri)
      if (std::binary_search(near.begin(), near.end(), w)) return true;
    return false;
  }
};

/// Outward unit normal of boundary face f of Y (the owning tet's orientation decides the
/// side); false when the face has no area.
bool boundary_face_normal(const ResponseObject& y, Index f, Vec3& normal) {
  const Topology& topo = *y.topology;
  const auto& tri = topo.boundary_faces[static_cast<std::size_t>(f)];
  const Vec3 a = y.positions->col(tri[0]);
  const Vec3 e1 = y.positions->col(tri[1]) - a, e2 = y.positions->col(tri[2]) - a;
  const Vec3 cross = e1.cross(e2);
  const double norm = cross.norm();
  if (!(norm > 1e-14 * e1.norm() * e2.norm()) || !std::isfinite(norm)) return false;
  const Tet& owner = y.tets[static_cast<std::size_t>(topo.boundary_face_tet[f])];
  const double orientation = signed_volume(*y.positions, owner) < 0.0 ? -1.0 : 1.0;
  normal = orientation * cross / norm;
  return true;
}

/// True when the triangle (p0, p1, p2) is certainly farther from x than `reach` (metres)
/// as closest_point_triangle() measures it: x's distance to the triangle's box exceeds
/// reach by more than that function's rounding can take off (10^-9 of the coordinates'
/// size, some 10^6 times its worst case). A face skipped so could not have become the
/// nearest (nearest_face() takes a face only within reach of the best so far), so the
/// search finds the same face, bit for bit, with a box test instead of a closest point
/// for most faces (about three in four around a deep contact).
bool far_beyond(const Vec3& x, const Vec3& p0, const Vec3& p1, const Vec3& p2, double reach) {
  if (!(reach < std::numeric_limits<double>::infinity())) return false;
  const Vec3 lo = p0.cwiseMin(p1).cwiseMin(p2), hi = p0.cwiseMax(p1).cwiseMax(p2);
  const double gap2 = (lo - x).cwiseMax(x - hi).cwiseMax(0.0).squaredNorm();
  const double size = std::max({x.cwiseAbs().maxCoeff(), lo.cwiseAbs().maxCoeff(),
                                hi.cwiseAbs().maxCoeff(), (hi - lo).maxCoeff()});
  const double bound = reach + 1e-9 * size;
  return gap2 > bound * bound;
}

/// Nearest boundary face of Y to x, searched from the faces around tet `tet`'s four nodes
/// and around their anchors (the boundary nodes their depths were measured to), then by
/// descent on the surface: while the closest point lies on a vertex or an edge of the
/// best face, the faces around that vertex or edge's ends are searched too. Distances
/// within `tie` (metres) of each other are ties, which go to the lower face index, so
/// neither the order of the search nor rounding (a scale, an offset) decides between
/// faces that are equally near.
FaceHit nearest_face(const ResponseObject& y, const Tet& tet, const Vec3& x, double tie,
                     const Exclusion& exclusion) {
  FaceHit best;
  if (y.topology == nullptr) return best;
  const Topology& topo = *y.topology;
  constexpr int kMaxRows = 48;  // rows searched at most (the descent stops there)
  std::array<Index, kMaxRows> seen{};
  int count = 0;
  FeatureLoc best_loc = FeatureLoc::kInterior;
  double best_dist = std::numeric_limits<double>::infinity();
  const auto scan = [&](Index v) {
    if (v < 0 || v >= topo.node_boundary_faces.rows() || count == kMaxRows) return false;
    for (int i = 0; i < count; ++i)
      if (seen[i] == v) return false;
    seen[count++] = v;
    bool improved = false;
    for (const Index f : topo.node_boundary_faces.row(v)) {
      if (exclusion.excludes(f)) continue;
      const auto& tri = topo.boundary_faces[static_cast<std::size_t>(f)];
      const Vec3 p0 = y.positions->col(tri[0]), p1 = y.positions->col(tri[1]),
                 p2 = y.positions->col(tri[2]);
      if (far_beyond(x, p0, p1, p2, best_dist + tie)) continue;
      const auto cp = closest_point_triangle(x, p0, p1, p2);
      const double d2 = (cp.point - x).squaredNorm();
      const double d = std::sqrt(d2);
      if (d < best_dist - tie || (d <= best_dist + tie && f < best.face)) {
        best_dist = d;
        best.sq_dist = d2;
        best.face = f;
        best.closest = cp.point;
        best_loc = cp.loc;
        improved = true;
      }
    }
    return improved;
  };
  for (int k = 0; k < 4; ++k) scan(tet[k]);
  if (!y.anchor.empty())
    for (int k = 0; k < 4; ++k) scan(y.anchor[static_cast<std::size_t>(tet[k])]);
  // Descent: the faces around the closest point's vertex (or its edge's two ends).
  while (best.face >= 0 && best_loc != FeatureLoc::kInterior) {
    const auto& tri = topo.boundary_faces[static_cast<std::size_t>(best.face)];
    Index ends[2] = {-1, -1};
    switch (best_loc) {
      case FeatureLoc::kV0:
      case FeatureLoc::kV1:
      case FeatureLoc::kV2:
        ends[0] = tri[static_cast<int>(best_loc)];
        break;
      case FeatureLoc::kE01:
        ends[0] = tri[0], ends[1] = tri[1];
        break;
      case FeatureLoc::kE12:
        ends[0] = tri[1], ends[1] = tri[2];
        break;
      case FeatureLoc::kE20:
        ends[0] = tri[2], ends[1] = tri[0];
        break;
      case FeatureLoc::kInterior:
        break;
    }
    const bool a = scan(ends[0]);
    const bool b = scan(ends[1]);
    if (!a && !b) break;
  }
  return best;
}

/// Push-out direction at x from its nearest face: towards the closest point, or the
/// face's outward normal when x is (within rounding) on the face or on its outer side.
bool face_direction(const ResponseObject& y, FaceHit& hit, const Vec3& x, double size, Vec3& n) {
  if (hit.face < 0 || !std::isfinite(hit.sq_dist)) return false;
  if (!boundary_face_normal(y, hit.face, hit.normal)) return false;
  const Vec3 out = hit.closest - x;
  const double dist = std::sqrt(hit.sq_dist);
  n = dist > 1e-9 * size && out.dot(hit.normal) > 0.0 ? Vec3(out / dist) : hit.normal;
  return n.allFinite();
}

double longest_edge(const TetData& td) {
  double size = 0.0;
  for (const auto& e : kTetEdges) size = std::max(size, (td.x[e[0]] - td.x[e[1]]).norm());
  return size;
}

/// The depth gradient of the tet, when it is usable (options' limits).
bool gradient_direction(const TetData& td, const ResponseOptions& o, Direction& dir) {
  if (!td.frame.regular) return false;
  const Vec3 g = linear_gradient(td.frame, td.d);
  const double norm = g.norm();
  if (!(std::isfinite(norm) && norm >= o.min_gradient && norm <= o.max_gradient && norm > 0.0))
    return false;
  dir.n = -g / norm;
  dir.gradient = g;
  dir.gamma = norm;
  return true;
}

/// The direction of a contact at x in tet t of Y (and on the nearest-face path that
/// face, in `hit`), by the chain of docs/RESPONSE.md "Depth and direction": the
/// evaluation asked for, then the other one, then the pair direction, then +z. In the
/// separating pass of a symmetric overlap (ResponseOptions::along_pair_direction) the
/// pair direction replaces the result, the depth being found as usual.
Direction direction_by_depth(const ResponseObject& y, Index t, const TetData& td, const Vec3& x,
                             const ResponseOptions& o, const Vec3& pair_direction, FaceHit& hit,
                             const Exclusion& exclusion) {
  Direction dir;
  const Tet& tet = y.tets[static_cast<std::size_t>(t)];
  const auto by_face = [&] {
    const double size = longest_edge(td);
    hit = nearest_face(y, tet, x, 1e-9 * size, exclusion);
    if (!face_direction(y, hit, x, size, dir.n)) return false;
    dir.from_face = true;
    return true;
  };
  if (o.evaluation == DepthEvaluation::kNearestFace) {
    if (by_face()) return dir;
    if (gradient_direction(td, o, dir)) {
      dir.fallback = Fallback::kGradient;
      return dir;
    }
  } else {
    if (gradient_direction(td, o, dir)) return dir;
    if (by_face()) {
      dir.fallback = Fallback::kNearestFace;
      return dir;
    }
  }
  // Away from Y's contact region towards X's; else a fixed axis.
  if (pair_direction.allFinite() && pair_direction.squaredNorm() > 0.5) {
    dir.n = pair_direction.normalized();
    dir.fallback = Fallback::kPairDirection;
  } else {
    dir.n = Vec3::UnitZ();
    dir.fallback = Fallback::kAxis;
  }
  return dir;
}

Direction direction_at(const ResponseObject& y, Index t, const TetData& td, const Vec3& x,
                       const ResponseOptions& o, const Vec3& pair_direction, FaceHit& hit,
                       const Exclusion& exclusion) {
  Direction dir = direction_by_depth(y, t, td, x, o, pair_direction, hit, exclusion);
  if (o.along_pair_direction && pair_direction.allFinite() && pair_direction.squaredNorm() > 0.5) {
    dir.n = pair_direction.normalized();
    dir.gradient.setZero();
    dir.gamma = 1.0;
    dir.fallback = Fallback::kPairDirection;
    dir.forced = true;
  }
  return dir;
}

/// d/dp of node_length_weight: half the sum of the unit vectors from the neighbours.
Vec3 node_length_weight_gradient(const ResponseObject& o, Index node) {
  const Vec3 p = o.positions->col(node);
  Vec3 sum = Vec3::Zero();
  for (const Index q : o.topology->node_adjacency.row(node)) {
    const Vec3 e = p - o.positions->col(q);
    const double len = e.norm();
    if (len > 0.0) sum += e / len;
  }
  return 0.5 * sum;
}

/// Integral over [l1, l2] of the product of two functions linear in lambda with values
/// (p1, p2) and (q1, q2) at the ends; delta = l2 - l1.
double integral2(double delta, double p1, double p2, double q1, double q2) {
  return delta * (2.0 * p1 * q1 + p1 * q2 + p2 * q1 + 2.0 * p2 * q2) / 6.0;
}

/// The face of a tet through which a segment with direction ab enters (entering == true:
/// the barycentric weight grows along ab) or leaves, at a point with barycentric
/// coordinates raw: the face of smallest |b_j| among those crossed the right way.
/// Returns -1 when none is crossed transversally.
int clip_face(const Vec4& raw, const std::array<Vec3, 4>& grads, const Vec3& ab, bool entering) {
  int best = -1;
  double best_value = std::numeric_limits<double>::infinity();
  for (int j = 0; j < 4; ++j) {
    const double s = grads[j].dot(ab);
    const bool transversal = std::abs(s) > 1e-12 * grads[j].norm() * ab.norm();
    if (!transversal || (entering ? s <= 0.0 : s >= 0.0)) continue;
    if (std::abs(raw[j]) < best_value) {
      best_value = std::abs(raw[j]);
      best = j;
    }
  }
  return best;
}

}  // namespace

std::vector<Index> node_components(const Topology& topology) {
  std::vector<Index> component(static_cast<std::size_t>(topology.num_nodes), -1);
  for (Index v = 0; v < topology.num_nodes && v < topology.node_tets.rows(); ++v)
    if (!topology.node_tets.row(v).empty())
      component[static_cast<std::size_t>(v)] =
          topology.tet_component[static_cast<std::size_t>(topology.node_tets.row(v)[0])];
  return component;
}

double node_length_weight(const ResponseObject& object, Index node) {
  const Vec3 p = object.positions->col(node);
  double sum = 0.0;
  for (const Index q : object.topology->node_adjacency.row(node))
    sum += (p - object.positions->col(q)).norm();
  return 0.5 * sum;
}

ContactResult point_contact(const ResponseObject& intruder, const ResponseObject& target,
                            const IntrudingNode& c, const ResponseOptions& options,
                            const Eigen::Vector3d& pair_direction) {
  ContactResult r;
  r.intruder_nodes = 1;
  r.node[0] = c.node;
  const Tet& tet = target.tets[static_cast<std::size_t>(c.tet)];
  const Vec3 p = intruder.positions->col(c.node);
  const TetData td = load_tet(target, c.tet);
  Vec4 beta = c.bary;
  if (!p.allFinite() || !td.finite || !normalize_weights(beta)) {
    r.skipped = true;
    return r;
  }
  r.inverted = td.frame.volume6 < 0.0;
  FaceHit hit;
  const Direction dir = direction_at(target, c.tet, td, p, options, pair_direction, hit,
                                     Exclusion::of(intruder, target, c.node, -1));
  r.fallback = dir.fallback;
  r.normal = dir.n;
  // The interpolation's own fallback keeps its depth where that is larger (a flat tet
  // inside a body has node depths but no volume); the default path uses the face alone.
  double depth = beta.dot(td.d);
  if (dir.from_face)
    depth = dir.fallback == Fallback::kNearestFace ? std::max(depth, std::sqrt(hit.sq_dist))
                                                   : std::sqrt(hit.sq_dist);
  depth = std::max(depth, 0.0);
  r.depth = depth;

  const bool by_length = options.measure == ForceMeasure::kEdgeLength;
  const double w = by_length ? node_length_weight(intruder, c.node) : 1.0;
  const double ce = options.stiffness * w;  // N/m: elastic coefficient of this node
  double m = ce * depth;
  const bool moving = intruder.velocities != nullptr || target.velocities != nullptr;
  const bool damped = options.damping > 0.0 && moving;
  const bool rubbing = options.friction > 0.0 && moving;
  Vec3 v = Vec3::Zero();  // v_rel: the node's velocity against the tet's at the node
  if (damped || rubbing) {
    v = velocity(intruder, c.node);
    for (int k = 0; k < 4; ++k) v -= beta[k] * velocity(target, tet[k]);
  }
  if (damped) m -= options.damping * w * dir.n.dot(v);
  if (!std::isfinite(m)) {
    r.skipped = true;
    return r;
  }
  if (!(m > 0.0)) return r;  // not in, or separating faster than the penalty pushes
  r.active = true;
  r.points = 1;
  r.bary[0] = beta;
  r.point_depth[0] = depth;
  Vec3 f = m * dir.n;
  r.push[0] = f.norm();
  Friction friction;
  if (rubbing) {
    friction = friction_at(options.friction, options.friction_velocity, r.push[0], dir.n, v);
    f += friction.force;
  }
  r.force[0] = f;
  r.target_nodes = options.push_point_only ? 0 : 4;
  for (int k = 0; k < r.target_nodes; ++k) {
    r.node[1 + k] = tet[k];
    r.force[1 + k] = -beta[k] * f;
  }
  if (options.stiffness_mode == StiffnessMode::kNone) return r;

  const Vec3& n = dir.n;
  const Mat3 nn = n * n.transpose();
  // df/dv, lumped as the kLumped stiffness: the tet's node k takes beta_k of it.
  r.damping[0] = friction.dv;
  if (damped) r.damping[0] -= options.damping * w * nn;
  for (int k = 0; k < r.target_nodes; ++k) r.damping[1 + k] = beta[k] * r.damping[0];
  if (options.stiffness_mode == StiffnessMode::kLumped || dir.gradient.isZero()) {
    r.stiffness[0] = -ce * dir.gamma * nn;
    for (int k = 0; k < r.target_nodes; ++k) r.stiffness[1 + k] = beta[k] * r.stiffness[0];
    return r;
  }
  // Exact diagonal blocks with the depth values held fixed (docs/RESPONSE.md).
  const Vec3& g = dir.gradient;
  r.stiffness[0] = ce * n * g.transpose();
  if (by_length)
    r.stiffness[0] +=
        options.stiffness * depth * n * node_length_weight_gradient(intruder, c.node).transpose();
  const std::array<Vec3, 4> grads = barycentric_gradients(td.frame);
  const Vec3 fe = ce * depth * n;
  const Mat3 tangential = Mat3::Identity() - nn;
  for (int k = 0; k < r.target_nodes; ++k)
    r.stiffness[1 + k] = beta[k] * fe * grads[k].transpose() +
                         beta[k] * beta[k] * ce * n * g.transpose() +
                         beta[k] * ce * depth * tangential * grads[k] * n.transpose();
  return r;
}

ContactResult segment_contact(const ResponseObject& intruder, const ResponseObject& target,
                              const IntrudingEdge& c, const ResponseOptions& options,
                              const Eigen::Vector3d& pair_direction) {
  ContactResult r;
  r.intruder_nodes = 2;
  const auto& edge = intruder.topology->edges[static_cast<std::size_t>(c.edge)];
  r.node[0] = edge[0];
  r.node[1] = edge[1];
  const Tet& tet = target.tets[static_cast<std::size_t>(c.tet)];
  const Vec3 a = intruder.positions->col(edge[0]);
  const Vec3 b = intruder.positions->col(edge[1]);
  const TetData td = load_tet(target, c.tet);
  if (!a.allFinite() || !b.allFinite() || !td.finite || !std::isfinite(c.lambda_in) ||
      !std::isfinite(c.lambda_out)) {
    r.skipped = true;
    return r;
  }
  const double l1 = std::clamp(c.lambda_in, 0.0, 1.0);
  const double l2 = std::clamp(c.lambda_out, 0.0, 1.0);
  if (!(l2 > l1)) return r;
  r.inverted = td.frame.volume6 < 0.0;
  const Vec3 ab = b - a;
  const Vec3 x1 = a + l1 * ab;
  const Vec3 x2 = a + l2 * ab;
  Vec4 raw1 = Vec4::Constant(0.25), raw2 = Vec4::Constant(0.25);
  if (td.frame.regular) {
    raw1 = barycentric(td.frame, x1);
    raw2 = barycentric(td.frame, x2);
  }
  Vec4 b1 = raw1, b2 = raw2;
  if (!normalize_weights(b1)) b1 = Vec4::Constant(0.25);
  if (!normalize_weights(b2)) b2 = Vec4::Constant(0.25);
  // One face for the whole piece: the nearest to its midpoint. Its plane gives the
  // depth at both clip points and its outward normal the direction, a linear depth field
  // like the interpolated one, which the two-point form below integrates exactly
  // (per-point nearest faces would switch along the piece near a convex edge and make
  // the force jump; docs/RESPONSE.md).
  const Vec3 mid = 0.5 * (x1 + x2);
  FaceHit hit;
  Direction dir = direction_at(target, c.tet, td, mid, options, pair_direction, hit,
                               Exclusion::of(intruder, target, edge[0], edge[1]));
  double d1 = b1.dot(td.d), d2 = b2.dot(td.d);
  if (dir.from_face) {
    const Vec3 normal = hit.normal;  // set with the direction: the face has an area
    if (!dir.forced) dir.n = normal;
    const double p1 = std::max(0.0, (hit.closest - x1).dot(normal));
    const double p2 = std::max(0.0, (hit.closest - x2).dot(normal));
    const bool keep = dir.fallback == Fallback::kNearestFace;  // as for point contacts
    d1 = keep ? std::max(d1, p1) : p1;
    d2 = keep ? std::max(d2, p2) : p2;
  }
  r.fallback = dir.fallback;
  r.normal = dir.n;
  r.depth = std::max({d1, d2, 0.0});

  const bool by_length = options.measure == ForceMeasure::kEdgeLength;
  const double len = ab.norm();
  const double ell = by_length ? len : 1.0;  // metres per unit lambda (or 1)
  const double delta = l2 - l1;
  const double clipped = ell * delta;  // L: the clipped measure
  if (!(clipped > 0.0)) return r;
  const double k = options.stiffness;
  double m1 = k * d1, m2 = k * d2;  // penalty density at the clip points
  const bool moving = intruder.velocities != nullptr || target.velocities != nullptr;
  const bool damped = options.damping > 0.0 && moving;
  const bool rubbing = options.friction > 0.0 && moving;
  Vec3 v1 = Vec3::Zero(), v2 = Vec3::Zero();  // relative velocities at the clip points
  if (damped || rubbing) {
    const Vec3 va = velocity(intruder, edge[0]), vb = velocity(intruder, edge[1]);
    v1 = (1.0 - l1) * va + l1 * vb;
    v2 = (1.0 - l2) * va + l2 * vb;
    for (int j = 0; j < 4; ++j) {
      const Vec3 vt = velocity(target, tet[j]);
      v1 -= b1[j] * vt;
      v2 -= b2[j] * vt;
    }
  }
  if (damped) {
    m1 -= options.damping * dir.n.dot(v1);
    m2 -= options.damping * dir.n.dot(v2);
  }
  if (!std::isfinite(m1) || !std::isfinite(m2)) {
    r.skipped = true;
    return r;
  }
  // Which densities the damping still moves (a clamped one does not).
  const double live1 = damped && m1 > 0.0 ? 1.0 : 0.0;
  const double live2 = damped && m2 > 0.0 ? 1.0 : 0.0;
  m1 = std::max(m1, 0.0);
  m2 = std::max(m2, 0.0);
  if (!(m1 > 0.0 || m2 > 0.0)) return r;
  r.active = true;
  r.points = 2;
  r.lambda = {l1, l2};
  r.bary = {b1, b2};
  r.point_depth = {std::max(d1, 0.0), std::max(d2, 0.0)};
  Vec3 f1 = clipped * (2.0 * m1 + m2) / 6.0 * dir.n;
  Vec3 f2 = clipped * (m1 + 2.0 * m2) / 6.0 * dir.n;
  Friction fr1, fr2;
  if (rubbing) {
    fr1 = friction_at(options.friction, options.friction_velocity, f1.norm(), dir.n, v1);
    fr2 = friction_at(options.friction, options.friction_velocity, f2.norm(), dir.n, v2);
  }
  r.force[0] = (1.0 - l1) * f1 + (1.0 - l2) * f2;
  r.force[1] = l1 * f1 + l2 * f2;
  r.push[0] = r.force[0].norm();
  r.push[1] = r.force[1].norm();
  if (rubbing) {
    f1 += fr1.force;
    f2 += fr2.force;
    r.force[0] = (1.0 - l1) * f1 + (1.0 - l2) * f2;
    r.force[1] = l1 * f1 + l2 * f2;
  }
  r.target_nodes = options.push_point_only ? 0 : 4;
  for (int j = 0; j < r.target_nodes; ++j) {
    r.node[2 + j] = tet[j];
    r.force[2 + j] = -(b1[j] * f1 + b2[j] * f2);
  }
  if (options.stiffness_mode == StiffnessMode::kNone) return r;

  const Vec3& n = dir.n;
  const Mat3 nn = n * n.transpose();
  // df/dv of the forces at the clip points under a velocity change shared by the
  // intruder's nodes (row sums, as kLumped), then moved like the forces.
  const Mat3 g1 = fr1.dv - options.damping * clipped * (2.0 * live1 + live2) / 6.0 * nn;
  const Mat3 g2 = fr2.dv - options.damping * clipped * (live1 + 2.0 * live2) / 6.0 * nn;
  r.damping[0] = (1.0 - l1) * g1 + (1.0 - l2) * g2;
  r.damping[1] = l1 * g1 + l2 * g2;
  for (int j = 0; j < r.target_nodes; ++j) r.damping[2 + j] = b1[j] * g1 + b2[j] * g2;
  const double kl = k * ell;
  if (options.stiffness_mode == StiffnessMode::kLumped || dir.gradient.isZero()) {
    const double scale = kl * dir.gamma;
    r.stiffness[0] = -scale * delta * (1.0 - 0.5 * (l1 + l2)) * nn;
    r.stiffness[1] = -scale * delta * 0.5 * (l1 + l2) * nn;
    for (int j = 0; j < r.target_nodes; ++j)
      r.stiffness[2 + j] = -scale * delta * 0.5 * (b1[j] + b2[j]) * nn;
    return r;
  }
  // Exact diagonal blocks with the depth values held fixed (docs/RESPONSE.md).
  const Vec3& g = dir.gradient;
  const Mat3 ng = n * g.transpose();
  const std::array<Vec3, 4> grads = barycentric_gradients(td.frame);
  r.stiffness[0] = kl * integral2(delta, 1.0 - l1, 1.0 - l2, 1.0 - l1, 1.0 - l2) * ng;
  r.stiffness[1] = kl * integral2(delta, l1, l2, l1, l2) * ng;
  if (by_length && len > 0.0) {
    const Vec3 unit = ab / len;
    r.stiffness[0] -= k * integral2(delta, d1, d2, 1.0 - l1, 1.0 - l2) * n * unit.transpose();
    r.stiffness[1] += k * integral2(delta, d1, d2, l1, l2) * n * unit.transpose();
  }
  // Clip limits that are face crossings move with a, b and the tet's nodes.
  const int j1 = l1 > 0.0 ? clip_face(raw1, grads, ab, true) : -1;
  const int j2 = l2 < 1.0 ? clip_face(raw2, grads, ab, false) : -1;
  Vec3 dl1 = Vec3::Zero(), dl2 = Vec3::Zero();  // grad b_j / (grad b_j . ab)
  if (j1 >= 0) dl1 = grads[j1] / grads[j1].dot(ab);
  if (j2 >= 0) dl2 = grads[j2] / grads[j2].dot(ab);
  // d lambda / d a = -(1 - lambda) dl, d lambda / d b = -lambda dl.
  r.stiffness[0] +=
      kl * n *
      (-(d2 * (1.0 - l2) * (1.0 - l2)) * dl2 + d1 * (1.0 - l1) * (1.0 - l1) * dl1).transpose();
  r.stiffness[1] += kl * n * (-(d2 * l2 * l2) * dl2 + d1 * l1 * l1 * dl1).transpose();
  const Mat3 tangential = Mat3::Identity() - nn;
  for (int j = 0; j < r.target_nodes; ++j) {
    const double ib = integral2(delta, d1, d2, b1[j], b2[j]);
    // d lambda / d x_j = b_j(x_clip) dl.
    const Vec3 limits = d2 * b2[j] * b2[j] * dl2 - d1 * b1[j] * b1[j] * dl1;
    r.stiffness[2 + j] =
        kl * (integral2(delta, b1[j], b2[j], b1[j], b2[j]) * ng + ib * n * grads[j].transpose() +
              ib * tangential * grads[j] * n.transpose() - n * limits.transpose());
  }
  return r;
}

}  // namespace tc
