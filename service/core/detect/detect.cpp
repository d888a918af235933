#include "core/detect/detect.hpp"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "core/common/chunked.hpp"
#include "core/detect/edge_hits.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/sorted_index_set.hpp"

namespace tc {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

constexpr std::size_t kNarrowChunk = 256;
constexpr std::size_t kFeatureChunk = 32;
constexpr std::size_t kFilterChunk = 1024;
/// Kept pairs tested a chunk (candidates_from_kept()).
constexpr std::size_t kKeptChunk = 2048;
/// Frames a local tree over the same tets is refitted before it is built again.
constexpr int kLocalTreeRefits = 32;

}  // namespace

// ----------------------------------------------------------------------------- Detector

/// One thread's TetGeometry of the tets in candidate pairs, [0] for body A's slots and [1]
/// for B's, built when the thread first needs a tet in a detect() call (stamp).
struct Detector::ThreadGeometry {
  struct Copy {
    std::array<std::vector<TetGeometry>, 2> geom;
    std::array<std::vector<std::uint64_t>, 2> built;  ///< per slot: the stamp it was built at
    std::uint64_t all_built = 0;                      ///< the stamp every slot was built at
    std::vector<Index> missing;                       ///< scratch: slots to build

    /// True when slot s of body w (0: A, 1: B) is still to be built in the detect() call
    /// `stamp`; it then counts as built.
    bool claim(std::size_t w, Index s, std::uint64_t stamp) {
      if (all_built == stamp) return false;
      std::uint64_t& b = built[w][static_cast<std::size_t>(s)];
      if (b == stamp) return false;
      b = stamp;
      return true;
    }
  };
  tbb::enumerable_thread_specific<Copy> copies;

  /// This thread's copy, sized for the slots of both bodies.
  Copy& local(std::size_t slots_a, std::size_t slots_b) {
    Copy& copy = copies.local();
    const std::array<std::size_t, 2> slots = {slots_a, slots_b};
    for (std::size_t w = 0; w < 2; ++w) {
      if (copy.geom[w].size() < slots[w]) copy.geom[w].resize(slots[w]);
      if (copy.built[w].size() < slots[w]) copy.built[w].resize(slots[w], 0);
    }
    return copy;
  }
};

namespace {

/// Builds the geometry of the slots slot_at(0), ..., slot_at(count - 1) (slot s: tet tets[s]
/// of the body at positions p) into geom, 4 tets a call (make_tet_geometry4: the bits of
/// make_tet_geometry).
template <typename SlotAt>
void build_slots(const Positions& p, std::span<const Tet> body_tets, std::span<const Index> tets,
                 std::size_t count, const SlotAt& slot_at, std::vector<TetGeometry>& geom) {
  const auto corners_of = [&](std::size_t slot) {
    return tet_corners(p, body_tets[static_cast<std::size_t>(tets[slot])]);
  };
  std::size_t k = 0;
  for (; k + 4 <= count; k += 4) {
    std::array<TetCorners, 4> corners;
    std::array<TetGeometry*, 4> out;
    for (std::size_t j = 0; j < 4; ++j) {
      const std::size_t slot = slot_at(k + j);
      corners[j] = corners_of(slot);
      out[j] = &geom[slot];
    }
    make_tet_geometry4(corners, out);
  }
  for (; k < count; ++k) make_tet_geometry(corners_of(slot_at(k)), geom[slot_at(k)]);
}

}  // namespace

/// The calling thread's geometry of one body's slots, built on first use in this detect()
/// call: what the intrusion scans test points and segments against.
class Detector::GeometryOf {
 public:
  GeometryOf(ThreadGeometry::Copy& copy, int side, std::uint64_t stamp, const Positions& positions,
             std::span<const Tet> body_tets, std::span<const Index> tets)
      : copy_(copy),
        side_(static_cast<std::size_t>(side)),
        stamp_(stamp),
        positions_(positions),
        body_tets_(body_tets),
        tets_(tets) {}

  const TetGeometry& operator()(Index slot) {
    std::vector<TetGeometry>& geom = copy_.geom[side_];
    const auto s = static_cast<std::size_t>(slot);
    if (copy_.claim(side_, slot, stamp_))
      build_slots(
          positions_, body_tets_, tets_, 1, [s](std::size_t) { return s; }, geom);
    return geom[s];
  }
  /// The slot of geometry g: &g - base().
  [[nodiscard]] const TetGeometry* base() const { return copy_.geom[side_].data(); }

 private:
  ThreadGeometry::Copy& copy_;
  std::size_t side_;
  std::uint64_t stamp_;
  const Positions& positions_;
  std::span<const Tet> body_tets_;
  std::span<const Index> tets_;
};

Detector::Detector(DetectOptions options)
    : options_(options), thread_geometry_(std::make_unique<ThreadGeometry>()) {}
Detector::~Detector() = default;
Detector::Detector(Detector&&) noexcept = default;
Detector& Detector::operator=(Detector&&) noexcept = default;

void Detector::index_tets(const CollisionBody& body, Geometry& g) {
  if (g.slot.size() < body.tets_.size()) g.slot.resize(body.tets_.size(), -1);
  g.boxes.resize(g.tets.size());
  for (std::size_t i = 0; i < g.tets.size(); ++i) g.slot[g.tets[i]] = static_cast<Index>(i);
  // The tet boxes the broad phase made this frame for every tet near the contact (every
  // tet in a candidate pair is): the corners' min and max, empty for a non-finite corner,
  // as in make_tet_geometry() (up to the sign of a zero, which no test below can see).
  for (std::size_t i = 0; i < g.tets.size(); ++i) {
    const Aabb& box = body.bounds_.boxes[static_cast<std::size_t>(g.tets[i])];
    g.boxes[i] = box.empty() ? TetBox{box.lo, box.hi, 0.0}
                             : TetBox{box.lo, box.hi, (box.hi - box.lo).maxCoeff()};
  }
  g.reach = TetBox{Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()),
                   Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity()), 0.0};
  for (const TetBox& b : g.boxes) {
    g.reach.lo = g.reach.lo.cwiseMin(b.lo);
    g.reach.hi = g.reach.hi.cwiseMax(b.hi);
    g.reach.scale = std::max(g.reach.scale, b.scale);
  }
}

void Detector::clear_slots(Geometry& g) {
  for (const Index t : g.tets) g.slot[t] = -1;
}

void Detector::gather_near(CollisionBody& body, const Aabb& region,
                           std::vector<Index>& list) const {
  if (options_.cluster_cull) {
    body.tets_near(region, list);
  } else {
    list.resize(body.tets_.size());
    std::iota(list.begin(), list.end(), Index{0});
  }
}

void Detector::filter_tets(const CollisionBody& body, std::span<const Index> near,
                           const Aabb& region, std::vector<Index>& subset,
                           std::vector<Aabb>& boxes) {
  // Each tet whose box meets the region gets the box of its part inside it (exact across
  // the region's thinnest axis): where the objects barely touch, the overlap box is a
  // thin slab and these boxes are much smaller than the tets'.
  const Eigen::Vector3d extent = region.hi - region.lo;
  int slab_axis = 0;
  if (extent.y() < extent[slab_axis]) slab_axis = 1;
  if (extent.z() < extent[slab_axis]) slab_axis = 2;
  const double rel = relative_tolerance();
  const std::size_t m = near.size();
  const std::size_t chunks = detail::num_chunks(m, kFilterChunk);
  detail::reset_parts(index_parts_, chunks);
  detail::reset_parts(box_parts_, chunks);
  const Positions& p = *body.positions_;
  detail::for_chunks(m, kFilterChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
    // The tets whose box meets the region, 4 at a time through clipped_tet_boxes4 (the
    // same boxes as clipped_tet_box), in order.
    std::array<TetCorners, 4> corners;
    std::array<double, 4> pads;
    std::array<Index, 4> tets;
    std::array<Aabb, 4> clipped;
    std::size_t waiting = 0;
    const auto flush = [&] {
      if (waiting == 4) {
        clipped_tet_boxes4(corners, region, slab_axis, pads, clipped);
      } else {
        for (std::size_t j = 0; j < waiting; ++j)
          clipped[j] = clipped_tet_box(corners[j], region, slab_axis, pads[j]);
      }
      for (std::size_t j = 0; j < waiting; ++j) {
        if (clipped[j].empty()) continue;
        index_parts_[c].push_back(tets[j]);
        box_parts_[c].push_back(clipped[j]);
      }
      waiting = 0;
    };
    for (std::size_t i = begin; i < end; ++i) {
      const auto t = static_cast<std::size_t>(near[i]);
      const Aabb& raw = body.bounds_.boxes[t];
      if (!raw.overlaps(region)) continue;
      // Pad: the tolerance scale of this tet, plus rounding of its coordinates.
      pads[waiting] = rel * (raw.hi - raw.lo).maxCoeff() +
                      8.0 * std::numeric_limits<double>::epsilon() *
                          raw.lo.cwiseAbs().cwiseMax(raw.hi.cwiseAbs()).maxCoeff();
      corners[waiting] = tet_corners(p, body.tets_[t]);
      tets[waiting] = static_cast<Index>(t);
      if (++waiting == 4) flush();
    }
    flush();
  });
  detail::concat_parts(index_parts_, chunks, subset);
  detail::concat_parts(box_parts_, chunks, boxes);
}

/// The broad-phase pairs of one object pair, kept across frames: every pair of entries of
/// the two `tets` lists whose `boxes` overlap. Each entry's box is the box of its tet's
/// part inside the overlap box padded by `margin`, itself padded by `margin`. While each
/// tet that the broad phase keeps in a later frame is in these lists and its box then lies
/// inside its box here, every pair whose boxes overlap then is among these pairs (each box
/// lies inside its padded one, so the padded ones overlap too): testing these pairs' boxes
/// of the frame gives the same candidates as a tree would.
struct Detector::KeptPairs {
  const CollisionBody* a = nullptr;
  const CollisionBody* b = nullptr;
  std::array<std::vector<Index>, 2> tets;  ///< A's and B's, sorted
  std::array<std::vector<Aabb>, 2> boxes;  ///< padded, per entry of tets
  std::array<std::vector<Index>, 2> slot;  ///< per tet of the body: entry in tets, or -1
  /// The pairs, each as (A's entry, B's entry) rather than tets (one list made in place),
  /// sorted: the entries follow tet order, so these follow (tet_a, tet_b).
  std::vector<TetPair> pairs;
  /// Per pair, the certificate of its last full overlap test (kOverlapHintUnknown when the
  /// list is made): the narrow phase checks it first (docs/DETECTION.md, "Overlap hints").
  std::vector<OverlapHint> hints;
  /// This call's box of each entry (empty when the broad phase did not keep its tet).
  std::array<std::vector<Aabb>, 2> now;
  /// The margin as a fraction of the mean box extent of the tets near the contact:
  /// halved when a list serves long, doubled when it serves briefly.
  double fraction = 0.02;
  int served = 0;  ///< calls served since made
  /// Calls left before keeping again. A new object pair starts with one: its first call
  /// is served by the tree (a one-off detection, or the first frame of a contact that may
  /// not last, would pay for a list it never uses).
  int pause = 1;
  int pauses = 0;           ///< pauses in a row
  int shorts = 0;           ///< short-lived lists in a row with the widest margin
  std::uint64_t used = 0;   ///< last use (the Detector's count of calls)
  AabbTree tree;            ///< over B's padded boxes, when made
  std::vector<Index> near;  ///< scratch
  /// Each body's box centre at this object pair's last call, and how far it moved in each
  /// of the last two calls (none before there were two): what a list made now is
  /// stretched along (steady_sweep()).
  std::array<Eigen::Vector3d, 2> centre{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  std::array<Eigen::Vector3d, 2> step{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  std::array<Eigen::Vector3d, 2> step_before{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
};

namespace {

/// The margin's fraction of the mean box extent near the contact stays in this range. A
/// list that serves fewer than kKeptShort calls gets a wider margin next time; after two
/// such lists in a row with the widest margin, none is made for kKeptPause calls (contact
/// that moves too fast for kept pairs is not slowed down), and each further pause in a row
/// is twice as long, up to 16 times. A list that serves more than kKeptLong calls gets a
/// narrower margin next time (fewer pairs to test).
constexpr double kKeptMinFraction = 0.005;
constexpr double kKeptMaxFraction = 0.08;
constexpr int kKeptShort = 8;
constexpr int kKeptLong = 64;
constexpr int kKeptPause = 64;
constexpr int kKeptMaxPauseShift = 4;  ///< pauses in a row grow to 16 kKeptPause
/// Object pairs whose kept pairs are held (the least recently used goes first).
constexpr std::size_t kKeptPairsHeld = 16;
/// A body whose box moved the same way in each of the last two calls (a dragged tool, a
/// sliding block) has its kept boxes stretched along that motion for this many calls
/// more, so that a list outlives motion far beyond the margin; at most kKeptMaxSweep mean
/// tet extents near the contact per axis (a jump is not steady motion).
constexpr double kKeptSteps = 16.0;
constexpr double kKeptMaxSweep = 2.0;

/// kKeptSteps calls of the motion both `step` and `before` show, per axis: the smaller of
/// the two moves where they have the same sign, else none; at most `cap` either way.
Eigen::Vector3d steady_sweep(const Eigen::Vector3d& step, const Eigen::Vector3d& before,
                             double cap) {
  Eigen::Vector3d sweep = Eigen::Vector3d::Zero();
  for (int i = 0; i < 3; ++i) {
    const double now = step[i], then = before[i];
    if (!(now * then > 0.0)) continue;  // opposite, still, or not finite
    const double move = now > 0.0 ? std::min(now, then) : std::max(now, then);
    sweep[i] = std::clamp(kKeptSteps * move, -cap, cap);
  }
  return sweep;
}

}  // namespace

Detector::KeptPairs* Detector::kept_of(const CollisionBody& a, const CollisionBody& b) {
  const std::array<const CollisionBody*, 2> bodies = {&a, &b};
  const auto centre_of = [&](std::size_t s) -> Eigen::Vector3d {
    return 0.5 * (bodies[s]->box().lo + bodies[s]->box().hi);
  };
  KeptPairs* k = nullptr;
  for (auto& e : kept_)
    if (e->a == &a && e->b == &b) k = e.get();
  if (k == nullptr) {
    if (kept_.size() >= kKeptPairsHeld)
      kept_.erase(std::min_element(kept_.begin(), kept_.end(),
                                   [](const auto& x, const auto& y) { return x->used < y->used; }));
    kept_.push_back(std::make_unique<KeptPairs>());
    k = kept_.back().get();
    k->a = &a;
    k->b = &b;
    for (std::size_t s = 0; s < 2; ++s) k->centre[s] = centre_of(s);  // first call: no step
  }
  k->used = ++kept_calls_;
  for (std::size_t s = 0; s < 2; ++s) {
    const Eigen::Vector3d centre = centre_of(s);
    k->step_before[s] = k->step[s];
    k->step[s] = centre - k->centre[s];
    k->centre[s] = centre;
  }
  return k;
}

bool Detector::kept_paused(KeptPairs& k) {
  if (k.pause == 0) return false;
  --k.pause;
  return true;
}

bool Detector::candidates_from_kept(KeptPairs* k, CollisionBody& a, CollisionBody& b,
                                    const Aabb& cull, DetectStats& st) {
  const std::array<CollisionBody*, 2> bodies = {&a, &b};
  const std::array<const std::vector<Index>*, 2> subsets = {&subset_a_, &subset_b_};
  const std::array<const std::vector<Aabb>*, 2> boxes_now = {&boxes_a_, &boxes_b_};
  // Whether each tet the broad phase kept is in the lists with its box inside its padded
  // one; on the way, this call's box of each entry.
  const auto covers = [&] {
    for (std::size_t s = 0; s < 2; ++s) {
      const std::vector<Index>& slot = k->slot[s];
      const std::vector<Aabb>& padded = k->boxes[s];
      const std::vector<Index>& tets = *subsets[s];
      const std::vector<Aabb>& boxes = *boxes_now[s];
      std::vector<Aabb>& now = k->now[s];
      if (slot.size() != bodies[s]->tets_.size()) return false;
      now.assign(padded.size(), Aabb{});
      for (std::size_t i = 0; i < tets.size(); ++i) {
        const Index j = slot[static_cast<std::size_t>(tets[i])];
        if (j < 0 || !padded[static_cast<std::size_t>(j)].contains(boxes[i])) return false;
        now[static_cast<std::size_t>(j)] = boxes[i];
      }
    }
    return true;
  };
  if (!covers()) {
    if (!k->tets[0].empty()) {  // a list that served k->served calls: its margin next time
      if (k->served < kKeptShort) {
        // Short-lived: a wider margin next time. Twice in a row with the widest one (a
        // jump of the contact ends one short list, not two), too fast for kept pairs:
        // they sit out, longer each time in a row.
        k->shorts = k->fraction >= kKeptMaxFraction ? k->shorts + 1 : 0;
        if (k->shorts >= 2) {
          k->pause = kKeptPause << std::min(k->pauses++, kKeptMaxPauseShift);
          k->fraction = kKeptMaxFraction / 2;
          k->shorts = 0;
          k->tets[0].clear();
          return false;
        }
        k->fraction = std::min(2 * k->fraction, kKeptMaxFraction);
      } else {
        k->shorts = 0;
        k->pauses = 0;
        if (k->served > kKeptLong) k->fraction = std::max(k->fraction / 2, kKeptMinFraction);
      }
    }
    // Made again, over the tets near the overlap box padded by the margin.
    double extent = 0.0;
    std::size_t count = 0;
    for (std::size_t s = 0; s < 2; ++s)
      for (const Index t : *subsets[s]) {
        const Aabb& raw = bodies[s]->bounds_.boxes[static_cast<std::size_t>(t)];
        extent += (raw.hi - raw.lo).maxCoeff();
        ++count;
      }
    const double mean_extent = count > 0 ? extent / static_cast<double>(count) : 0.0;
    const double margin = k->fraction * mean_extent;
    if (!(margin > 0.0) || !std::isfinite(margin)) return false;
    const Eigen::Vector3d pad = Eigen::Vector3d::Constant(margin);
    // Steady motion of either body (two calls seen moving the same way): its boxes are
    // stretched along it, and the region by both (the overlap box of two translated
    // boxes lies within the overlap box stretched by the two translations).
    std::array<Eigen::Vector3d, 2> sweep;
    for (std::size_t s = 0; s < 2; ++s)
      sweep[s] = steady_sweep(k->step[s], k->step_before[s], kKeptMaxSweep * mean_extent);
    const Aabb region{cull.lo - pad + sweep[0].cwiseMin(sweep[1]).cwiseMin(0.0),
                      cull.hi + pad + sweep[0].cwiseMax(sweep[1]).cwiseMax(0.0)};
    for (std::size_t s = 0; s < 2; ++s) {
      for (const Index t : k->tets[s]) k->slot[s][static_cast<std::size_t>(t)] = -1;
      CollisionBody& body = *bodies[s];
      gather_near(body, region, k->near);
      body.ensure_bounds(k->near, false);
      filter_tets(body, k->near, region, k->tets[s], k->boxes[s]);
      const Eigen::Vector3d lo_pad = pad - sweep[s].cwiseMin(0.0);
      const Eigen::Vector3d hi_pad = pad + sweep[s].cwiseMax(0.0);
      for (Aabb& box : k->boxes[s]) {
        box.lo -= lo_pad;
        box.hi += hi_pad;
      }
      k->slot[s].resize(body.tets_.size(), -1);
      for (std::size_t i = 0; i < k->tets[s].size(); ++i)
        k->slot[s][static_cast<std::size_t>(k->tets[s][i])] = static_cast<Index>(i);
    }
    k->tree.build(k->boxes[1]);
    BvhSide bvh;
    bvh.tree = &k->tree;
    bvh.tet_boxes = k->boxes[1];
    bvh.over_side = true;
    broad_.find_pairs(BroadPhaseKind::kBvh, {k->tets[0], k->boxes[0], a.bounds_.spheres},
                      {k->tets[1], k->boxes[1], b.bounds_.spheres}, bvh, k->pairs);
    for (TetPair& p : k->pairs)
      p = {k->slot[0][static_cast<std::size_t>(p.tet_a)],
           k->slot[1][static_cast<std::size_t>(p.tet_b)]};
    k->hints.assign(k->pairs.size(), kOverlapHintUnknown);
    k->served = 0;
    st.pairs_rebuilt = true;
    if (!covers()) {  // (rounding beyond the margin: not expected)
      k->tets[0].clear();
      return false;
    }
  }
  // This call's candidates: the kept pairs whose boxes of this frame overlap, in order,
  // written without a branch on each.
  const std::vector<TetPair>& pairs = k->pairs;
  const std::size_t chunks = detail::num_chunks(pairs.size(), kKeptChunk);
  detail::reset_parts(pair_parts_, chunks);
  detail::reset_parts(entry_parts_, chunks);
  detail::for_chunks(
      pairs.size(), kKeptChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
        std::vector<TetPair>& part = pair_parts_[c];
        std::vector<Index>& entries = entry_parts_[c];
        part.resize(end - begin);
        entries.resize(end - begin);
        std::size_t kept = 0;
        for (std::size_t i = begin; i < end; ++i) {
          const auto ia = static_cast<std::size_t>(pairs[i].tet_a);  // entries (above)
          const auto ib = static_cast<std::size_t>(pairs[i].tet_b);
          part[kept] = {k->tets[0][ia], k->tets[1][ib]};
          entries[kept] = static_cast<Index>(i);
          kept += k->now[0][ia].overlaps(k->now[1][ib]) ? 1 : 0;
        }
        part.resize(kept);
        entries.resize(kept);
      });
  detail::concat_parts(pair_parts_, chunks, candidates_);
  detail::concat_parts(entry_parts_, chunks, candidate_entries_);
  hints_ = &k->hints;
  ++k->served;
  st.pairs_kept = true;
  return true;
}

void Detector::detect(CollisionBody& a, CollisionBody& b, PairContacts& out, DetectStats* stats,
                      const EdgeNeed& need_edges) {
  const auto start = Clock::now();
  DetectStats st;
  out.overlapping.clear();
  out.marked_a.clear();
  out.marked_b.clear();
  out.nodes_a_in_b.clear();
  out.nodes_b_in_a.clear();
  out.edges_a_in_b.clear();
  out.edges_b_in_a.clear();
  candidates_.clear();
  candidate_entries_.clear();
  hints_ = nullptr;
  if (a.positions_ == nullptr || b.positions_ == nullptr)
    throw std::logic_error("Detector::detect: set_positions() was not called");

  st.boxes_overlap = a.box().overlaps(b.box());
  if (!st.boxes_overlap) {
    st.broad_ms = st.total_ms = ms_since(start);
    if (stats != nullptr) *stats = st;
    return;
  }
  find_candidates(a, b, start, st);
  st.candidates = candidates_.size();
  const auto broad_end = Clock::now();
  st.broad_ms = std::chrono::duration<double, std::milli>(broad_end - start).count();

  index_candidate_tets(a, b);
  narrow_phase(a, b, out);
  st.overlapping = out.overlapping.size();
  for (const std::size_t n : hinted_parts_) st.hinted += n;
  mark_tets(out);

  const auto intrusion_start = Clock::now();
  find_intrusions(a, b, out, need_edges);
  clear_slots(geom_a_);
  clear_slots(geom_b_);
  st.intrusion_ms = ms_since(intrusion_start);

  st.narrow_ms = ms_since(broad_end);
  st.total_ms = ms_since(start);
  if (stats != nullptr) *stats = st;
}

void Detector::find_candidates(CollisionBody& a, CollisionBody& b, Clock::time_point start,
                               DetectStats& st) {
  const BroadPhaseKind kind = options_.broad_phase;
  // Only the tets of the clusters that meet the overlap box of the two objects get
  // bounds and the filter below: a small tool in a large organ costs what the part of
  // the organ near the tool costs, not the whole organ.
  const Aabb cull = a.box().intersection(b.box());
  gather_near(a, cull, near_a_);
  gather_near(b, cull, near_b_);
  st.tets_a_near = near_a_.size();
  st.tets_b_near = near_b_.size();
  const bool spheres = kind == BroadPhaseKind::kGrid;
  // kBvh: B's persistent tree (refitted over all of B) when most of B is near the
  // overlap, else a tree built over the few tets of B that pass the filter. Both give
  // the same pairs.
  const bool full_tree = kind == BroadPhaseKind::kBvh &&
                         (!options_.cluster_cull || 2 * near_b_.size() > b.tets_.size());
  // Kept pairs need no tree: B's bounds where it is near, as for a local tree.
  KeptPairs* const kept_pairs =
      kind == BroadPhaseKind::kBvh && options_.keep_pairs ? kept_of(a, b) : nullptr;
  const bool keep = kept_pairs != nullptr && !kept_paused(*kept_pairs);
  if (full_tree && !keep)
    b.prepare(kind);
  else
    b.ensure_bounds(near_b_, spheres);
  a.ensure_bounds(near_a_, spheres);
  st.bounds_ms = ms_since(start);

  // Tets whose box meets the overlap box of the two objects: the only ones that can
  // overlap anything of the other object (filter_tets()).
  filter_tets(a, near_a_, cull, subset_a_, boxes_a_);
  filter_tets(b, near_b_, cull, subset_b_, boxes_b_);
  st.tets_a_in_box = subset_a_.size();
  st.tets_b_in_box = subset_b_.size();

  const bool from_kept = keep && candidates_from_kept(kept_pairs, a, b, cull, st);
  if (!from_kept) candidates_from_broad_phase(a, b, full_tree, keep, st);
  drop_left_out(a, b);
}

void Detector::candidates_from_broad_phase(const CollisionBody& a, CollisionBody& b, bool full_tree,
                                           bool keep, DetectStats& st) {
  const BroadPhaseKind kind = options_.broad_phase;
  if (full_tree && keep) b.prepare(kind);  // (its bounds were made near the contact only)
  BvhSide bvh;
  if (full_tree) {
    if (box_slot_.size() < b.tets_.size()) box_slot_.resize(b.tets_.size(), -1);
    for (std::size_t k = 0; k < subset_b_.size(); ++k)
      box_slot_[subset_b_[k]] = static_cast<Index>(k);
    bvh = {&b.tree_, b.bounds_.boxes, box_slot_};
  } else if (kind == BroadPhaseKind::kBvh) {
    // A local tree. Any tree over these boxes answers the same (a refit makes every
    // node box exact); only its shape, and so the query cost, depends on where the
    // boxes were when it was built: rebuilt when the tets change, and every
    // kLocalTreeRefits frames.
    if (local_tree_body_ == &b && local_tree_refits_ < kLocalTreeRefits &&
        local_tree_tets_ == subset_b_) {
      local_tree_.refit(boxes_b_);
      ++local_tree_refits_;
      st.local_tree_refitted = true;
    } else {
      local_tree_.build(boxes_b_);
      local_tree_body_ = &b;
      local_tree_tets_ = subset_b_;
      local_tree_refits_ = 0;
    }
    bvh.tree = &local_tree_;
    bvh.tet_boxes = boxes_b_;
    bvh.over_side = true;
  }
  broad_.find_pairs(kind, {subset_a_, boxes_a_, a.bounds_.spheres},
                    {subset_b_, boxes_b_, b.bounds_.spheres}, bvh, candidates_);
  if (full_tree)
    for (const Index t : subset_b_) box_slot_[t] = -1;
}

void Detector::drop_left_out(const CollisionBody& a, const CollisionBody& b) {
  if (!a.left_out_.empty() || !b.left_out_.empty()) {
    // Tets left out of contact (set_left_out_tets()): no pair with them is tested, so they
    // are never marked and never host an intruding node or edge. The kept pairs keep
    // them: a tet left out this frame may take part in the next.
    const auto out_of = [](const std::vector<Index>& list, Index t) {
      return !list.empty() && std::binary_search(list.begin(), list.end(), t);
    };
    std::erase_if(candidates_, [&](const TetPair& p) {
      return out_of(a.left_out_, p.tet_a) || out_of(b.left_out_, p.tet_b);
    });
    // (The hints follow the candidates they were made for: none this call.)
    candidate_entries_.clear();
    hints_ = nullptr;
  }
}

void Detector::index_candidate_tets(const CollisionBody& a, const CollisionBody& b) {
  geom_a_.tets.clear();
  for (const TetPair& p : candidates_)
    if (geom_a_.tets.empty() || geom_a_.tets.back() != p.tet_a) geom_a_.tets.push_back(p.tet_a);
  geom_b_.tets.clear();
  {
    detail::SortedIndexSet set(bits_, b.tets_.size());
    for (const TetPair& p : candidates_) set.insert(p.tet_b);
    set.drain(geom_b_.tets);
  }
  index_tets(a, geom_a_);
  index_tets(b, geom_b_);
  ++geometry_stamp_;
  if (detail::single_thread()) {
    // Every chunk below runs on this thread: all the geometry now, in slot order.
    auto& copy = thread_geometry_->local(geom_a_.tets.size(), geom_b_.tets.size());
    const auto same = [](std::size_t k) { return k; };
    build_slots(*a.positions_, a.tets_, geom_a_.tets, geom_a_.tets.size(), same, copy.geom[0]);
    build_slots(*b.positions_, b.tets_, geom_b_.tets, geom_b_.tets.size(), same, copy.geom[1]);
    copy.all_built = geometry_stamp_;
  }
}

namespace {

/// The narrow phase of n <= kNarrowChunk candidates with kept pairs' hints: hits[i] for
/// candidates[i], entries[i] its entry in `hints`. The pairs whose hint holds are decided by
/// it; the others get the full test (their geometry gathered in `pairs`), then a hint made
/// again from its answer. Returns how many the hints decided.
template <typename GeometryOfPair>
std::size_t test_with_hints(std::span<const TetPair> candidates, std::span<const Index> entries,
                            std::vector<OverlapHint>& hints, double rel,
                            const GeometryOfPair& geometry_of,
                            std::array<GeometryPair, kNarrowChunk>& pairs,
                            std::array<bool, kNarrowChunk>& hits) {
  const std::size_t n = candidates.size();
  std::array<std::uint16_t, kNarrowChunk> open;
  std::size_t num_open = 0, decided = 0;
  // How many pairs ahead B's geometry is asked for (B's tets come scattered): its box, the
  // face normals and the corners, what a hint reads.
  constexpr std::size_t kAhead = 4;
  for (std::size_t i = 0; i < n; ++i) {
    if (i + kAhead < n) {
      const char* next = reinterpret_cast<const char*>(geometry_of(candidates[i + kAhead]).b);
      for (std::size_t off = 0; off < 384; off += 64) __builtin_prefetch(next + off);
    }
    const GeometryPair g = geometry_of(candidates[i]);
    const OverlapHint h = hints[static_cast<std::size_t>(entries[i])];
    const int answer = h == kOverlapHintUnknown || h == kOverlapHintNone
                           ? -1
                           : check_overlap_hint(*g.a, *g.b, rel, h);
    if (answer >= 0) {
      hits[i] = answer == 1;
      ++decided;
    } else {
      pairs[num_open] = g;
      open[num_open++] = static_cast<std::uint16_t>(i);
    }
  }
  std::array<bool, kNarrowChunk> open_hits;
  tets_overlap_pairs({pairs.data(), num_open}, rel, {open_hits.data(), num_open});
  for (std::size_t j = 0; j < num_open; ++j) {
    const std::size_t i = open[j];
    hits[i] = open_hits[j];
    OverlapHint& h = hints[static_cast<std::size_t>(entries[i])];
    // A pair without a hint is not looked at again until the list is made again (it lies
    // within the margins, and would be every frame).
    if (h != kOverlapHintNone) {
      const GeometryPair& g = pairs[j];
      h = find_overlap_hint(*g.a, *g.b, rel, open_hits[j]);
    }
  }
  return decided;
}

}  // namespace

void Detector::narrow_phase(const CollisionBody& a, const CollisionBody& b, PairContacts& out) {
  const double rel = relative_tolerance();
  const std::size_t chunks = detail::num_chunks(candidates_.size(), kNarrowChunk);
  detail::reset_parts(pair_parts_, chunks);
  hinted_parts_.assign(chunks, 0);
  detail::for_chunks(
      candidates_.size(), kNarrowChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
        // This thread's geometry of the chunk's tets, built now where it has not yet
        // been in this call (A's tets come in order, B's scattered).
        auto& copy = thread_geometry_->local(geom_a_.tets.size(), geom_b_.tets.size());
        const std::uint64_t stamp = geometry_stamp_;
        const auto gather = [&](std::size_t w, const Geometry& g, auto tet_of) {
          copy.missing.clear();
          if (copy.all_built == stamp) return;  // the calling thread of a one-thread call
          for (std::size_t i = begin; i < end; ++i) {
            const Index slot = g.slot[tet_of(candidates_[i])];
            if (copy.claim(w, slot, stamp)) copy.missing.push_back(slot);
          }
        };
        const auto missing = [&](std::size_t k) {
          return static_cast<std::size_t>(copy.missing[k]);
        };
        gather(0, geom_a_, [](const TetPair& p) { return p.tet_a; });
        build_slots(*a.positions_, a.tets_, geom_a_.tets, copy.missing.size(), missing,
                    copy.geom[0]);
        gather(1, geom_b_, [](const TetPair& p) { return p.tet_b; });
        build_slots(*b.positions_, b.tets_, geom_b_.tets, copy.missing.size(), missing,
                    copy.geom[1]);
        std::array<GeometryPair, kNarrowChunk> pairs;
        std::array<bool, kNarrowChunk> hits;
        const std::size_t n = end - begin;
        const auto geometry_of = [&](const TetPair& p) -> GeometryPair {
          return {&copy.geom[0][static_cast<std::size_t>(geom_a_.slot[p.tet_a])],
                  &copy.geom[1][static_cast<std::size_t>(geom_b_.slot[p.tet_b])]};
        };
        if (hints_ == nullptr) {
          for (std::size_t i = 0; i < n; ++i) pairs[i] = geometry_of(candidates_[begin + i]);
          tets_overlap_pairs({pairs.data(), n}, rel, {hits.data(), n});
        } else {
          hinted_parts_[c] =
              test_with_hints(std::span<const TetPair>(candidates_).subspan(begin, n),
                              std::span<const Index>(candidate_entries_).subspan(begin, n), *hints_,
                              rel, geometry_of, pairs, hits);
        }
        // The overlapping ones kept in order, without a branch on each (about half of
        // the candidates overlap, in no pattern a branch predictor could learn).
        std::vector<TetPair>& part = pair_parts_[c];
        std::size_t kept = part.size();
        part.resize(kept + n);
        for (std::size_t i = 0; i < n; ++i) {
          part[kept] = candidates_[begin + i];
          kept += hits[i] ? 1 : 0;
        }
        part.resize(kept);
      });
  detail::concat_parts(pair_parts_, chunks, out.overlapping);
}

void Detector::mark_tets(PairContacts& out) {
  // Marked tets and, for each, the tets of the other object it overlaps (as geometry
  // slots, which follow tet order).
  // Both lists are written without a branch on "a new tet": each entry goes to the next
  // free place, which only a new tet keeps (whether a pair starts a new tet follows no
  // pattern a branch predictor could learn).
  const std::size_t num_overlapping = out.overlapping.size();
  rows_a_.items.resize(num_overlapping);
  out.marked_a.resize(num_overlapping);
  rows_a_.offsets.resize(num_overlapping + 1);
  {
    std::size_t rows = 0;
    Index previous = -1;  // no tet
    for (std::size_t i = 0; i < num_overlapping; ++i) {
      const TetPair& p = out.overlapping[i];
      out.marked_a[rows] = p.tet_a;
      rows_a_.offsets[rows] = static_cast<Index>(i);
      rows += p.tet_a != previous ? 1 : 0;
      previous = p.tet_a;
      rows_a_.items[i] = geom_b_.slot[p.tet_b];
    }
    out.marked_a.resize(rows);
    rows_a_.offsets.resize(rows);
  }
  rows_a_.offsets.push_back(static_cast<Index>(num_overlapping));

  // B's rows: a counting sort of the pairs on tet_b's slot. The pairs come sorted by
  // (tet_a, tet_b), so each row of B receives its tets of A in increasing order.
  counts_.assign(geom_b_.tets.size(), 0);
  for (const TetPair& p : out.overlapping) ++counts_[geom_b_.slot[p.tet_b]];
  out.marked_b.resize(geom_b_.tets.size());
  rows_b_.offsets.resize(geom_b_.tets.size() + 1);
  Index filled = 0;
  {
    std::size_t rows = 0;
    for (std::size_t s = 0; s < geom_b_.tets.size(); ++s) {
      const Index count = counts_[s];
      out.marked_b[rows] = geom_b_.tets[s];
      rows_b_.offsets[rows] = filled;
      rows += count > 0 ? 1 : 0;
      counts_[s] = filled;
      filled += count;
    }
    out.marked_b.resize(rows);
    rows_b_.offsets.resize(rows);
  }
  rows_b_.offsets.push_back(filled);
  rows_b_.items.resize(num_overlapping);
  for (const TetPair& p : out.overlapping)
    rows_b_.items[counts_[geom_b_.slot[p.tet_b]]++] = geom_a_.slot[p.tet_a];
}

void Detector::find_intrusions(CollisionBody& a, CollisionBody& b, PairContacts& out,
                               const EdgeNeed& need_edges) {
  std::array<bool, 2> edges = {options_.intruding_edges, options_.intruding_edges};
  if (options_.intruding_edges && need_edges && !out.overlapping.empty()) edges = need_edges(out);
  if (!out.overlapping.empty() && (options_.intruding_nodes || edges[0] || edges[1])) {
    if (edges[0]) a.prepare_edges();
    if (edges[1]) b.prepare_edges();
    for (int side = 0; side < 2; ++side) {
      const CollisionBody& x = side == 0 ? a : b;
      const CollisionBody& y = side == 0 ? b : a;
      const Geometry& gy = side == 0 ? geom_b_ : geom_a_;
      const std::vector<Index>& marked = side == 0 ? out.marked_a : out.marked_b;
      const Rows& rows = side == 0 ? rows_a_ : rows_b_;
      if (row_of_.size() < x.tets_.size()) row_of_.resize(x.tets_.size(), -1);
      for (std::size_t r = 0; r < marked.size(); ++r) row_of_[marked[r]] = static_cast<Index>(r);
      const int gy_side = 1 - side;
      if (options_.intruding_nodes)
        intruding_nodes(x, marked, rows, y, gy, gy_side,
                        side == 0 ? out.nodes_a_in_b : out.nodes_b_in_a);
      if (edges[static_cast<std::size_t>(side)])
        intruding_edges(x, marked, rows, y, gy, gy_side,
                        side == 0 ? out.edges_a_in_b : out.edges_b_in_a);
      for (const Index t : marked) row_of_[t] = -1;
    }
  }
}

void Detector::collect_features(std::span<const Index> marked, const CollisionBody& x, bool edges) {
  // The nodes (or edges) of the marked tets of X, each once, sorted.
  const std::size_t count = edges ? x.edges_.size() : static_cast<std::size_t>(x.num_nodes_);
  detail::SortedIndexSet set(bits_, count);
  for (const Index t : marked) {
    if (edges) {
      for (const Index e : x.tet_edges_[t]) set.insert(e);
    } else {
      for (const Index v : x.tets_[t]) set.insert(v);
    }
  }
  features_.clear();
  set.drain(features_);
}

namespace {

/// Per-thread visit marks over the candidate tets of Y (by slot): a tet reached again
/// through another tet of X around the same node or edge is skipped. Only used for dedup, so
/// the output does not depend on which thread ran what.
struct VisitMarks {
  std::vector<std::uint64_t> mark;
  std::uint64_t now = 0;
  // intruding_edges, one edge at a time, reused: the tets whose box the edge meets (their
  // geometry slot is target.tet - geom) and their clips.
  std::vector<ClipTarget> clip_targets;
  std::vector<SegmentClip> clips;
  std::vector<detail::EdgeHit> hits;
};
thread_local VisitMarks t_marks;

/// The box [slo, shi] meets [lo - tol, hi + tol]: Eigen's (slo <= hi + tol).all() && (shi
/// >= lo - tol).all(), the same six comparisons of the same sums, combined with & and not
/// && (the scans test thousands of boxes a frame, and a chain of six branches that go either
/// way mispredicts more than the comparisons cost).
inline bool meets_padded_box(const Eigen::Vector3d& slo, const Eigen::Vector3d& shi,
                             const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double tol) {
  // As 0/1 integers: & of bools reads as a typo for && to clang (-Wbitwise-instead-of-logical).
  const auto bit = [](bool b) { return static_cast<unsigned>(b); };
  return (bit(slo.x() <= hi.x() + tol) & bit(slo.y() <= hi.y() + tol) &
          bit(slo.z() <= hi.z() + tol) & bit(shi.x() >= lo.x() - tol) &
          bit(shi.y() >= lo.y() - tol) & bit(shi.z() >= lo.z() - tol)) != 0;
}

}  // namespace

void Detector::intruding_nodes(const CollisionBody& x, std::span<const Index> marked,
                               const Rows& rows, const CollisionBody& y, const Geometry& gy,
                               int gy_side, std::vector<IntrudingNode>& out) {
  collect_features(marked, x, false);
  const Positions& px = *x.positions_;
  const double rel = relative_tolerance();
  // The tests below accept p only inside a tet's box padded by rel * its scale, which
  // lies inside this one (IEEE rounding is monotonic): a node outside it (most nodes of
  // the marked tets, on the far side of the contact) skips its rows.
  const double reach_tol = rel * gy.reach.scale;
  const Eigen::Array3d reach_lo = gy.reach.lo.array() - reach_tol;
  const Eigen::Array3d reach_hi = gy.reach.hi.array() + reach_tol;
  const std::size_t chunks = detail::num_chunks(features_.size(), kFeatureChunk);
  detail::reset_parts(node_parts_, chunks);
  detail::for_chunks(
      features_.size(), kFeatureChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
        VisitMarks& marks = t_marks;
        if (marks.mark.size() < gy.tets.size()) marks.mark.resize(gy.tets.size(), 0);
        GeometryOf geometry(thread_geometry_->local(geom_a_.tets.size(), geom_b_.tets.size()),
                            gy_side, geometry_stamp_, *y.positions_, y.tets_, gy.tets);
        for (std::size_t i = begin; i < end; ++i) {
          const Index node = features_[i];
          const Eigen::Vector3d p = px.col(node);
          if (!((p.array() >= reach_lo).all() && (p.array() <= reach_hi).all())) continue;
          // The first tet of Y (in tet order) containing the node, among the tets
          // overlapped by the marked tets around it. Rows repeat tets: a tet
          // already tested for this node (it did not contain it) or not before the
          // best found so far is skipped, so no need to sort them.
          // Slots follow tet order: the smallest slot is the first tet.
          Index best = std::numeric_limits<Index>::max();
          Eigen::Vector4d bary = Eigen::Vector4d::Zero();
          const std::uint64_t now = ++marks.now;
          for (const Index t : x.node_tets().row(node)) {
            const Index r = row_of_[t];
            if (r < 0) continue;
            for (Index k = rows.offsets[r]; k < rows.offsets[r + 1]; ++k) {
              const Index slot = rows.items[k];
              if (slot >= best) break;  // rows are sorted
              // Not tested yet for this node, and p in its padded box: one branch for
              // both (each goes either way; the box of a repeat was just read, so it is
              // in the L1 cache).
              const bool fresh = marks.mark[slot] != now;
              marks.mark[slot] = now;
              const TetBox& box = gy.boxes[slot];
              const double tol = rel * box.scale;
              const bool in_box = meets_padded_box(p, p, box.lo, box.hi, tol);
              if ((static_cast<unsigned>(fresh) & static_cast<unsigned>(in_box)) == 0) continue;
              const PointInTet hit = point_in_tet(p, geometry(slot), tol);
              if (hit.inside) {
                best = slot;
                bary = hit.bary;
                break;
              }
            }
          }
          if (best != std::numeric_limits<Index>::max())
            node_parts_[c].push_back({node, gy.tets[best], bary});
        }
      });
  detail::concat_parts(node_parts_, chunks, out);
}

void Detector::intruding_edges(const CollisionBody& x, std::span<const Index> marked,
                               const Rows& rows, const CollisionBody& y, const Geometry& gy,
                               int gy_side, std::vector<IntrudingEdge>& out) {
  collect_features(marked, x, true);
  const Positions& px = *x.positions_;
  const double rel = relative_tolerance();
  const std::size_t chunks = detail::num_chunks(features_.size(), kFeatureChunk);
  detail::reset_parts(edge_parts_, chunks);
  detail::for_chunks(
      features_.size(), kFeatureChunk, [&](std::size_t begin, std::size_t end, std::size_t c) {
        VisitMarks& marks = t_marks;
        if (marks.mark.size() < gy.tets.size()) marks.mark.resize(gy.tets.size(), 0);
        std::vector<detail::EdgeHit>& hits = marks.hits;
        std::vector<IntrudingEdge>& part = edge_parts_[c];
        const Index* const row_of = row_of_.data();
        const Index* const offsets = rows.offsets.data();
        const Index* const items = rows.items.data();
        const TetBox* const boxes = gy.boxes.data();
        GeometryOf geometry(thread_geometry_->local(geom_a_.tets.size(), geom_b_.tets.size()),
                            gy_side, geometry_stamp_, *y.positions_, y.tets_, gy.tets);
        const TetGeometry* const geom = geometry.base();
        for (std::size_t i = begin; i < end; ++i) {
          const Index edge = features_[i];
          const Eigen::Vector3d p0 = px.col(x.edges_[edge][0]);
          const Eigen::Vector3d p1 = px.col(x.edges_[edge][1]);
          const Eigen::Vector3d lo = p0.cwiseMin(p1), hi = p0.cwiseMax(p1);
          const double length = (p1 - p0).norm();
          {
            // As for the nodes: every box test below passes only inside this one.
            const double tol = rel * std::max(gy.reach.scale, length);
            if (!meets_padded_box(lo, hi, gy.reach.lo, gy.reach.hi, tol)) continue;
          }
          const std::uint64_t now = ++marks.now;
          // Local pointers: a vector's growth is a call, after which the compiler would
          // otherwise reload the marks and rows through the thread-local on every visit.
          std::uint64_t* const mark = marks.mark.data();
          marks.clip_targets.clear();
          // Every tet of Y overlapped by a marked tet of X around the edge, once (an edge has
          // ~15 such visits here for ~9 distinct tets, ~5.5 clipped, ~1.8 hit).
          for (const Index t : x.edge_tets_.row(edge)) {
            const Index r = row_of[t];
            if (r < 0) continue;
            for (const Index *k = items + offsets[r], *kend = items + offsets[r + 1]; k != kend;
                 ++k) {
              const Index slot = *k;
              if (mark[slot] == now) continue;
              mark[slot] = now;
              const TetBox& box = boxes[slot];
              const double tol = rel * std::max(box.scale, length);
              if (!meets_padded_box(lo, hi, box.lo, box.hi, tol)) continue;
              marks.clip_targets.push_back({&geometry(slot), tol});
            }
          }
          const std::size_t n = marks.clip_targets.size();
          if (n == 0) continue;
          if (marks.clips.size() < n) marks.clips.resize(n);
          clip_segment_tets(p0, p1, marks.clip_targets, marks.clips);
          hits.clear();
          for (std::size_t j = 0; j < n; ++j) {
            const SegmentClip& clip = marks.clips[j];
            const ClipTarget& target = marks.clip_targets[j];
            if (clip.hit)
              hits.push_back({{edge, gy.tets[target.tet - geom], clip.lambda_in, clip.lambda_out},
                              target.tolerance / length});
          }
          if (hits.empty()) continue;
          if (hits.size() > 1)
            std::sort(hits.begin(), hits.end(),
                      [](const detail::EdgeHit& u, const detail::EdgeHit& v) {
                        return u.edge.tet < v.edge.tet;
                      });
          detail::append_edge_hits(hits, part);
        }
      });
  detail::concat_parts(edge_parts_, chunks, out);
}

// ---------------------------------------------------------------------------- one-offs

PairContacts detect_pair(const Positions& positions_a, std::span<const Tet> tets_a,
                         const Topology& topology_a, const Positions& positions_b,
                         std::span<const Tet> tets_b, const Topology& topology_b,
                         const DetectOptions& options, DetectStats* stats) {
  CollisionBody a(tets_a, topology_a);
  CollisionBody b(tets_b, topology_b);
  a.set_positions(positions_a);
  b.set_positions(positions_b);
  Detector detector(options);
  PairContacts out;
  detector.detect(a, b, out, stats);
  return out;
}

std::vector<std::pair<Index, Index>> touching_object_pairs(
    std::span<const Aabb> boxes, const std::function<bool(Index, Index)>& enabled) {
  std::vector<std::pair<Index, Index>> pairs;
  const Index k = static_cast<Index>(boxes.size());
  for (Index i = 0; i < k; ++i)
    for (Index j = i + 1; j < k; ++j)
      if (boxes[i].overlaps(boxes[j]) && (!enabled || enabled(i, j))) pairs.emplace_back(i, j);
  return pairs;
}

}  // namespace tc
