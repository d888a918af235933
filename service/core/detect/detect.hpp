// Collision detection between two deformable tet meshes (paper Sec. 3): object boxes,
// broad phase, exact tet-tet overlap, then the intruding nodes and edges the response
// needs. Self-collision (a mesh against itself) is out of scope.
//
// Two ways in:
//   detect_pair(...)          one-off, for scripts and tests
//   CollisionBody + Detector  for the per-frame pipeline: a body is built once per
//                             topology and keeps its bounds and AABB tree across frames;
//                             a detector keeps its buffers across pairs and frames.
// Output: PairContacts (core/detect/contacts.hpp), every list sorted, bit-identical
// whatever the TBB thread count. Units: metres throughout. See docs/DETECTION.md.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "core/common/chunk_buffer.hpp"
#include "core/detect/broad_phase.hpp"
#include "core/detect/contacts.hpp"
#include "core/detect/tet_overlap.hpp"
#include "core/mesh/shape_check.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"

namespace tc {

struct DetectOptions {
  /// Broad phase method. The default comes from bench_detect (docs/DETECTION.md).
  BroadPhaseKind broad_phase = BroadPhaseKind::kBvh;
  /// Distance tolerance relative to the local length scale (the largest box extent of
  /// the two tets, of the tet, or of the tet and the edge tested). Penetrations up to
  /// it count as touching, which is not an overlap.
  double relative_tolerance = kDefaultRelativeTolerance;
  /// Compute nodes_a_in_b / nodes_b_in_a.
  bool intruding_nodes = true;
  /// Compute edges_a_in_b / edges_b_in_a.
  bool intruding_edges = true;
  /// Give bounds and the broad phase only the tets of the spatial clusters that meet the
  /// overlap box (and, for kBvh, a tree over B's few tets there when they are less than
  /// half of B). Off: every tet every frame, as before clusters. The contacts are the
  /// same either way (tests/unit/test_detect.cpp checks it); only the cost differs.
  bool cluster_cull = true;
  /// kBvh: keep each pair's broad-phase pairs across frames, over boxes padded by a margin,
  /// and while every tet's box of this frame lies inside its padded box, take the
  /// candidates from them (an exact box test a pair) instead of querying a tree. The same
  /// candidates either way (tests/unit/test_detect.cpp checks it); only the cost differs.
  bool keep_pairs = true;
};

/// What one detect() call did and how long it took.
struct DetectStats {
  bool boxes_overlap = false;     ///< object boxes touch (else nothing else ran)
  std::size_t tets_a_in_box = 0;  ///< tets of A whose box meets the overlap box
  std::size_t tets_b_in_box = 0;  ///< same for B
  std::size_t tets_a_near = 0;    ///< tets of A whose bounds were looked at (clusters)
  std::size_t tets_b_near = 0;    ///< same for B
  std::size_t candidates = 0;     ///< tet pairs out of the broad phase
  std::size_t overlapping = 0;    ///< tet pairs out of the narrow phase
  double broad_ms = 0.0;          ///< object boxes, tet bounds, tree refit, broad phase
  double narrow_ms = 0.0;         ///< exact overlap tests, marked tets, intrusions
  double total_ms = 0.0;
  // Finer split, included in the above.
  double bounds_ms = 0.0;     ///< tet bounds and tree refit (prepare), part of broad_ms
  double intrusion_ms = 0.0;  ///< intruding nodes and edges, part of narrow_ms
  /// kBvh over B's few tets near the contact: the last call's tree over the same tets
  /// was refitted rather than built again.
  bool local_tree_refitted = false;
  /// The candidates came from pairs kept from an earlier call (DetectOptions::keep_pairs).
  bool pairs_kept = false;
  /// The kept pairs of this object pair were made again in this call.
  bool pairs_rebuilt = false;
  /// Candidates whose overlap the kept pairs' hints decided (check_overlap_hint()), without
  /// the full test; included in candidates.
  std::size_t hinted = 0;
};

/// One object as detection sees it: its topology-derived tables (built once, in the
/// constructor) and, per frame, its positions, box, tet bounds and AABB tree.
class CollisionBody {
 public:
  /// @param[in] tets      m tets, node indices in [0, topology.num_nodes) (validate first)
  /// @param[in] topology  the topology of exactly these tets (build_topology)
  /// Both are read, not copied (a large organ's tables are tens of MB): they must outlive
  /// the body and stay unchanged.
  /// @throws std::invalid_argument when the tets and the topology disagree
  CollisionBody(std::span<const Tet> tets, const Topology& topology);

  /// Starts a new frame: keeps a reference to `positions` (3 x n, metres; it must stay
  /// alive and unchanged until the frame's detect() calls are done) and computes the
  /// object box over the finite coordinates. Cost O(n); tet bounds wait for prepare().
  /// @throws std::invalid_argument when positions.cols() != n
  void set_positions(const Positions& positions);
  /// The same, with the object box already known: `box` must be what box() would be
  /// after set_positions(positions), bit for bit (ShapeCheck::Stats::box_lo / box_hi of a
  /// clean state are). Saves the pass over the nodes that computes it.
  void set_positions(const Positions& positions, const Aabb& box);
  /// The same, with what the object's shape check proved of these positions
  /// (ShapeCheck::bound() of the check that accepted them): the group boxes of
  /// tets_near() then come from the check's references and radii, and no pass over the
  /// nodes compares them with the body's own references. The same near tets either way.
  /// A bound that does not follow the last one given (a check in between whose bound was
  /// not passed on) makes the body take the check's references and radii anew and
  /// compare the nodes itself that frame. `box` is the box of the check's pass when it
  /// made one (ShapeCheck::Stats::has_box), else null (the body then reads the nodes for
  /// it).
  void set_positions(const Positions& positions, const MotionBound& bound, const Aabb* box);
  /// Whether this frame's group boxes come from a shape check's bound (no pass over the
  /// nodes for them).
  [[nodiscard]] bool groups_from_bound() const { return bound_frame_; }

  /// Starts a new frame with the last frame's positions: the same matrix, unchanged
  /// since set_positions() (a static object, or one without a new state). The box,
  /// cluster boxes, tet bounds and tree made for them stay valid and are not made again,
  /// so an object at rest costs nothing here. detect() gives what set_positions() with
  /// the same positions would give.
  /// @throws std::logic_error before the first set_positions()
  void reuse_positions();

  /// Computes this frame's tet bounds (and builds or refits the AABB tree for kBvh),
  /// once per frame; later calls return at once. detect() calls it when needed; call it
  /// yourself before running detect() on several pairs sharing this body concurrently.
  void prepare(BroadPhaseKind kind);

  /// The tets that may meet `region` this frame, sorted: every tet whose box overlaps it,
  /// and others of the same clusters. Cost: one box test per cluster plus the tets
  /// returned, not a pass over every tet (the first call of a frame refits the
  /// clusters' boxes from their nodes). Not thread-safe for one body.
  void tets_near(const Aabb& region, std::vector<Index>& out);

  /// Computes this frame's bounds (boxes, and spheres when `spheres` is set) of the
  /// listed tets that do not have them yet. Not thread-safe for one body.
  void ensure_bounds(std::span<const Index> tets, bool spheres);

  /// Makes the tables of the tets' edges the intruding-edge scan reads (once per body:
  /// about 50 bytes a tet, so an object never answered by segments never holds them).
  /// detect() calls it when it needs them; call it yourself before running detect() with
  /// intruding edges on several pairs sharing this body concurrently. Not thread-safe for
  /// one body.
  void prepare_edges();
  /// Whether prepare_edges() has made the tables.
  [[nodiscard]] bool edges_prepared() const { return edges_ready_; }

  /// Tets that take part in no contact until the next call (sorted, duplicates
  /// allowed; empty: every tet takes part): Detector::detect() drops the broad-phase
  /// candidates with one of them, so they overlap nothing, hold no node or edge of the
  /// other object, and their nodes and edges are tested only where the object's other
  /// tets overlap. The pipeline's degraded mode leaves a state's few inverted or
  /// degenerate tets out this way (docs/DETECTION.md, "Inverted tets").
  void set_left_out_tets(std::span<const Index> tets) {
    left_out_.assign(tets.begin(), tets.end());
  }
  [[nodiscard]] std::span<const Index> left_out_tets() const { return left_out_; }
  /// Box of the finite node positions of this frame (empty before set_positions()).
  [[nodiscard]] const Aabb& box() const { return box_; }
  [[nodiscard]] Index num_nodes() const { return num_nodes_; }
  [[nodiscard]] Index num_tets() const { return static_cast<Index>(tets_.size()); }
  [[nodiscard]] std::span<const Tet> tets() const { return tets_; }
  /// Unique edges (a, b), a < b, sorted: the same list as Topology::edges.
  [[nodiscard]] std::span<const std::array<Index, 2>> edges() const { return edges_; }

 private:
  friend class Detector;

  std::span<const Tet> tets_;  ///< the caller's
  Index num_nodes_ = 0;
  std::span<const std::array<Index, 2>> edges_;  ///< the topology's
  /// n rows: the tets using each node, the topology's (null: owned_node_tets_, made when
  /// the topology has none). Through node_tets() only: a moved body keeps it right.
  const Csr* topology_node_tets_ = nullptr;
  Csr owned_node_tets_;
  [[nodiscard]] const Csr& node_tets() const {
    return topology_node_tets_ != nullptr ? *topology_node_tets_ : owned_node_tets_;
  }
  // prepare_edges():
  bool edges_ready_ = false;
  Csr edge_tets_;                                ///< edge rows: tets using the edge
  std::vector<std::array<Index, 6>> tet_edges_;  ///< m x 6: edge ids (kTetEdges order)
  /// tet_edges (m x 6) from the topology's edges; the first entry (6 t + k) whose edge is
  /// not there (its id then -1), if any.
  std::optional<std::size_t> find_tet_edges(std::vector<std::array<Index, 6>>& tet_edges) const;

  /// Spatial clusters, made once per topology from the first positions: tets sorted
  /// along a Morton curve of their centroids and cut into runs of 64; each frame a
  /// cluster's box is refitted from the nodes its tets use.
  void build_clusters(const Positions& positions);
  void start_frame(const Positions& positions, const Aabb* box, const MotionBound* bound);
  Csr cluster_tets_;                          ///< per cluster: its tets, sorted
  Csr cluster_nodes_;                         ///< per cluster: the nodes its tets use, sorted
  std::vector<Aabb> tet_boxes_;               ///< per cluster: box of its tets (valid when stamped)
  std::vector<std::uint32_t> cluster_frame_;  ///< per cluster: frame tet_boxes_ was refitted
  /// Groups of consecutive clusters (neighbours on the Morton curve): the nodes their tets
  /// use, and their boxes this frame. A cluster can meet a region only if its group does,
  /// so only the clusters of the groups that meet it are refitted.
  Csr group_nodes_;
  std::vector<Aabb> group_boxes_;
  /// The group boxes kept across frames. Each node has a reference position (its position
  /// when it last moved more than reach_ along an axis) and each group the box of its
  /// nodes' references; a group's box this frame is that box grown by 2 reach_. A frame
  /// compares every node with its reference (one pass, in node order), moves the nodes
  /// that went further into their references and refits only the groups around them.
  Positions ref_;                   ///< 3 x n reference positions (empty until made)
  std::vector<Aabb> ref_boxes_;     ///< per group: box of its nodes' finite references
  double reach_ = 0.0;              ///< a quarter of the mean edge length at the first frame
  Csr node_groups_;                 ///< per node: the groups whose tets use it
  std::uint32_t motion_frame_ = 0;  ///< frame whose nodes were last compared (0: none)
  std::vector<std::vector<Index>> moved_parts_;  ///< per chunk of nodes: those that moved
  std::vector<std::uint32_t> group_stamp_;       ///< per group: frame it was last refitted
  std::vector<Index> dirty_groups_;              ///< scratch
  /// Compares the nodes with their references (chunk `c` of `chunk` nodes, from `begin`
  /// to `end`), listing those beyond reach_ in moved_parts_[c]. Returns nothing; the
  /// caller calls finish_motion() once every chunk is done.
  void compare_chunk(const double* xyz, std::size_t begin, std::size_t end, std::size_t c);
  /// Moves the listed nodes into their references and refits their groups' reference
  /// boxes (every group when more than a quarter of the nodes moved), then this frame's
  /// group boxes.
  void finish_motion(const Positions& positions);
  /// The group boxes from a shape check's bound (set_positions() with a MotionBound): per
  /// group the box of its nodes' references in the check and a radius at least each of
  /// its nodes' radii there since the version taken (it only grows until the next
  /// resync); a frame's group box is that box moved by the check's shift (after its turn,
  /// when the check turned the references: the box of the turned box) and grown by the
  /// radius and the rounding.
  std::vector<Aabb> bound_boxes_;
  std::vector<double> bound_radius_;
  /// The check's version bound_boxes_ and bound_radius_ hold for (none: not taken yet).
  std::optional<std::uint64_t> bound_version_;
  bool bound_frame_ = false;  ///< this frame's group boxes come from the bound
  Eigen::Vector3d bound_shift_ = Eigen::Vector3d::Zero();
  bool bound_rotated_ = false;  ///< the check turned the references: bound_rotation_
  Eigen::Matrix3d bound_rotation_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d bound_pivot_ = Eigen::Vector3d::Zero();
  std::vector<Index> bound_dirty_;  ///< scratch
  /// Takes in a shape check's bound of this frame's positions (sets bound_frame_).
  void apply_bound(const MotionBound& bound);
  /// Last frame's regions met fewer than half of the groups: refit the groups first, then
  /// the clusters of the groups that meet. Else (a contact spread over most of the
  /// object) every cluster is refitted directly, which reads fewer nodes, and the group
  /// boxes are made from the cluster boxes.
  bool use_groups_ = true;
  /// Starts a frame's count of the groups met, after setting use_groups_ from the last.
  void decide_groups();
  bool near_asked_ = false;            ///< tets_near() was called this frame
  std::size_t groups_met_ = 0;         ///< groups that met a region this frame (over all calls)
  bool clusters_ready_ = false;        ///< this frame's group boxes (or all cluster boxes) made
  std::vector<Index> stale_clusters_;  ///< scratch for tets_near()
  std::vector<std::uint32_t> box_frame_, sphere_frame_;  ///< per tet: frame bounds were made
  std::uint32_t frame_ = 0;               ///< set_positions() calls, never 0 after the first
  std::vector<Index> stale_;              ///< scratch for ensure_bounds()
  std::vector<std::uint64_t> near_bits_;  ///< scratch bitmap of tets_near(), all 0 between calls

  const Positions* positions_ = nullptr;
  std::vector<Index> left_out_;  ///< set_left_out_tets(), sorted
  Aabb box_;
  TetBounds bounds_;
  bool bounds_ready_ = false;
  bool spheres_ready_ = false;
  AabbTree tree_;
  bool tree_built_ = false;
  bool tree_ready_ = false;
};

/// Runs detection on pairs of bodies, keeping its buffers. Not thread-safe: one
/// Detector per thread (its inner loops use TBB).
class Detector {
 public:
  explicit Detector(DetectOptions options = {});
  ~Detector();
  Detector(Detector&&) noexcept;
  Detector& operator=(Detector&&) noexcept;
  Detector(const Detector&) = delete;
  Detector& operator=(const Detector&) = delete;

  [[nodiscard]] const DetectOptions& options() const { return options_; }
  void set_options(const DetectOptions& options) { options_ = options; }

  /// Which intruding edges a pair needs, {A's edges in B, B's edges in A}, asked once its
  /// overlapping pairs and marked tets are in `out` and before the intrusion scans (the
  /// response's choice between points and segments reads the marked tets).
  using EdgeNeed = std::function<std::array<bool, 2>(const PairContacts& out)>;

  /// Contacts of the ordered pair (a, b) for the current frame of both bodies
  /// (set_positions() called). When the object boxes do not touch, only that test runs.
  /// @param[out] out         cleared, then filled (see PairContacts)
  /// @param[out] stats       optional counts and timings
  /// @param[in]  need_edges  optional: the directions whose intruding edges are computed,
  ///                         when DetectOptions::intruding_edges is on (unset: both)
  void detect(CollisionBody& a, CollisionBody& b, PairContacts& out, DetectStats* stats = nullptr,
              const EdgeNeed& need_edges = {});

  /// Broad-phase candidates of the last detect() call, sorted by (tet_a, tet_b).
  [[nodiscard]] std::span<const TetPair> candidates() const { return candidates_; }

 private:
  /// For each marked tet of X (sorted), the tets of Y it overlaps, as sorted slots of Y's
  /// Geometry (slots follow tet order, so a row sorted by slot is sorted by tet).
  struct Rows {
    std::vector<Index> offsets;
    std::vector<Index> items;
  };
  /// Derived geometry of the tets of one body that appear in candidate pairs.
  /// Box (metres) and largest extent of a tet: what the intrusion scans test first,
  /// apart from the ~1 kB TetGeometry so that a rejected tet costs one cache line.
  struct TetBox {
    Eigen::Vector3d lo, hi;
    double scale = 0.0;
  };
  /// The tets of one body that appear in candidate pairs, by slot (their index in `tets`),
  /// with their boxes. Their TetGeometry is built by each thread that needs it, in that
  /// thread's own copy (ThreadGeometry, detect.cpp): a tet's geometry is 816 bytes, and a
  /// shared copy written by one core and read by the other cost more than building it
  /// twice when the two cores are far apart (docs/DETECTION.md, "One frame of one pair").
  struct Geometry {
    std::vector<Index> tets;    ///< sorted
    std::vector<TetBox> boxes;  ///< per slot: make_tet_geometry()'s lo, hi, scale
    /// The union of `boxes` and their largest scale: no point or segment outside it,
    /// padded by the tolerance, can be in any of these tets.
    TetBox reach;
    std::vector<Index> slot;  ///< scratch, per tet of the body: index or -1
  };
  struct ThreadGeometry;
  class GeometryOf;
  /// g.slot, g.boxes and g.reach for the tets in g.tets (their geometry is built later, by
  /// each thread that needs it).
  void index_tets(const CollisionBody& body, Geometry& g);
  static void clear_slots(Geometry& g);
  /// gy_side: 0 when Y is the pair's body A, 1 when B (which copy of each thread's geometry).
  void intruding_nodes(const CollisionBody& x, std::span<const Index> marked, const Rows& rows,
                       const CollisionBody& y, const Geometry& gy, int gy_side,
                       std::vector<IntrudingNode>& out);
  void intruding_edges(const CollisionBody& x, std::span<const Index> marked, const Rows& rows,
                       const CollisionBody& y, const Geometry& gy, int gy_side,
                       std::vector<IntrudingEdge>& out);
  void collect_features(std::span<const Index> marked, const CollisionBody& x, bool edges);
  struct KeptPairs;
  /// The kept pairs of (a, b); a new, empty entry when there are none (the least recently
  /// used object pair's entry goes when kKeptPairsHeld are held).
  KeptPairs* kept_of(const CollisionBody& a, const CollisionBody& b);
  /// True while the kept pairs of `k` sit out (contact that moved too fast for them);
  /// counts the call.
  static bool kept_paused(KeptPairs& k);
  /// The candidates of this call from the kept pairs `k` of (a, b) (made again when this
  /// frame's boxes leave them), into candidates_; false when they cannot serve this call.
  bool candidates_from_kept(KeptPairs* k, CollisionBody& a, CollisionBody& b, const Aabb& cull,
                            DetectStats& st);
  // The steps of detect(), in the order it runs them once the object boxes touch.
  /// Broad phase: the tets of each body near the overlap box of the two objects, their
  /// bounds (st.bounds_ms: since `start`) and those whose box meets it (subset_a_, subset_b_),
  /// then the tet pairs whose boxes overlap, from the kept pairs or the broad phase, less
  /// those with a left-out tet, into candidates_.
  void find_candidates(CollisionBody& a, CollisionBody& b,
                       std::chrono::steady_clock::time_point start, DetectStats& st);
  /// The candidates of options_.broad_phase over subset_a_ and subset_b_, into candidates_:
  /// for kBvh, B's own tree when `full_tree` (prepared here when `keep` left it unprepared),
  /// else a local tree over subset_b_.
  void candidates_from_broad_phase(const CollisionBody& a, CollisionBody& b, bool full_tree,
                                   bool keep, DetectStats& st);
  /// Drops the candidates with a tet left out of contact (set_left_out_tets()).
  void drop_left_out(const CollisionBody& a, const CollisionBody& b);
  /// geom_a_ and geom_b_: the tets in candidate pairs, once per tet, indexed (index_tets());
  /// on one thread their geometry is built now, in slot order.
  void index_candidate_tets(const CollisionBody& a, const CollisionBody& b);
  /// Narrow phase: the exact overlap of every candidate, in candidate order; the overlapping
  /// ones into out.overlapping.
  void narrow_phase(const CollisionBody& a, const CollisionBody& b, PairContacts& out);
  /// out.marked_a and out.marked_b from out.overlapping, and for each marked tet its row of
  /// the other body's tets it overlaps (rows_a_, rows_b_).
  void mark_tets(PairContacts& out);
  /// The feature scans: the intruding nodes and edges of each body in the other, as the
  /// options and `need_edges` ask, into `out`.
  void find_intrusions(CollisionBody& a, CollisionBody& b, PairContacts& out,
                       const EdgeNeed& need_edges);
  /// The tets of `body` whose cluster box meets `region` (every tet without the cluster
  /// cull), into `list`.
  void gather_near(CollisionBody& body, const Aabb& region, std::vector<Index>& list) const;
  /// subset_x_ and boxes_x_ of `body`: its tets among `near` whose box meets `region`, and
  /// the box of each one's part inside it.
  void filter_tets(const CollisionBody& body, std::span<const Index> near, const Aabb& region,
                   std::vector<Index>& subset, std::vector<Aabb>& boxes);
  /// options_.relative_tolerance, with negative or NaN read as 0.
  [[nodiscard]] double relative_tolerance() const {
    return options_.relative_tolerance > 0.0 ? options_.relative_tolerance : 0.0;
  }

  DetectOptions options_;
  BroadPhase broad_;
  std::vector<Index> subset_a_, subset_b_;  ///< tets in the overlap box
  std::vector<Aabb> boxes_a_, boxes_b_;     ///< their boxes clipped to it
  detail::ChunkBuffers<Index> index_parts_;
  detail::ChunkBuffers<Aabb> box_parts_;
  std::vector<Index> box_slot_;         ///< scratch: tet of B -> index in subset_b_, or -1
  std::vector<Index> near_a_, near_b_;  ///< tets of the clusters meeting the overlap box
  AabbTree local_tree_;                 ///< kBvh over subset_b_ when it is a small part of B
  /// What local_tree_ was built over: the body, its tets (subset_b_ then) and the frames
  /// it has been refitted since. The same tets next frame (contact moves little between
  /// frames) refit it instead of building it again.
  const CollisionBody* local_tree_body_ = nullptr;
  std::vector<Index> local_tree_tets_;
  int local_tree_refits_ = 0;
  std::vector<TetPair> candidates_;
  detail::ChunkBuffers<TetPair> pair_parts_;
  /// When the candidates came from kept pairs: each one's entry in the kept pairs, and
  /// their overlap hints (KeptPairs::hints), which the narrow phase checks and renews;
  /// else empty and null.
  std::vector<Index> candidate_entries_;
  detail::ChunkBuffers<Index> entry_parts_;
  std::vector<OverlapHint>* hints_ = nullptr;
  std::vector<std::size_t> hinted_parts_;  ///< per narrow-phase chunk: pairs the hints decided
  std::vector<std::unique_ptr<KeptPairs>> kept_;  ///< per object pair (KeptPairs::used: last use)
  std::uint64_t kept_calls_ = 0;                  ///< kept_of() calls
  Geometry geom_a_, geom_b_;
  std::unique_ptr<ThreadGeometry> thread_geometry_;  ///< each thread's geometry of both bodies
  std::uint64_t geometry_stamp_ = 0;                 ///< detect() calls that built geometry
  Rows rows_a_, rows_b_;
  std::vector<Index> row_of_;        ///< scratch: tet of X -> its row, or -1
  std::vector<Index> counts_;        ///< scratch: counting sort of the rows of B
  std::vector<std::uint64_t> bits_;  ///< scratch bitmap (tets or features), all 0 between uses
  std::vector<Index> features_;
  detail::ChunkBuffers<IntrudingNode> node_parts_;
  detail::ChunkBuffers<IntrudingEdge> edge_parts_;
};

/// One-off detection between object A (positions_a 3 x n_a metres, tets_a m_a tets,
/// topology_a) and object B. Builds two CollisionBody and a Detector; for repeated
/// frames keep those instead.
PairContacts detect_pair(const Positions& positions_a, std::span<const Tet> tets_a,
                         const Topology& topology_a, const Positions& positions_b,
                         std::span<const Tet> tets_b, const Topology& topology_b,
                         const DetectOptions& options = {}, DetectStats* stats = nullptr);

/// The object pairs (i, j), i < j, of a scene whose boxes touch and that `enabled` allows
/// (e.g. not two static objects); sorted. An empty `enabled` allows every pair.
std::vector<std::pair<Index, Index>> touching_object_pairs(
    std::span<const Aabb> boxes, const std::function<bool(Index, Index)>& enabled = {});

}  // namespace tc
