#include "core/detect/broad_phase.hpp"

#include <tbb/parallel_invoke.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <utility>

#include "core/common/chunked.hpp"
#include "core/mesh/geometry.hpp"

namespace tc {
namespace {

using Eigen::Vector3d;

constexpr double kEps = std::numeric_limits<double>::epsilon();
/// Tets of A per chunk of the parallel query loops.
constexpr std::size_t kQueryChunk = 64;
/// Subtree depth above which AabbTree::refit forks.
constexpr int kRefitParallelDepth = 6;

/// Per-thread hit list of one tree query (bvh_pairs), reused across chunks and frames.
thread_local std::vector<Index> t_found;

bool sphere_overlap(const BoundingSphere& a, const BoundingSphere& b) {
  const double r = a.radius + b.radius;
  return a.radius >= 0.0 && b.radius >= 0.0 && (a.center - b.center).squaredNorm() <= r * r;
}

/// Cell lattice over a region: cell (i, j, k) covers lo + h [i, i+1) x ...
struct Lattice {
  Vector3d lo = Vector3d::Zero();
  double h = 1.0;
  std::array<std::int64_t, 3> dims = {1, 1, 1};

  /// Cell coordinate of x along axis d, clamped into the lattice.
  [[nodiscard]] std::int32_t coord(double x, int d) const {
    const double c = std::floor((x - lo[d]) / h);
    const double clamped = std::clamp(c, 0.0, static_cast<double>(dims[d] - 1));
    return static_cast<std::int32_t>(clamped);
  }
  [[nodiscard]] std::array<std::int32_t, 3> low(const Aabb& b) const {
    return {coord(b.lo.x(), 0), coord(b.lo.y(), 1), coord(b.lo.z(), 2)};
  }
  [[nodiscard]] std::array<std::int32_t, 3> high(const Aabb& b) const {
    return {coord(b.hi.x(), 0), coord(b.hi.y(), 1), coord(b.hi.z(), 2)};
  }
  [[nodiscard]] std::int64_t index(std::int32_t i, std::int32_t j, std::int32_t k) const {
    return i + dims[0] * (j + dims[1] * static_cast<std::int64_t>(k));
  }
};

/// Sets the lattice dims over `region` for cell size h, growing h until the lattice has
/// at most `max_cells` cells (and at most 2^20 per axis).
void size_lattice(Lattice& lat, const Aabb& region, double h, double max_cells) {
  const Vector3d ext = (region.hi - region.lo).cwiseMax(0.0);
  const double max_ext = ext.maxCoeff();
  if (!(h > 0.0) || !std::isfinite(h)) h = max_ext > 0.0 ? max_ext : 1.0;
  lat.lo = region.lo;
  for (int iter = 0; iter < 64; ++iter) {
    double total = 1.0;
    bool ok = true;
    for (int d = 0; d < 3; ++d) {
      const double n = std::max(1.0, std::ceil(ext[d] / h));
      ok = ok && n <= double(1 << 20);
      total *= n;
    }
    if (ok && total <= max_cells) break;
    const double grow = std::isfinite(total) ? std::cbrt(total / max_cells) : 2.0;
    h *= std::max(grow, 1.0) * 1.01 + kEps;
    if (!std::isfinite(h)) h = max_ext > 0.0 ? max_ext : 1.0;
  }
  lat.h = h;
  for (int d = 0; d < 3; ++d)
    lat.dims[d] = static_cast<std::int64_t>(std::max(1.0, std::ceil(ext[d] / h)));
}

/// Sorts each tet of A's run of pairs by b (pairs of one tet are appended together).
void sort_tail(std::vector<TetPair>& part, std::size_t start) {
  std::sort(part.begin() + static_cast<std::ptrdiff_t>(start), part.end());
}

std::uint64_t next_prime(std::uint64_t n) {
  if (n <= 2) return 2;
  if (n % 2 == 0) ++n;
  for (;; n += 2) {
    bool prime = true;
    for (std::uint64_t d = 3; d * d <= n; d += 2)
      if (n % d == 0) {
        prime = false;
        break;
      }
    if (prime) return n;
  }
}

/// Teschner et al. 2003 hash of a cell, modulo the table size.
std::uint64_t cell_hash(std::int32_t i, std::int32_t j, std::int32_t k, std::uint64_t size) {
  const std::uint64_t h = (static_cast<std::uint64_t>(i) * 73856093ULL) ^
                          (static_cast<std::uint64_t>(j) * 19349663ULL) ^
                          (static_cast<std::uint64_t>(k) * 83492791ULL);
  return h % size;
}

}  // namespace

std::string_view broad_phase_name(BroadPhaseKind kind) {
  switch (kind) {
    case BroadPhaseKind::kGrid:
      return "grid";
    case BroadPhaseKind::kHash:
      return "hash";
    case BroadPhaseKind::kSap:
      return "sap";
    case BroadPhaseKind::kBvh:
      return "bvh";
  }
  return "grid";
}

std::optional<BroadPhaseKind> parse_broad_phase(std::string_view name) {
  for (const BroadPhaseKind k :
       {BroadPhaseKind::kGrid, BroadPhaseKind::kHash, BroadPhaseKind::kSap, BroadPhaseKind::kBvh})
    if (broad_phase_name(k) == name) return k;
  return std::nullopt;
}

namespace {

/// Box (and sphere when `sphere` is set) of one tet.
void tet_bounds(const Positions& positions, const Tet& t, Aabb& box_out, BoundingSphere* sphere) {
  const Vector3d c0 = positions.col(t[0]), c1 = positions.col(t[1]), c2 = positions.col(t[2]),
                 c3 = positions.col(t[3]);
  const Aabb box{c0.cwiseMin(c1).cwiseMin(c2.cwiseMin(c3)),
                 c0.cwiseMax(c1).cwiseMax(c2.cwiseMax(c3))};
  // Checked corner by corner (min/max may drop a NaN): x - x is 0 for a finite x and NaN
  // for an infinite or NaN one, so the sum is 0 exactly when all 12 are finite (no
  // overflow is possible), with fewer branches than 12 isfinite tests.
  const Vector3d zero_if_finite = ((c0 - c0) + (c1 - c1)) + ((c2 - c2) + (c3 - c3));
  const bool finite = (zero_if_finite.array() == 0.0).all();
  box_out = finite ? box : Aabb{};
  if (sphere == nullptr) return;
  if (!finite) {
    *sphere = BoundingSphere{};
    return;
  }
  const Vector3d center = 0.25 * (c0 + c1 + c2 + c3);
  const double r2 = std::max(std::max((c0 - center).squaredNorm(), (c1 - center).squaredNorm()),
                             std::max((c2 - center).squaredNorm(), (c3 - center).squaredNorm()));
  // A hair larger than the rounded radius, so the sphere surely holds the corners.
  *sphere = {center, std::sqrt(r2) * (1.0 + 16.0 * kEps)};
}

}  // namespace

void TetBounds::compute(const Positions& positions, std::span<const Tet> tets, bool with_spheres) {
  const std::size_t m = tets.size();
  boxes.resize(m);
  if (with_spheres) spheres.resize(m);  // else kept: entries made earlier stay valid
  detail::for_chunks(m, 2048, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t i = begin; i < end; ++i)
      tet_bounds(positions, tets[i], boxes[i], with_spheres ? &spheres[i] : nullptr);
  });
}

void TetBounds::compute(const Positions& positions, std::span<const Tet> tets,
                        std::span<const Index> which, bool with_spheres) {
  const std::size_t m = tets.size();
  if (boxes.size() != m) boxes.resize(m);
  if (with_spheres && spheres.size() != m) spheres.resize(m);
  detail::for_chunks(which.size(), 2048, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t i = begin; i < end; ++i) {
      const auto t = static_cast<std::size_t>(which[i]);
      tet_bounds(positions, tets[t], boxes[t], with_spheres ? &spheres[t] : nullptr);
    }
  });
}

// ---------------------------------------------------------------------------- AabbTree

namespace {

/// Items from which AabbTree::build forks its two halves.
constexpr std::size_t kBuildParallelItems = 512;

/// {nodes of a tree over n items, nodes over n + 1}: AabbTree::build splits at the
/// median down to leaves of at most 4 items. O(log n).
std::pair<Index, Index> tree_node_counts(std::size_t n) {
  if (n <= 3) return {1, 1};
  if (n == 4) return {1, 3};
  const auto [p, q] = tree_node_counts(n / 2);
  return n % 2 == 0 ? std::pair{1 + 2 * p, 1 + p + q} : std::pair{1 + p + q, 1 + 2 * q};
}

}  // namespace

Index AabbTree::nodes_for(std::size_t items) {
  return tree_node_counts(items).first;
}

void AabbTree::build(std::span<const Aabb> boxes) {
  nodes_.clear();
  items_.resize(boxes.size());
  std::iota(items_.begin(), items_.end(), Index{0});
  if (boxes.empty()) return;
  std::vector<Vector3d> centers(boxes.size());
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const Vector3d c = 0.5 * (boxes[i].lo + boxes[i].hi);
    centers[i] = c.allFinite() ? c : Vector3d::Zero();
  }
  // Every subtree's size, and so its place in the pre-order, is known before it is
  // built: the two halves of a large node are built at once, into the same nodes the
  // serial recursion fills.
  nodes_.assign(static_cast<std::size_t>(nodes_for(boxes.size())), Node{});
  build_node(items_, centers, 0, 0);
  refit(boxes);
}

void AabbTree::build_node(std::span<Index> items, std::span<const Vector3d> centers, Index first,
                          Index node) {
  if (items.size() <= 4) {
    nodes_[node].first = first;
    nodes_[node].count = static_cast<Index>(items.size());
    return;
  }
  Aabb cb;
  for (const Index i : items) cb.extend(centers[i]);
  const Vector3d ext = cb.hi - cb.lo;
  int axis = 0;
  if (ext.y() > ext[axis]) axis = 1;
  if (ext.z() > ext[axis]) axis = 2;
  const std::size_t mid = items.size() / 2;
  std::nth_element(items.begin(), items.begin() + static_cast<std::ptrdiff_t>(mid), items.end(),
                   [&](Index x, Index y) {
                     const double cx = centers[x][axis], cy = centers[y][axis];
                     return cx < cy || (cx == cy && x < y);
                   });
  const Index right = node + 1 + nodes_for(mid);
  nodes_[node].right = right;
  const auto left_half = [&] { build_node(items.first(mid), centers, first, node + 1); };
  const auto right_half = [&] {
    build_node(items.subspan(mid), centers, first + static_cast<Index>(mid), right);
  };
  if (items.size() >= kBuildParallelItems) {
    tbb::parallel_invoke(left_half, right_half);
  } else {
    left_half();
    right_half();
  }
}

void AabbTree::refit(std::span<const Aabb> boxes) {
  if (!nodes_.empty()) refit_node(0, boxes, 0);
}

void AabbTree::refit_node(Index node, std::span<const Aabb> boxes, int depth) {
  Node& n = nodes_[node];
  if (n.count > 0) {
    Aabb box;
    for (Index i = n.first; i < n.first + n.count; ++i) box.extend(boxes[items_[i]]);
    n.box = box;
    return;
  }
  const Index left = node + 1, right = n.right;
  if (depth < kRefitParallelDepth && n.right - node > 2048) {
    tbb::parallel_invoke([&] { refit_node(left, boxes, depth + 1); },
                         [&] { refit_node(right, boxes, depth + 1); });
  } else {
    refit_node(left, boxes, depth + 1);
    refit_node(right, boxes, depth + 1);
  }
  n.box = nodes_[left].box;
  n.box.extend(nodes_[right].box);
}

void AabbTree::query(const Aabb& box, std::span<const Aabb> boxes, std::vector<Index>& out) const {
  if (nodes_.empty() || box.empty()) return;
  Index stack[96];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Index id = stack[--top];
    const Node& n = nodes_[id];
    if (!n.box.overlaps(box)) continue;
    if (n.count > 0) {
      for (Index i = n.first; i < n.first + n.count; ++i)
        if (boxes[items_[i]].overlaps(box)) out.push_back(items_[i]);
    } else {
      stack[top++] = n.right;
      stack[top++] = id + 1;
    }
  }
}

// -------------------------------------------------------------------------- BroadPhase

void BroadPhase::find_pairs(BroadPhaseKind kind, const BroadPhaseSide& a, const BroadPhaseSide& b,
                            const BvhSide& bvh, std::vector<TetPair>& out) {
  const std::size_t chunks = detail::num_chunks(a.tets.size(), kQueryChunk);
  detail::reset_parts(parts_, chunks);
  const bool ready =
      kind == BroadPhaseKind::kBvh ? bvh.tree != nullptr && !b.tets.empty() : !b.tets.empty();
  if (!a.tets.empty() && ready) {
    switch (kind) {
      case BroadPhaseKind::kGrid:
        grid_pairs(a, b);
        break;
      case BroadPhaseKind::kHash:
        hash_pairs(a, b);
        break;
      case BroadPhaseKind::kSap:
        sap_pairs(a, b);
        break;
      case BroadPhaseKind::kBvh:
        bvh_pairs(a, b, bvh);
        break;
    }
  }
  detail::concat_parts(parts_, chunks, out);
}

void BroadPhase::grid_pairs(const BroadPhaseSide& a, const BroadPhaseSide& b) {
  // The paper's grid: tets rounded by spheres; cell size = mean sphere diameter. A tet
  // goes into the cells its box meets (the box lies inside the sphere's box).
  Aabb extent;
  double diameter_sum = 0.0;
  std::size_t count = 0;
  for (std::size_t k = 0; k < b.tets.size(); ++k) {
    const double r = b.spheres[b.tets[k]].radius;
    if (r < 0.0 || b.boxes[k].empty()) continue;
    extent.extend(b.boxes[k]);
    diameter_sum += 2.0 * r;
    ++count;
  }
  for (const Index t : a.tets)
    if (a.spheres[t].radius >= 0.0) {
      diameter_sum += 2.0 * a.spheres[t].radius;
      ++count;
    }
  if (extent.empty() || count == 0) return;
  Lattice lat;
  size_lattice(lat, extent, diameter_sum / double(count), 2.0 * double(b.tets.size()) + 1024.0);
  const std::int64_t cells = lat.dims[0] * lat.dims[1] * lat.dims[2];

  // Counting sort of B's tets into cells (B order within each cell).
  const auto in_grid = [&](std::size_t k) {
    return b.spheres[b.tets[k]].radius >= 0.0 && !b.boxes[k].empty();
  };
  cell_start_.assign(static_cast<std::size_t>(cells) + 1, 0);
  low_b_.resize(b.tets.size());
  for (std::size_t k = 0; k < b.tets.size(); ++k) {
    if (!in_grid(k)) continue;
    const auto lo = lat.low(b.boxes[k]), hi = lat.high(b.boxes[k]);
    low_b_[k] = lo;
    for (std::int32_t z = lo[2]; z <= hi[2]; ++z)
      for (std::int32_t y = lo[1]; y <= hi[1]; ++y)
        for (std::int32_t x = lo[0]; x <= hi[0]; ++x) ++cell_start_[lat.index(x, y, z) + 1];
  }
  for (std::size_t c = 0; c < static_cast<std::size_t>(cells); ++c)
    cell_start_[c + 1] += cell_start_[c];
  cell_items_.resize(static_cast<std::size_t>(cell_start_.back()));
  {
    std::vector<Index> fill(cell_start_.begin(), cell_start_.end() - 1);
    for (std::size_t k = 0; k < b.tets.size(); ++k) {
      if (!in_grid(k)) continue;
      const auto lo = lat.low(b.boxes[k]), hi = lat.high(b.boxes[k]);
      for (std::int32_t z = lo[2]; z <= hi[2]; ++z)
        for (std::int32_t y = lo[1]; y <= hi[1]; ++y)
          for (std::int32_t x = lo[0]; x <= hi[0]; ++x)
            cell_items_[fill[lat.index(x, y, z)]++] = static_cast<Index>(k);
    }
  }

  detail::for_chunks(a.tets.size(), kQueryChunk,
                     [&](std::size_t begin, std::size_t end, std::size_t chunk) {
                       std::vector<TetPair>& part = parts_[chunk];
                       for (std::size_t i = begin; i < end; ++i) {
                         const Index ta = a.tets[i];
                         const BoundingSphere& s = a.spheres[ta];
                         const Aabb& box = a.boxes[i];
                         if (s.radius < 0.0 || !box.overlaps(extent)) continue;
                         const auto lo = lat.low(box), hi = lat.high(box);
                         const std::size_t start = part.size();
                         for (std::int32_t z = lo[2]; z <= hi[2]; ++z)
                           for (std::int32_t y = lo[1]; y <= hi[1]; ++y)
                             for (std::int32_t x = lo[0]; x <= hi[0]; ++x) {
                               const std::int64_t c = lat.index(x, y, z);
                               for (Index e = cell_start_[c]; e < cell_start_[c + 1]; ++e) {
                                 const Index k = cell_items_[e];
                                 const auto& lb = low_b_[k];
                                 // Report each pair once: in the first cell the two ranges share.
                                 if (x != std::max(lo[0], lb[0]) || y != std::max(lo[1], lb[1]) ||
                                     z != std::max(lo[2], lb[2]))
                                   continue;
                                 const Index tb = b.tets[k];
                                 if (sphere_overlap(s, b.spheres[tb]) && box.overlaps(b.boxes[k]))
                                   part.push_back({ta, tb});
                               }
                             }
                         sort_tail(part, start);
                       }
                     });
}

void BroadPhase::hash_pairs(const BroadPhaseSide& a, const BroadPhaseSide& b) {
  // Cell size = mean box extent (Teschner et al. found the mean edge length best).
  Aabb extent;
  double size_sum = 0.0;
  std::size_t count = 0;
  for (const Aabb& box : b.boxes) {
    if (box.empty()) continue;
    extent.extend(box);
    size_sum += (box.hi - box.lo).sum() / 3.0;
    ++count;
  }
  for (const Aabb& box : a.boxes) {
    if (box.empty()) continue;
    size_sum += (box.hi - box.lo).sum() / 3.0;
    ++count;
  }
  if (extent.empty() || count == 0) return;
  // Cells are counted from extent.lo (so coordinates are small and non-negative) and
  // clamped into B's extent, which loses nothing: no box of B lies outside it.
  Lattice lat;
  double h = size_sum / double(count);
  const double max_entries = 8.0 * double(b.tets.size()) + 1024.0;
  for (int iter = 0;; ++iter) {
    size_lattice(lat, extent, h, 1e15);
    double entries = 0.0;
    for (const Aabb& box : b.boxes) {
      if (box.empty()) continue;
      const auto lo = lat.low(box), hi = lat.high(box);
      entries += double(hi[0] - lo[0] + 1) * double(hi[1] - lo[1] + 1) * double(hi[2] - lo[2] + 1);
    }
    if (entries <= max_entries || iter >= 32) break;
    h = lat.h * 1.5;  // an outsized tet: coarser cells
  }

  entries_.clear();
  low_b_.resize(b.tets.size());
  for (std::size_t k = 0; k < b.tets.size(); ++k) {
    const Aabb& box = b.boxes[k];
    if (box.empty()) continue;
    const auto lo = lat.low(box), hi = lat.high(box);
    low_b_[k] = lo;
    for (std::int32_t z = lo[2]; z <= hi[2]; ++z)
      for (std::int32_t y = lo[1]; y <= hi[1]; ++y)
        for (std::int32_t x = lo[0]; x <= hi[0]; ++x)
          entries_.push_back({static_cast<std::int32_t>(k), x, y, z});
  }
  const std::uint64_t table = next_prime(2 * entries_.size() + 1);
  cell_start_.assign(table + 1, 0);
  for (const auto& e : entries_) ++cell_start_[cell_hash(e[1], e[2], e[3], table) + 1];
  for (std::uint64_t c = 0; c < table; ++c) cell_start_[c + 1] += cell_start_[c];
  cell_items_.resize(entries_.size());
  {
    std::vector<Index> fill(cell_start_.begin(), cell_start_.end() - 1);
    for (std::size_t e = 0; e < entries_.size(); ++e) {
      const auto& en = entries_[e];
      cell_items_[fill[cell_hash(en[1], en[2], en[3], table)]++] = static_cast<Index>(e);
    }
  }

  detail::for_chunks(
      a.tets.size(), kQueryChunk, [&](std::size_t begin, std::size_t end, std::size_t chunk) {
        std::vector<TetPair>& part = parts_[chunk];
        for (std::size_t i = begin; i < end; ++i) {
          const Index ta = a.tets[i];
          const Aabb& box = a.boxes[i];
          if (!box.overlaps(extent)) continue;
          const auto lo = lat.low(box), hi = lat.high(box);
          const std::size_t start = part.size();
          for (std::int32_t z = lo[2]; z <= hi[2]; ++z)
            for (std::int32_t y = lo[1]; y <= hi[1]; ++y)
              for (std::int32_t x = lo[0]; x <= hi[0]; ++x) {
                const std::uint64_t bucket = cell_hash(x, y, z, table);
                for (Index s = cell_start_[bucket]; s < cell_start_[bucket + 1]; ++s) {
                  const auto& en = entries_[cell_items_[s]];
                  if (en[1] != x || en[2] != y || en[3] != z) continue;  // hash collision
                  const auto& lb = low_b_[en[0]];
                  if (x != std::max(lo[0], lb[0]) || y != std::max(lo[1], lb[1]) ||
                      z != std::max(lo[2], lb[2]))
                    continue;  // reported in the first shared cell
                  if (box.overlaps(b.boxes[en[0]])) part.push_back({ta, b.tets[en[0]]});
                }
              }
          sort_tail(part, start);
        }
      });
}

void BroadPhase::sap_pairs(const BroadPhaseSide& a, const BroadPhaseSide& b) {
  // Sweep axis: the one along which the box centres spread most.
  Vector3d sum = Vector3d::Zero(), sum2 = Vector3d::Zero();
  std::size_t count = 0;
  for (const auto* boxes : {&a.boxes, &b.boxes})
    for (const Aabb& box : *boxes) {
      if (box.empty()) continue;
      const Vector3d c = 0.5 * (box.lo + box.hi);
      sum += c;
      sum2 += c.cwiseProduct(c);
      ++count;
    }
  if (count == 0) return;
  const Vector3d mean = sum / double(count);
  const Vector3d var = sum2 / double(count) - mean.cwiseProduct(mean);
  int axis = 0;
  if (var.y() > var[axis]) axis = 1;
  if (var.z() > var[axis]) axis = 2;

  sorted_b_.clear();
  double max_len = 0.0;
  for (std::size_t k = 0; k < b.tets.size(); ++k) {
    const Aabb& box = b.boxes[k];
    if (box.empty()) continue;
    sorted_b_.emplace_back(box.lo[axis], static_cast<Index>(k));
    max_len = std::max(max_len, box.hi[axis] - box.lo[axis]);
  }
  if (sorted_b_.size() > 8192)
    tbb::parallel_sort(sorted_b_.begin(), sorted_b_.end());
  else
    std::sort(sorted_b_.begin(), sorted_b_.end());

  detail::for_chunks(
      a.tets.size(), kQueryChunk, [&](std::size_t begin, std::size_t end, std::size_t chunk) {
        std::vector<TetPair>& part = parts_[chunk];
        for (std::size_t i = begin; i < end; ++i) {
          const Aabb& box = a.boxes[i];
          if (box.empty()) continue;
          // B boxes starting in [lo_a - max_len, hi_a] are the only ones that can reach A's.
          const auto first = std::lower_bound(
              sorted_b_.begin(), sorted_b_.end(), box.lo[axis] - max_len,
              [](const std::pair<double, Index>& e, double v) { return e.first < v; });
          const std::size_t start = part.size();
          for (auto it = first; it != sorted_b_.end() && it->first <= box.hi[axis]; ++it)
            if (box.overlaps(b.boxes[it->second])) part.push_back({a.tets[i], b.tets[it->second]});
          sort_tail(part, start);
        }
      });
}

void BroadPhase::bvh_pairs(const BroadPhaseSide& a, const BroadPhaseSide& b, const BvhSide& bvh) {
  detail::for_chunks(a.tets.size(), kQueryChunk,
                     [&](std::size_t begin, std::size_t end, std::size_t chunk) {
                       std::vector<TetPair>& part = parts_[chunk];
                       std::vector<Index>& found = t_found;
                       for (std::size_t i = begin; i < end; ++i) {
                         const Aabb& box = a.boxes[i];
                         found.clear();
                         bvh.tree->query(box, bvh.tet_boxes, found);
                         std::sort(found.begin(), found.end());
                         if (bvh.over_side) {
                           // The tree is over b.boxes itself: its query already tested them.
                           for (const Index k : found) part.push_back({a.tets[i], b.tets[k]});
                           continue;
                         }
                         for (const Index tb : found) {
                           const Index k = bvh.slot[tb];
                           if (k >= 0 && box.overlaps(b.boxes[k])) part.push_back({a.tets[i], tb});
                         }
                       }
                     });
}

}  // namespace tc
