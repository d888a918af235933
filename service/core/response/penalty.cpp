#include "core/response/penalty.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/mesh/geometry.hpp"
#include "core/response/tet_frame.hpp"

namespace tc {
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

/// Squared distance from p to the triangle (a, b, c) (Ericson, Real-Time Collision
/// Detection, 5.1.5: closest point by Voronoi regions).
double point_triangle_distance2(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return ap.squaredNorm();
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return bp.squaredNorm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    return (ap - v * ab).squaredNorm();
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return cp.squaredNorm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double w = d2 / (d2 - d6);
    return (ap - w * ac).squaredNorm();
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return (bp - w * (c - b)).squaredNorm();
  }
  const double denom = va + vb + vc;
  if (!(std::abs(denom) > 0.0)) return ap.squaredNorm();
  const double v = vb / denom, w = vc / denom;
  return (ap - v * ab - w * ac).squaredNorm();
}

/// The push-out direction of a contact at point x in tet t of the penetrated object.
struct Direction {
  Vec3 n = Vec3::UnitZ();        ///< unit push-out direction of the intruder
  Vec3 gradient = Vec3::Zero();  ///< grad d (regular path only)
  double gamma = 1.0;            ///< |grad d| for the blocks; 1 on fallbacks
  Fallback fallback = Fallback::kNone;
  bool has_plane = false;  ///< a boundary face plane also gives a depth
  Vec3 plane_point = Vec3::Zero();

  /// Depth of x below the face plane (>= 0), metres.
  [[nodiscard]] double plane_depth(const Vec3& x) const {
    return has_plane ? std::max(0.0, (plane_point - x).dot(n)) : 0.0;
  }
};

/// Outward unit normal of face j of a tet with the given orientation sign (+1 or -1);
/// false when the face has no area.
bool face_normal(const Positions& pos, const Tet& tet, int j, double orientation, Vec3& normal,
                 std::array<Vec3, 3>& corners) {
  for (int i = 0; i < 3; ++i) corners[i] = pos.col(tet[kTetFaces[j][i]]);
  const Vec3 e1 = corners[1] - corners[0], e2 = corners[2] - corners[0];
  const Vec3 cross = e1.cross(e2);
  const double norm = cross.norm();
  if (!(norm > 1e-14 * e1.norm() * e2.norm()) || !std::isfinite(norm)) return false;
  normal = orientation * cross / norm;
  return true;
}

double orientation_of(double volume6) {
  return volume6 < 0.0 ? -1.0 : 1.0;
}

/// The fallback chain of docs/RESPONSE.md, section "Degenerate gradients".
Direction fallback_direction(const ResponseObject& y, Index t, const TetData& td, const Vec3& x,
                             const Vec3& pair_direction) {
  Direction dir;
  if (y.topology != nullptr) {
    const Topology& topo = *y.topology;
    const Tet& tet = y.tets[static_cast<std::size_t>(t)];
    std::array<Vec3, 3> corners;
    Vec3 normal;
    // Near-ties go to the first candidate, so rounding (scale, offset) cannot flip the
    // choice between faces that are equally near.
    double size = 0.0;
    for (const auto& e : kTetEdges) size = std::max(size, (td.x[e[0]] - td.x[e[1]]).norm());
    const double tie = 1e-9 * size;
    // 1. The tet's own boundary faces: the nearest face plane.
    double best = std::numeric_limits<double>::infinity();
    const double own_orientation = orientation_of(td.frame.volume6);
    for (int j = 0; j < 4; ++j) {
      if (topo.tet_neighbors[static_cast<std::size_t>(t)][j] != -1) continue;
      if (!face_normal(*y.positions, tet, j, own_orientation, normal, corners)) continue;
      const double inward = (corners[0] - x).dot(normal);
      if (inward < best - tie) {
        best = inward;
        dir.n = normal;
        dir.plane_point = corners[0];
        dir.has_plane = true;
        dir.fallback = Fallback::kOwnFace;
      }
    }
    if (dir.has_plane) return dir;
    // 2. Boundary faces of the tets sharing a node with t: the nearest triangle.
    std::vector<Index> ring;
    for (int k = 0; k < 4; ++k)
      for (const Index s : topo.node_tets.row(tet[k]))
        if (s != t) ring.push_back(s);
    std::sort(ring.begin(), ring.end());
    ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
    best = std::numeric_limits<double>::infinity();
    for (const Index s : ring) {
      const Tet& other = y.tets[static_cast<std::size_t>(s)];
      const double orientation = orientation_of(signed_volume(*y.positions, other));
      for (int j = 0; j < 4; ++j) {
        if (topo.tet_neighbors[static_cast<std::size_t>(s)][j] != -1) continue;
        if (!face_normal(*y.positions, other, j, orientation, normal, corners)) continue;
        const double dist =
            std::sqrt(point_triangle_distance2(x, corners[0], corners[1], corners[2]));
        if (dist < best - tie) {
          best = dist;
          dir.n = normal;
          dir.plane_point = corners[0];
          dir.has_plane = true;
          dir.fallback = Fallback::kRingFace;
        }
      }
    }
    if (dir.has_plane) return dir;
  }
  // 3. Away from Y's contact region towards X's; 4. a fixed axis.
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
                       const ResponseOptions& o, const Vec3& pair_direction) {
  if (td.frame.regular) {
    const Vec3 g = linear_gradient(td.frame, td.d);
    const double norm = g.norm();
    if (std::isfinite(norm) && norm >= o.min_gradient && norm <= o.max_gradient && norm > 0.0) {
      Direction dir;
      dir.n = -g / norm;
      dir.gradient = g;
      dir.gamma = norm;
      return dir;
    }
  }
  return fallback_direction(y, t, td, x, pair_direction);
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
  const Direction dir = direction_at(target, c.tet, td, p, options, pair_direction);
  r.fallback = dir.fallback;
  r.normal = dir.n;
  double depth = beta.dot(td.d);
  if (dir.has_plane) depth = std::max(depth, dir.plane_depth(p));
  r.depth = std::max(depth, 0.0);

  const bool by_length = options.measure == ForceMeasure::kEdgeLength;
  const double w = by_length ? node_length_weight(intruder, c.node) : 1.0;
  const double ce = options.stiffness * w;  // N/m: elastic coefficient of this node
  double m = ce * depth;
  if (options.damping > 0.0 && (intruder.velocities != nullptr || target.velocities != nullptr)) {
    Vec3 v = velocity(intruder, c.node);
    for (int k = 0; k < 4; ++k) v -= beta[k] * velocity(target, tet[k]);
    m -= options.damping * w * dir.n.dot(v);
  }
  if (!std::isfinite(m)) {
    r.skipped = true;
    return r;
  }
  if (!(m > 0.0)) return r;  // not in, or separating faster than the penalty pushes
  r.active = true;
  const Vec3 f = m * dir.n;
  r.force[0] = f;
  r.target_nodes = options.push_point_only ? 0 : 4;
  for (int k = 0; k < r.target_nodes; ++k) {
    r.node[1 + k] = tet[k];
    r.force[1 + k] = -beta[k] * f;
  }
  if (options.stiffness_mode == StiffnessMode::kNone) return r;

  const Vec3& n = dir.n;
  const Mat3 nn = n * n.transpose();
  if (options.stiffness_mode == StiffnessMode::kLumped || dir.fallback != Fallback::kNone) {
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
  double d1 = b1.dot(td.d), d2 = b2.dot(td.d);
  const Direction dir = direction_at(target, c.tet, td, 0.5 * (x1 + x2), options, pair_direction);
  r.fallback = dir.fallback;
  r.normal = dir.n;
  if (dir.has_plane) {
    d1 = std::max(d1, dir.plane_depth(x1));
    d2 = std::max(d2, dir.plane_depth(x2));
  }
  r.depth = std::max({d1, d2, 0.0});

  const bool by_length = options.measure == ForceMeasure::kEdgeLength;
  const double len = ab.norm();
  const double ell = by_length ? len : 1.0;  // metres per unit lambda (or 1)
  const double delta = l2 - l1;
  const double clipped = ell * delta;  // L: the clipped measure
  if (!(clipped > 0.0)) return r;
  const double k = options.stiffness;
  double m1 = k * d1, m2 = k * d2;  // penalty density at the clip points
  if (options.damping > 0.0 && (intruder.velocities != nullptr || target.velocities != nullptr)) {
    const Vec3 va = velocity(intruder, edge[0]), vb = velocity(intruder, edge[1]);
    Vec3 v1 = (1.0 - l1) * va + l1 * vb, v2 = (1.0 - l2) * va + l2 * vb;
    for (int j = 0; j < 4; ++j) {
      const Vec3 vt = velocity(target, tet[j]);
      v1 -= b1[j] * vt;
      v2 -= b2[j] * vt;
    }
    m1 -= options.damping * dir.n.dot(v1);
    m2 -= options.damping * dir.n.dot(v2);
  }
  if (!std::isfinite(m1) || !std::isfinite(m2)) {
    r.skipped = true;
    return r;
  }
  m1 = std::max(m1, 0.0);
  m2 = std::max(m2, 0.0);
  if (!(m1 > 0.0 || m2 > 0.0)) return r;
  r.active = true;
  const Vec3 f1 = clipped * (2.0 * m1 + m2) / 6.0 * dir.n;
  const Vec3 f2 = clipped * (m1 + 2.0 * m2) / 6.0 * dir.n;
  r.force[0] = (1.0 - l1) * f1 + (1.0 - l2) * f2;
  r.force[1] = l1 * f1 + l2 * f2;
  r.target_nodes = options.push_point_only ? 0 : 4;
  for (int j = 0; j < r.target_nodes; ++j) {
    r.node[2 + j] = tet[j];
    r.force[2 + j] = -(b1[j] * f1 + b2[j] * f2);
  }
  if (options.stiffness_mode == StiffnessMode::kNone) return r;

  const Vec3& n = dir.n;
  const Mat3 nn = n * n.transpose();
  const double kl = k * ell;
  if (options.stiffness_mode == StiffnessMode::kLumped || dir.fallback != Fallback::kNone) {
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
