#include "core/response/response.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>

#include "core/mesh/geometry.hpp"

namespace tc {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

Error invalid(std::string message) {
  return Error{ErrorCode::kInvalidArgument, std::move(message)};
}

std::string range_text(Index value, std::size_t size) {
  return std::to_string(value) + " out of range [0, " + std::to_string(size) + ")";
}

Status validate_object(const ResponseObject& o, const char* name) {
  const std::string who = std::string("response: object ") + name;
  if (o.positions == nullptr || o.topology == nullptr)
    return invalid(who + ": positions and topology are required");
  const auto n = static_cast<std::size_t>(o.positions->cols());
  if (static_cast<std::size_t>(o.topology->num_nodes) != n)
    return invalid(who + ": topology has " + std::to_string(o.topology->num_nodes) +
                   " nodes, positions have " + std::to_string(n));
  if (o.is_surface()) {
    if (o.topology->num_tets != 0 || !o.topology->tet_neighbors.empty())
      return invalid(who +
                     ": a surface's topology has no tets (build_edge_topology), this one has " +
                     std::to_string(o.topology->num_tets));
    if (!o.depth.empty() || !o.anchor.empty())
      return invalid(who + ": a surface has no depth map, but depth has " +
                     std::to_string(o.depth.size()) + " values and anchor " +
                     std::to_string(o.anchor.size()));
  } else {
    if (static_cast<std::size_t>(o.topology->num_tets) != o.tets.size() ||
        o.topology->tet_neighbors.size() != o.tets.size())
      return invalid(who + ": topology has " + std::to_string(o.topology->num_tets) +
                     " tets, the tet list has " + std::to_string(o.tets.size()));
    if (o.depth.size() != n)
      return invalid(who + ": depth has " + std::to_string(o.depth.size()) + " values for " +
                     std::to_string(n) + " nodes");
  }
  if (!o.anchor.empty() && o.anchor.size() != n)
    return invalid(who + ": anchor has " + std::to_string(o.anchor.size()) + " values for " +
                   std::to_string(n) + " nodes");
  if (o.velocities != nullptr && static_cast<std::size_t>(o.velocities->cols()) != n)
    return invalid(who + ": velocities have " + std::to_string(o.velocities->cols()) +
                   " columns for " + std::to_string(n) + " nodes");
  return {};
}

Status validate_options(const ResponseOptions& o) {
  const auto bad = [](double v) { return !std::isfinite(v) || v < 0.0; };
  if (bad(o.stiffness)) return invalid("response: stiffness must be finite and >= 0");
  if (bad(o.damping)) return invalid("response: damping must be finite and >= 0");
  if (bad(o.friction)) return invalid("response: friction must be finite and >= 0");
  if (!(o.friction_velocity > 0.0) || !std::isfinite(o.friction_velocity))
    return invalid("response: friction_velocity must be finite and > 0");
  if (bad(o.auto_threshold)) return invalid("response: auto_threshold must be finite and >= 0");
  if (o.decided_kinds)
    for (const ResponseKind k : *o.decided_kinds)
      if (k != ResponseKind::kPoint && k != ResponseKind::kSegment)
        return invalid("response: decided_kinds must be point or segment");
  if (bad(o.min_gradient) || !(o.max_gradient > o.min_gradient) || std::isnan(o.max_gradient))
    return invalid("response: need 0 <= min_gradient < max_gradient");
  return {};
}

/// Marked cells of an object: its triangles for a surface, else its tets.
Status validate_marked(std::span<const Index> marked, const ResponseObject& o, const char* list) {
  const std::size_t cells = o.is_surface() ? o.triangles.size() : o.tets.size();
  const char* noun = o.is_surface() ? "]: triangle " : "]: tet ";
  for (std::size_t i = 0; i < marked.size(); ++i)
    if (marked[i] < 0 || static_cast<std::size_t>(marked[i]) >= cells)
      return invalid(std::string("response: ") + list + "[" + std::to_string(i) + noun +
                     range_text(marked[i], cells));
  return {};
}

std::string where(const char* list, std::size_t i) {
  return std::string("response: ") + list + "[" + std::to_string(i) + "]: ";
}

Status validate_nodes(std::span<const IntrudingNode> list, std::size_t nodes, std::size_t tets,
                      const char* name) {
  for (std::size_t i = 0; i < list.size(); ++i) {
    if (list[i].node < 0 || static_cast<std::size_t>(list[i].node) >= nodes)
      return invalid(where(name, i) + "node " + range_text(list[i].node, nodes));
    if (list[i].tet < 0 || static_cast<std::size_t>(list[i].tet) >= tets)
      return invalid(where(name, i) + "tet " + range_text(list[i].tet, tets));
  }
  return {};
}

Status validate_edges(std::span<const IntrudingEdge> list, std::size_t edges, std::size_t tets,
                      const char* name) {
  constexpr double kSlack = 1e-6;  // detection's rounding on lambda
  for (std::size_t i = 0; i < list.size(); ++i) {
    const IntrudingEdge& e = list[i];
    if (e.edge < 0 || static_cast<std::size_t>(e.edge) >= edges)
      return invalid(where(name, i) + "edge " + range_text(e.edge, edges));
    if (e.tet < 0 || static_cast<std::size_t>(e.tet) >= tets)
      return invalid(where(name, i) + "tet " + range_text(e.tet, tets));
    // Non-finite lambdas are skipped with a count; finite ones must be ordered in [0, 1].
    if (std::isfinite(e.lambda_in) && std::isfinite(e.lambda_out) &&
        (e.lambda_in < -kSlack || e.lambda_out > 1.0 + kSlack ||
         e.lambda_in > e.lambda_out + kSlack))
      return invalid(where(name, i) + "need 0 <= lambda_in <= lambda_out <= 1, got [" +
                     std::to_string(e.lambda_in) + ", " + std::to_string(e.lambda_out) + "]");
  }
  return {};
}

/// Box, centre and (when asked) RMS edge length of an object's contact cells (tets, or
/// triangles of a surface).
struct ContactRegion {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());
  Vec3 centre = Vec3::Zero();
  double rms_edge = 0.0;
  bool empty = true;
};

/// K = 4 (tets) or 3 (triangles); the edges are the K (K - 1) / 2 corner pairs (i < j)
/// in kTetEdges' order.
template <std::size_t K>
ContactRegion contact_region_of(const Positions& positions,
                                std::span<const std::array<Index, K>> cells,
                                std::span<const Index> marked, bool edges) {
  constexpr std::size_t kEdges = K * (K - 1) / 2;
  ContactRegion region;
  // Estimates, not exact values: a deterministic stride over at most ~1024 tets for the
  // box and centre and ~256 for the RMS edge length keeps this pass cheaper than the
  // contacts themselves on large contacts (every marked tet of a fine mesh otherwise).
  const std::size_t box_stride = std::max<std::size_t>(1, marked.size() / 1024);
  const std::size_t stride = std::max<std::size_t>(1, marked.size() / 256);
  double edge_sum = 0.0;
  std::size_t count = 0, edge_cells = 0;
  for (std::size_t i = 0; i < marked.size(); i += box_stride) {
    const std::array<Index, K>& cell = cells[static_cast<std::size_t>(marked[i])];
    std::array<Vec3, K> x;
    for (std::size_t k = 0; k < K; ++k) x[k] = positions.col(cell[k]);
    Vec3 sum = x[0];
    for (std::size_t k = 1; k < K; ++k) sum += x[k];
    if (!sum.allFinite()) continue;
    for (std::size_t k = 0; k < K; ++k) {  // min and max are exact: any order
      region.lo = region.lo.cwiseMin(x[k]);
      region.hi = region.hi.cwiseMax(x[k]);
    }
    region.centre += (1.0 / static_cast<double>(K)) * sum;
    ++count;
    if (edges && (i / box_stride) % std::max<std::size_t>(1, stride / box_stride) == 0) {
      for (std::size_t j = 0; j < K; ++j)
        for (std::size_t k = j + 1; k < K; ++k) edge_sum += (x[j] - x[k]).squaredNorm();
      ++edge_cells;
    }
  }
  if (count > 0) {
    region.empty = false;
    region.centre /= static_cast<double>(count);
  }
  if (edge_cells > 0)
    region.rms_edge = std::sqrt(edge_sum / (static_cast<double>(kEdges * edge_cells)));
  return region;
}

ContactRegion contact_region(const ResponseObject& o, std::span<const Index> marked, bool edges) {
  if (o.is_surface()) return contact_region_of<3>(*o.positions, o.triangles, marked, edges);
  return contact_region_of<4>(*o.positions, o.tets, marked, edges);
}

ContactDensity density_of(const ContactRegion& x, const ContactRegion& y) {
  ContactDensity density;
  density.rms_edge = x.rms_edge;
  if (!x.empty && !y.empty) {
    const Vec3 lo = x.lo.cwiseMax(y.lo), hi = x.hi.cwiseMin(y.hi);
    density.contact_extent = (hi - lo).cwiseMax(0.0).norm();
  }
  return density;
}

}  // namespace

void ResponseStats::add(const ResponseStats& other) {
  point_contacts += other.point_contacts;
  segment_contacts += other.segment_contacts;
  inactive += other.inactive;
  skipped += other.skipped;
  inverted += other.inverted;
  fallback_nearest_face += other.fallback_nearest_face;
  fallback_gradient += other.fallback_gradient;
  symmetric_pairs += other.symmetric_pairs;
  fallback_pair += other.fallback_pair;
  fallback_axis += other.fallback_axis;
  max_depth = std::max(max_depth, other.max_depth);
}

ContactDensity measure_contact_density(const ResponseObject& x, std::span<const Index> marked_x,
                                       const ResponseObject& y, std::span<const Index> marked_y) {
  return density_of(contact_region(x, marked_x, true), contact_region(y, marked_y, false));
}

std::array<ResponseKind, 2> response_kinds(const ResponseObject& a, std::span<const Index> marked_a,
                                           const ResponseObject& b, std::span<const Index> marked_b,
                                           const ResponseOptions& options) {
  if (options.kind != ResponseKind::kAuto) return {options.kind, options.kind};
  // kAuto measures the contact regions; other kinds skip that work.
  const ContactRegion region_a = contact_region(a, marked_a, true);
  const ContactRegion region_b = contact_region(b, marked_b, true);
  return {
      choose_response_kind(options.kind, density_of(region_a, region_b), options.auto_threshold),
      choose_response_kind(options.kind, density_of(region_b, region_a), options.auto_threshold)};
}

ResponseKind choose_response_kind(ResponseKind requested, const ContactDensity& density,
                                  double threshold) {
  if (requested != ResponseKind::kAuto) return requested;
  return density.rms_edge > threshold * density.contact_extent ? ResponseKind::kSegment
                                                               : ResponseKind::kPoint;
}

void ResponseAccumulator::NodeSums::prepare(Index n, bool blocks) {
  const auto size = static_cast<std::size_t>(n);
  if (force.size() < size) {
    force.resize(size, Vec3::Zero());
    used.resize(size, 0);
  }
  if (blocks && stiffness.size() < force.size()) {
    stiffness.resize(force.size(), Mat3::Zero());
    damping.resize(force.size(), Mat3::Zero());
  }
  touched.clear();
}

void ResponseAccumulator::NodeSums::add(Index node, const Vec3& f, const Mat3* k, const Mat3* d) {
  const auto i = static_cast<std::size_t>(node);
  if (used[i] == 0) {
    used[i] = 1;
    touched.push_back(node);
  }
  force[i] += f;
  if (k != nullptr) {
    stiffness[i] += *k;
    damping[i] += *d;
  }
}

double ResponseAccumulator::NodeSums::magnitude() const {
  double sum = 0.0;
  for (const Index node : touched) sum += force[static_cast<std::size_t>(node)].norm();
  return sum;
}

void ResponseAccumulator::NodeSums::clear() {
  for (const Index node : touched) {
    const auto i = static_cast<std::size_t>(node);
    force[i].setZero();
    if (i < stiffness.size()) {
      stiffness[i].setZero();
      damping[i].setZero();
    }
    used[i] = 0;
  }
  touched.clear();
}

void ResponseAccumulator::NodeSums::extract(ObjectForces& out, bool blocks) {
  std::sort(touched.begin(), touched.end());
  out.nodes = touched;
  out.forces.resize(touched.size());
  out.stiffness.resize(blocks ? touched.size() : 0);
  out.damping.resize(blocks ? touched.size() : 0);
  for (std::size_t j = 0; j < touched.size(); ++j) {
    const auto i = static_cast<std::size_t>(touched[j]);
    out.forces[j] = force[i];
    force[i].setZero();
    if (blocks) {
      out.stiffness[j] = stiffness[i];
      stiffness[i].setZero();
      out.damping[j] = damping[i];
      damping[i].setZero();
    }
    used[i] = 0;
  }
  touched.clear();
}

Status ResponseAccumulator::compute(const ResponseObject& a, const ResponseObject& b,
                                    const PairContacts& contacts, const ResponseOptions& options,
                                    PairResponse& out) {
  // Reset without freeing: a reused PairResponse keeps its capacity across frames.
  for (ObjectForces* f : {&out.a, &out.b}) {
    f->nodes.clear();
    f->forces.clear();
    f->stiffness.clear();
    f->damping.clear();
  }
  out.used_a_in_b = out.used_b_in_a = ResponseKind::kPoint;
  out.stats = ResponseStats{};
  out.point_contacts.clear();
  out.contacts.clear();
  if (Status s = validate_options(options); !s) return s;
  if (Status s = validate_object(a, "A"); !s) return s;
  if (Status s = validate_object(b, "B"); !s) return s;
  const bool blocks = options.stiffness_mode != StiffnessMode::kNone;
  if (contacts.nodes_a_in_b.empty() && contacts.nodes_b_in_a.empty() &&
      contacts.edges_a_in_b.empty() && contacts.edges_b_in_a.empty())
    return {};  // no overlap: nothing to do
  if (a.is_surface() && b.is_surface())
    return invalid("response: A and B are both surfaces: two surfaces are never tested");
  // A surface has no depth map: nothing can be pushed out of it.
  if (a.is_surface() && !(contacts.nodes_b_in_a.empty() && contacts.edges_b_in_a.empty()))
    return invalid("response: A is a surface (no depth map), but B has nodes or edges in it");
  if (b.is_surface() && !(contacts.nodes_a_in_b.empty() && contacts.edges_a_in_b.empty()))
    return invalid("response: B is a surface (no depth map), but A has nodes or edges in it");
  if (Status s = validate_marked(contacts.marked_a, a, "marked_a"); !s) return s;
  if (Status s = validate_marked(contacts.marked_b, b, "marked_b"); !s) return s;

  const std::array<ResponseKind, 2> kinds =
      options.decided_kinds ? *options.decided_kinds
                            : response_kinds(a, contacts.marked_a, b, contacts.marked_b, options);
  out.used_a_in_b = kinds[0];
  out.used_b_in_a = kinds[1];
  const bool seg_ab = out.used_a_in_b == ResponseKind::kSegment;
  const bool seg_ba = out.used_b_in_a == ResponseKind::kSegment;
  const std::size_t n_a = static_cast<std::size_t>(a.positions->cols());
  const std::size_t n_b = static_cast<std::size_t>(b.positions->cols());
  Status s = seg_ab ? validate_edges(contacts.edges_a_in_b, a.topology->edges.size(), b.tets.size(),
                                     "edges_a_in_b")
                    : validate_nodes(contacts.nodes_a_in_b, n_a, b.tets.size(), "nodes_a_in_b");
  if (!s) return s;
  s = seg_ba ? validate_edges(contacts.edges_b_in_a, b.topology->edges.size(), a.tets.size(),
                              "edges_b_in_a")
             : validate_nodes(contacts.nodes_b_in_a, n_b, a.tets.size(), "nodes_b_in_a");
  if (!s) return s;
  if (options.record_contacts) {  // the record reads the node lists of both directions
    if (seg_ab) s = validate_nodes(contacts.nodes_a_in_b, n_a, b.tets.size(), "nodes_a_in_b");
    if (!s) return s;
    if (seg_ba) s = validate_nodes(contacts.nodes_b_in_a, n_b, a.tets.size(), "nodes_b_in_a");
    if (!s) return s;
  }

  // Fallback direction 3, from B's contact centre towards A's: computed on first need
  // (a contact whose gradient and boundary faces both failed), then reused.
  bool have_pair_direction = false;
  Vec3 dir_ab = Vec3::Zero();
  const auto pair_direction = [&]() -> const Vec3& {
    if (!have_pair_direction) {
      have_pair_direction = true;
      const ContactRegion region_a = contact_region(a, contacts.marked_a, false);
      const ContactRegion region_b = contact_region(b, contacts.marked_b, false);
      if (!region_a.empty && !region_b.empty) {
        const Vec3 d = region_a.centre - region_b.centre;
        const double scale =
            std::max((region_a.hi - region_a.lo).norm(), (region_b.hi - region_b.lo).norm());
        if (d.norm() > 1e-9 * scale && d.allFinite()) dir_ab = d.normalized();
      }
    }
    return dir_ab;
  };

  sums_a_.prepare(a.positions->cols(), blocks);
  sums_b_.prepare(b.positions->cols(), blocks);
  ResponseStats& st = out.stats;
  // What the symmetric-overlap check reads: the pushes' magnitudes, by direction.
  double push_sum = 0.0;
  std::size_t active_ab = 0, active_ba = 0;
  const ResponseOptions* opt = &options;  // the pass's options (the separating pass's)
  Vec3 forced = Vec3::Zero();             // the separating pass's direction for A

  const auto record = [&](const IntrudingNode& c, const ContactResult& r, bool intruder_is_a) {
    if (r.active && !r.skipped)
      out.point_contacts.push_back({intruder_is_a, c.node, c.tet, r.depth, r.normal, r.fallback});
  };
  // The rows of ResponseOptions::report_contacts: the points behind one contact's forces.
  const auto report = [&](Index tet, const ContactResult& r, bool intruder_is_a) {
    if (!r.active || r.skipped) return;
    for (int i = 0; i < r.points; ++i) {
      ContactRow row;
      row.intruder_is_a = intruder_is_a;
      row.nodes = {r.node[0], r.intruder_nodes == 2 ? r.node[1] : Index{-1}};
      row.weights = {1.0 - r.lambda[i], r.lambda[i]};
      row.tet = tet;
      row.bary = r.bary[i];
      row.depth = r.point_depth[i];
      row.normal = r.normal;
      out.contacts.push_back(row);
    }
  };
  const auto accumulate = [&](const ContactResult& r, bool segment, NodeSums& xs, NodeSums& ys) {
    if (r.skipped) {
      ++st.skipped;
      return;
    }
    if (r.inverted) ++st.inverted;
    if (!r.active) {
      ++st.inactive;
      return;
    }
    ++(segment ? st.segment_contacts : st.point_contacts);
    switch (r.fallback) {
      case Fallback::kNone:
        break;
      case Fallback::kNearestFace:
        ++st.fallback_nearest_face;
        break;
      case Fallback::kGradient:
        ++st.fallback_gradient;
        break;
      case Fallback::kPairDirection:
        ++st.fallback_pair;
        break;
      case Fallback::kAxis:
        ++st.fallback_axis;
        break;
    }
    st.max_depth = std::max(st.max_depth, r.depth);
    ++(&xs == &sums_a_ ? active_ab : active_ba);
    for (int i = 0; i < r.intruder_nodes; ++i) {
      push_sum += r.push[i];
      xs.add(r.node[i], r.force[i], blocks ? &r.stiffness[i] : nullptr,
             blocks ? &r.damping[i] : nullptr);
    }
    for (int j = 0; j < r.target_nodes; ++j) {
      const int e = r.intruder_nodes + j;
      ys.add(r.node[e], r.force[e], blocks ? &r.stiffness[e] : nullptr,
             blocks ? &r.damping[e] : nullptr);
    }
  };
  // Per-contact work, in parallel for large lists; the sums always run in list order.
  // Kernels first run without the pair direction; the rare contact that needs it
  // (fallback kAxis) is redone with it, in the ordered pass.
  const auto run = [&](const auto& list, bool segment, const ResponseObject& x,
                       const ResponseObject& y, NodeSums& xs, NodeSums& ys, double sign) {
    const auto kernel = [&](const auto& c, const Vec3& dir) {
      if constexpr (std::is_same_v<std::decay_t<decltype(c)>, IntrudingEdge>)
        return segment_contact(x, y, c, *opt, dir);
      else
        return point_contact(x, y, c, *opt, dir);
    };
    const auto finish = [&](const auto& c, const ContactResult& r) {
      ContactResult redone;
      const ContactResult* used = &r;
      if (r.fallback == Fallback::kAxis && !r.skipped) {
        const Vec3 dir = sign * pair_direction();
        if (!dir.isZero()) {
          redone = kernel(c, dir);
          used = &redone;
        }
      }
      accumulate(*used, segment, xs, ys);
      if (options.report_contacts) report(c.tet, *used, sign > 0.0);
      if constexpr (std::is_same_v<std::decay_t<decltype(c)>, IntrudingNode>)
        if (options.record_contacts) record(c, *used, sign > 0.0);
    };
    const Vec3 none = sign * forced;
    if (list.size() >= std::max<std::size_t>(options.parallel_threshold, 1)) {
      results_.resize(list.size());
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, list.size(), 16),
                        [&](const tbb::blocked_range<std::size_t>& range) {
                          for (std::size_t i = range.begin(); i != range.end(); ++i)
                            results_[i] = kernel(list[i], none);
                        });
      for (std::size_t i = 0; i < list.size(); ++i) finish(list[i], results_[i]);
    } else {
      for (const auto& c : list) finish(c, kernel(c, none));
    }
  };
  // The record of a direction answered by segments: its point contacts, forces unused.
  const auto record_points = [&](std::span<const IntrudingNode> list, const ResponseObject& x,
                                 const ResponseObject& y, double sign) {
    for (const IntrudingNode& c : list) {
      ContactResult r = point_contact(x, y, c, *opt, sign * forced);
      if (r.fallback == Fallback::kAxis && !r.skipped) {
        const Vec3 dir = sign * pair_direction();
        if (!dir.isZero()) r = point_contact(x, y, c, *opt, dir);
      }
      record(c, r, sign > 0.0);
    }
  };
  const auto pass = [&] {
    if (seg_ab)
      run(contacts.edges_a_in_b, true, a, b, sums_a_, sums_b_, 1.0);
    else
      run(contacts.nodes_a_in_b, false, a, b, sums_a_, sums_b_, 1.0);
    if (seg_ba)
      run(contacts.edges_b_in_a, true, b, a, sums_b_, sums_a_, -1.0);
    else
      run(contacts.nodes_b_in_a, false, b, a, sums_b_, sums_a_, -1.0);
  };
  pass();
  // Symmetric overlap (docs/RESPONSE.md "Coincident and symmetric overlaps"): when both
  // objects push into each other and the pushes cancel node by node (two copies of one
  // mesh at one place: each node's push is undone by the reaction of its twin), the
  // depth directions cannot separate them. The pair is answered again with every
  // contact along one separating direction: from B's contact region towards A's, or,
  // where the two centres coincide, +x, +y or +z, whichever the overlap is thinnest in.
  if (options.symmetric_ratio > 0.0 && active_ab > 0 && active_ba > 0 &&
      sums_a_.magnitude() + sums_b_.magnitude() < options.symmetric_ratio * push_sum) {
    Vec3 u = pair_direction();
    if (u.isZero()) {
      const ContactRegion ra = contact_region(a, contacts.marked_a, false);
      const ContactRegion rb = contact_region(b, contacts.marked_b, false);
      const Vec3 extent = ra.hi.cwiseMin(rb.hi) - ra.lo.cwiseMax(rb.lo);
      Eigen::Index axis = 0;
      if (extent.allFinite()) extent.minCoeff(&axis);
      u = Vec3::Unit(axis);
    }
    ResponseOptions separating = options;
    separating.along_pair_direction = true;
    opt = &separating;
    forced = u;
    sums_a_.clear();
    sums_b_.clear();
    const ResponseKind used_ab = out.used_a_in_b, used_ba = out.used_b_in_a;
    st = ResponseStats{};
    out.point_contacts.clear();
    out.contacts.clear();
    out.used_a_in_b = used_ab;
    out.used_b_in_a = used_ba;
    st.symmetric_pairs = 1;
    pass();
  }
  if (options.record_contacts) {
    if (seg_ab) record_points(contacts.nodes_a_in_b, a, b, 1.0);
    if (seg_ba) record_points(contacts.nodes_b_in_a, b, a, -1.0);
  }

  sums_a_.extract(out.a, blocks);
  sums_b_.extract(out.b, blocks);
  return {};
}

Expected<PairResponse> compute_pair_response(const ResponseObject& a, const ResponseObject& b,
                                             const PairContacts& contacts,
                                             const ResponseOptions& options) {
  ResponseAccumulator accumulator;
  PairResponse out;
  if (Status s = accumulator.compute(a, b, contacts, options, out); !s) return s.error();
  return out;
}

void add_object_forces(ObjectForces& total, const ObjectForces& part) {
  if (part.nodes.empty()) return;
  const bool blocks = !part.stiffness.empty() && (total.nodes.empty() || !total.stiffness.empty());
  ObjectForces merged;
  merged.object = total.object;
  merged.nodes.reserve(total.nodes.size() + part.nodes.size());
  merged.forces.reserve(merged.nodes.capacity());
  if (blocks) {
    merged.stiffness.reserve(merged.nodes.capacity());
    merged.damping.reserve(merged.nodes.capacity());
  }
  std::size_t i = 0, j = 0;
  const auto block_of = [](const std::vector<Mat3>& b, std::size_t k) {
    return b.empty() ? Mat3::Zero().eval() : b[k];
  };
  // Appends entry k of `from` plus entry l of `add` for one node; a null side is absent.
  const auto push = [&](Index node, const ObjectForces* from, std::size_t k,
                        const ObjectForces* add, std::size_t l) {
    merged.nodes.push_back(node);
    if (from != nullptr && add != nullptr) {
      merged.forces.push_back(from->forces[k] + add->forces[l]);
      if (blocks) {
        merged.stiffness.push_back(block_of(from->stiffness, k) + add->stiffness[l]);
        merged.damping.push_back(block_of(from->damping, k) + block_of(add->damping, l));
      }
      return;
    }
    const ObjectForces& f = from != nullptr ? *from : *add;
    const std::size_t m = from != nullptr ? k : l;
    merged.forces.push_back(f.forces[m]);
    if (blocks) {
      merged.stiffness.push_back(block_of(f.stiffness, m));
      merged.damping.push_back(block_of(f.damping, m));
    }
  };
  while (i < total.nodes.size() || j < part.nodes.size()) {
    const bool take_total =
        j == part.nodes.size() || (i < total.nodes.size() && total.nodes[i] < part.nodes[j]);
    const bool take_part =
        i == total.nodes.size() || (j < part.nodes.size() && part.nodes[j] < total.nodes[i]);
    if (take_total) {
      push(total.nodes[i], &total, i, nullptr, 0);
      ++i;
    } else if (take_part) {
      push(part.nodes[j], nullptr, 0, &part, j);
      ++j;
    } else {  // same node
      push(total.nodes[i], &total, i, &part, j);
      ++i;
      ++j;
    }
  }
  total = std::move(merged);
}

std::size_t cap_object_forces(ObjectForces& forces, double max_force) {
  if (!(max_force > 0.0)) return 0;
  std::size_t capped = 0;
  for (std::size_t i = 0; i < forces.forces.size(); ++i) {
    Vec3& f = forces.forces[i];
    const double norm = f.norm();
    if (!(norm > max_force)) continue;
    const double scale = max_force / norm;
    const Vec3 unit = f / norm;
    f = max_force * unit;
    const Mat3 project = scale * (Mat3::Identity() - unit * unit.transpose());
    if (i < forces.stiffness.size()) forces.stiffness[i] = (project * forces.stiffness[i]).eval();
    if (i < forces.damping.size()) forces.damping[i] = (project * forces.damping[i]).eval();
    ++capped;
  }
  return capped;
}

}  // namespace tc
