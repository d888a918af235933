// The per-frame shape check of one object, at a cost that follows the motion.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "core/common/chunk_buffer.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"
#include "core/mesh/validate.hpp"

namespace tc {

/// How far each node of a tet may move from `positions` (all by at most the returned
/// distance, in any directions) while the tet surely keeps a quality of at least
/// `quality` (tet_quality(), with a margin for rounding: 1.001 * quality + 1e-6 is
/// proven). Negative when the tet is not that good as it is. The bound: 6V changes by at
/// most delta * sum|grad_i 6V| + 4 delta^2 (|e1| + |e2| + |e3|) + 8 delta^3 (the
/// triple product's expansion, e_k the edges from node 0, each moving by at most
/// 2 delta), and each edge length by at most 2 delta. The radius solves that bound made
/// linear on [0, h] (the cubic's terms at h, the edge term's chord), for a few h; ~10% of
/// the edge for a regular tet, within 2x of the largest radius the bound allows.
double certified_motion_radius(const Positions& positions, const Tet& tet, double quality);

/// What ShapeCheck::check() proved of the state it was given, for the detection's group
/// boxes (CollisionBody::set_positions): when `bounded`, the state is clean and every node
/// i lies within sqrt(max(radius2[i], 0)) of reference.col(i) + shift, or, when `rotated`,
/// of rotation * (reference.col(i) - pivot) + shift (the test check() makes, up to its
/// rounding), with radius2 as it was before this check changed it: the span holds the
/// radii after it, which differ only at the nodes in `changed` (new radii around the nodes
/// that moved, for the next state); the nodes in `moved` got new references, their
/// positions less the shift (and turned back: rotation^T * (x - shift) + pivot).
/// `version_before` and `version_after` number the reference and radii before and after
/// this check (they differ exactly when `moved` and `changed` say what changed, or when
/// `rebuilt`: every node's reference and radius is new, the reference is the state itself
/// and the shift 0). The spans and the pointer are valid until the next check().
struct MotionBound {
  bool bounded = false;
  bool rebuilt = false;
  std::uint64_t version_before = 0, version_after = 0;
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();
  bool rotated = false;  ///< the rigid motion turns too: `rotation` about `pivot`
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d pivot = Eigen::Vector3d::Zero();  ///< (0 when not rotated)
  const Positions* reference = nullptr;
  std::span<const double> radius2;  ///< per node, after this check: -1 always checked
  std::span<const Index> moved, changed;
  /// When `bounded`: every node that is not in `moved` lies within `motion` of its
  /// reference shifted (and turned), as the test computed it (up to its rounding: a few
  /// eps of the coordinates); the nodes in `moved` are at their new references. Infinity
  /// when not bounded. For the self-contact gate's certificate (SelfCollider::detect).
  double motion = std::numeric_limits<double>::infinity();
};

/// validate_positions() for the successive states of one object, the same reports at a
/// cost that follows how far the nodes moved.
///
/// A reference shape is kept (the last accepted positions of each node, up to one rigid
/// motion of the whole object) with, per node, a radius r_i = min over its tets of
/// certified_motion_radius() at the reference (the sliver threshold as the quality). A
/// new state is compared with the reference after removing the mean displacement (of
/// runs of 8 nodes every 512 on objects of over 8,192 nodes; a translation changes no
/// shape): a tet whose four nodes all stayed within their radii
/// is surely neither degenerate, inverted nor a sliver, and only the tets of the nodes
/// that moved further are checked. When the state is clean, those nodes become part of
/// the reference and the radii around them are recomputed. When the mean displacement
/// leaves more than a quarter of the nodes (or of the sample) beyond their radii, the
/// rigid motion that fits the same nodes best in least squares (a turn and a shift; Horn's
/// unit quaternion) is tried in its place, and kept while the object goes on turning: a
/// rotation changes no shape either (docs/DETECTION.md, "Rigid motions in the shape
/// check"). A still or rigidly moving object costs one pass over its positions, its
/// reference and its radii a frame (about 2.5x what reading the positions alone costs
/// when it only shifts, 4.5x when it turns: it reads 56 bytes a node, the positions
/// 24; the reference is kept a second time for it, by blocks of four nodes coordinate by
/// coordinate); the tets near a contact cost what they cost before plus their new radii.
///
/// What a check proved of its state's nodes (bound()) lets the detection keep the group
/// boxes of its cull without reading the nodes again (CollisionBody::set_positions).
///
/// When more than a quarter of the nodes moved under both motions (a large deformation; on
/// a large object a quarter of the sampled nodes already tells) every tet is checked as by
/// validate_positions(), and the reference is rebuilt on the 1st, 2nd, 4th, 8th, ... such
/// state in a row (the radii cost about a full check, so an object that keeps moving pays
/// for them less and less often).
///
/// The reports are those of validate_positions(positions, order, options) field for field
/// (min_quality only when options.compute_min_quality is false: NaN, as there), whatever
/// the thread count. `order` and `node_tets` (Topology::node_tets of the same tets) are
/// read, not copied: they must outlive the check.
class ShapeCheck {
 public:
  /// What the last check() did.
  struct Stats {
    std::size_t moved_nodes = 0;   ///< nodes beyond their radius (0 when not counted: the
                                   ///< first state, a NaN, or a busy state seen in a sample)
    std::size_t checked_tets = 0;  ///< tets whose shape was computed
    bool full = false;             ///< every tet was checked
    bool rebuilt = false;          ///< the reference was rebuilt from this state
    /// When the motion pass read every node (has_box): the box of the positions, each
    /// node taken in order as by lo = min(lo, x), hi = max(hi, x) with std::min and
    /// std::max, so the bits an Aabb extended node by node gets, signed zeros included.
    /// A state whose report is clean has only finite nodes: then it is their box.
    bool has_box = false;
    Eigen::Vector3d box_lo = Eigen::Vector3d::Zero(), box_hi = Eigen::Vector3d::Zero();
    bool bounded = false;  ///< MotionBound::bounded
    Eigen::Vector3d shift = Eigen::Vector3d::Zero();
    bool rotated = false;  ///< MotionBound::rotated: the nodes were compared after a turn
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    Eigen::Vector3d pivot = Eigen::Vector3d::Zero();
    std::uint64_t version_before = 0, version_after = 0;
    /// The largest squared motion of a node within its radius (MotionBound::motion), when
    /// the motion pass ran; 0 after a rebuild.
    double motion2 = std::numeric_limits<double>::infinity();
  };

  /// Throws std::invalid_argument when `node_tets` does not have `num_nodes` rows.
  ShapeCheck(const TetCheckOrder& order, const Csr& node_tets, Index num_nodes,
             const ValidationOptions& options);

  /// The report of validate_positions(positions, order, options). Throws
  /// std::invalid_argument when `positions` does not have num_nodes columns.
  ValidationReport check(const Positions& positions);

  [[nodiscard]] const Stats& last() const { return last_; }
  /// What the last check() proved of its state's nodes (see MotionBound).
  [[nodiscard]] MotionBound bound() const;

 private:
  ValidationReport check_all(const Positions& positions, bool rebuild);
  void rebuild(const Positions& positions);
  double node_radius2(Index node) const;
  /// Copies reference_'s column `node` into blocks_.
  void set_block_node(Index node);
  /// Extends ref_lo_, ref_hi_ by reference_'s column `node` when the node is in a tet.
  void cover(Index node);
  /// A bound on the distance from `pivot` (3 coordinates) of the reference of every node
  /// in a tet.
  [[nodiscard]] double reach(const double* pivot) const;

  // The steps of check(), once the state has a finite shift from the reference.
  /// The motion a state's nodes are compared after (defined in shape_check.cpp).
  struct Motion;
  /// Compares the nodes with their references after the shift in `motion`, or after a turn
  /// fitted in its place when that leaves clearly fewer beyond their radii (decided on the
  /// sample of `samples` nodes of a large object): moved_, and last_'s box and motion2.
  /// False, with no pass over every node, when the state is busy under either motion.
  bool compare_nodes(const double* x, std::size_t samples, Motion& motion);
  /// Fits a turn and a shift to the sampled nodes in tets (fit_rigid(); again without the
  /// nodes the first fit leaves beyond their radii) into `motion`; false, motion.turned
  /// false, when no fit whose rounding fits budget_ is found.
  bool fit_turn(const double* x, Motion& motion);
  /// Tries a fitted turn in place of the shift that leaves `by_shift` of `of` nodes beyond
  /// their radii and keeps it when count_beyond() under it is clearly fewer; else goes back
  /// to the shift and rests the fit for kFitPause states. Returns the count kept.
  template <typename CountBeyond>
  std::size_t keep_fit_if_better(const double* x, Motion& motion, std::size_t by_shift,
                                 const CountBeyond& count_beyond, std::size_t of);
  /// The motion pass over every node after `motion` (detail::motion_pass(), in chunks):
  /// moved_ sorted, and last_'s box and motion2.
  void pass_nodes(const double* x, const Motion& motion);
  /// check_all() of a busy state, rebuilding the reference on the 1st, 2nd, 4th, 8th, ...
  /// busy state in a row.
  ValidationReport check_busy(const Positions& positions);
  /// The shapes of the tets of the nodes in moved_ (places_, tets_, index_), in check order.
  ValidationReport check_moved_tets(const Positions& positions);
  /// What a clean state proved: last_'s bound after `motion`; turning_.
  void record_bound(const Motion& motion);
  /// The nodes in moved_ join the reference (moved back by `motion`), and the radii of
  /// their tets and of those tets' nodes are recomputed.
  void accept_moved(const Positions& positions, const Motion& motion);

  const TetCheckOrder& order_;
  const Csr& node_tets_;
  Index num_nodes_;
  ValidationOptions options_;
  double quality_;                  ///< the quality the radii certify
  std::vector<Index> position_of_;  ///< mesh tet -> its place in order_.tets
  Positions reference_;             ///< 3 x n; empty until a clean state was seen
  /// reference_ by blocks of kPassStep nodes, coordinate by coordinate (x x x x y y y y z z
  /// z z), for the motion pass; a last partial block's lanes beyond the nodes unused.
  std::vector<double> blocks_;
  std::vector<double> radius_;   ///< per place in order_: certified radius, < 0: none
  std::vector<double> radius2_;  ///< per node: squared radius less budget_, -1: always check
  /// Since the last rebuild: at least the square of every radius, and the box of the
  /// references of nodes in tets (for the rounding of the motion test); the room for
  /// that rounding kept off radius2_ (fixed at the last rebuild).
  double rcap2_ = 0.0;
  double budget_ = 0.0;
  double ref_lo_[3] = {}, ref_hi_[3] = {};
  std::vector<std::uint64_t> place_bits_, node_bits_;  ///< bitmaps, all 0 between calls
  std::vector<Index> moved_, places_, nodes_;
  std::vector<std::size_t> outside_;  ///< scratch of check(): sampled nodes beyond the first fit
  detail::ChunkBuffers<Index> moved_parts_;  ///< per chunk of the motion pass: moved nodes
  std::vector<PointBox> pass_boxes_;         ///< per chunk of the motion pass: its box
  std::vector<double> pass_within2_;         ///< per chunk of the motion pass: its motion2
  std::vector<Tet> tets_;
  std::vector<Index> index_;
  std::size_t busy_streak_ = 0;  ///< full checks in a row
  bool turning_ = false;         ///< the last accepted state was compared after a turn
  /// States left before a turn is fitted again after one that did not do better than the
  /// shift (a dent, not a turn): the fit costs about 3% of a dented state.
  std::size_t fit_pause_ = 0;
  std::uint64_t version_ = 0;  ///< changes of reference_ and radius2_ so far
  Stats last_;
};

}  // namespace tc
