// Priority queues for the Dijkstra-like marches (internal to core/depth; measured
// against each other in docs/DEPTH_MAPS.md).
//
// Interface: clear(); start(first) with the entries of the first layer (pushed while
// the boundary nodes were relaxed, so a queue can calibrate itself on them);
// push(sq_key, node); empty(); pop() -> node. Keys are squared distances (m^2, >= 0).
// All keep stale entries (lazy deletion): the caller skips a popped node it has already
// finalised. Every queue is deterministic: same pushes, same pops.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "core/mesh/tet_mesh.hpp"

namespace tc::detail {

/// A queued node and its squared-distance key.
struct QueueEntry {
  float key;
  Index node;
};

/// Binary min-heap (std::push_heap / pop_heap): exact Dijkstra order, ties by node.
class BinaryHeapQueue {
 public:
  void clear() { heap_.clear(); }
  void start(std::span<const QueueEntry> first) {
    for (const QueueEntry& e : first) push(e.key, e.node);
  }
  [[nodiscard]] bool empty() const { return heap_.empty(); }
  void push(float key, Index node) {
    heap_.push_back({key, node});
    std::push_heap(heap_.begin(), heap_.end(), Greater{});
  }
  Index pop() {
    std::pop_heap(heap_.begin(), heap_.end(), Greater{});
    const Index node = heap_.back().node;
    heap_.pop_back();
    return node;
  }

 private:
  struct Greater {
    bool operator()(const QueueEntry& a, const QueueEntry& b) const {
      return a.key != b.key ? a.key > b.key : a.node > b.node;
    }
  };
  std::vector<QueueEntry> heap_;
};

/// Radix heap (Ahuja, Mehlhorn, Orlin, Tarjan 1990) on the bit pattern of the float
/// key, which orders non-negative floats like their values: exact Dijkstra order (LIFO
/// among equal keys). A radix heap needs monotone keys; a key below the last popped
/// one is raised to it (the march can produce such keys: a neighbour may be nearer to
/// the carried feature than the node being finalised), so it is popped next, as a
/// binary heap would do.
class RadixHeap {
 public:
  void clear() {
    for (auto& b : buckets_) b.clear();
    last_ = 0;
    size_ = 0;
  }
  void start(std::span<const QueueEntry> first) {
    for (const QueueEntry& e : first) push(e.key, e.node);
  }
  [[nodiscard]] bool empty() const { return size_ == 0; }
  void push(float key, Index node) {
    std::uint32_t bits = std::bit_cast<std::uint32_t>(key);
    if (bits < last_) bits = last_;
    buckets_[bucket_of(bits ^ last_)].push_back({bits, node});
    ++size_;
  }
  Index pop() {
    if (buckets_[0].empty()) {
      std::size_t i = 1;
      while (buckets_[i].empty()) ++i;
      std::uint32_t smallest = buckets_[i][0].bits;
      for (const Entry& e : buckets_[i]) smallest = std::min(smallest, e.bits);
      last_ = smallest;
      for (const Entry& e : buckets_[i]) buckets_[bucket_of(e.bits ^ last_)].push_back(e);
      buckets_[i].clear();
    }
    const Index node = buckets_[0].back().node;
    buckets_[0].pop_back();
    --size_;
    return node;
  }

 private:
  struct Entry {
    std::uint32_t bits;
    Index node;
  };
  static std::size_t bucket_of(std::uint32_t x) {
    return x == 0 ? 0 : static_cast<std::size_t>(32 - std::countl_zero(x));
  }
  std::array<std::vector<Entry>, 33> buckets_;
  std::uint32_t last_ = 0;
  std::size_t size_ = 0;
};

/// Bucket queue ("untidy priority queue", Yatziv, Bartesaghi, Sapiro, J. Comput. Phys.
/// 2006): distances are binned in buckets of width w, a bucket is processed first in,
/// first out, and a key below the bucket being processed joins that bucket. O(1) per
/// operation, and the FIFO order keeps consecutive pops close in memory, which is what
/// makes it fast (docs/DEPTH_MAPS.md). w = `width_factor` times the mean distance of
/// the first layer (the nodes next to the boundary), i.e. a fraction of the local edge
/// length, recalibrated every frame from the positions.
class BucketQueue {
 public:
  explicit BucketQueue(float width_factor = 0.25f) : width_factor_(width_factor) {}

  void clear() {
    for (std::size_t k = 0; k < used_; ++k) buckets_[k].clear();
    used_ = 0;
    cur_ = 0;
    pos_ = 0;
    size_ = 0;
  }
  void start(std::span<const QueueEntry> first) {
    double sum = 0.0;
    for (const QueueEntry& e : first) sum += std::sqrt(static_cast<double>(e.key));
    const double mean = first.empty() ? 0.0 : sum / static_cast<double>(first.size());
    const double w = width_factor_ * mean;
    // A zero or non-finite mean (coincident nodes): any width works, the cap below
    // keeps the bucket count bounded.
    inv_width_ = (w > 0.0 && std::isfinite(w)) ? static_cast<float>(1.0 / w) : 1.0f;
    for (const QueueEntry& e : first) push(e.key, e.node);
  }
  [[nodiscard]] bool empty() const { return size_ == 0; }
  void push(float key, Index node) {
    const float scaled = std::sqrt(key) * inv_width_;
    std::size_t k = scaled < static_cast<float>(kMaxBuckets - 1) ? static_cast<std::size_t>(scaled)
                                                                 : kMaxBuckets - 1;
    k = std::max(k, cur_);
    if (k >= buckets_.size()) buckets_.resize(k + 1);
    used_ = std::max(used_, k + 1);
    buckets_[k].push_back(node);
    ++size_;
  }
  /// The node `ahead` pops after the next one, if it is already known (else -1): the
  /// march prefetches its data.
  [[nodiscard]] Index peek(std::size_t ahead) const {
    const auto& b = buckets_[cur_];
    return pos_ + ahead < b.size() ? b[pos_ + ahead] : -1;
  }
  Index pop() {
    while (pos_ >= buckets_[cur_].size()) {
      buckets_[cur_].clear();
      pos_ = 0;
      ++cur_;
    }
    --size_;
    return buckets_[cur_][pos_++];
  }

 private:
  /// Beyond this many buckets (a depth over 2^20 widths: only for absurdly graded
  /// meshes) the order degrades to FIFO in the last bucket; values stay distances to
  /// true boundary points.
  static constexpr std::size_t kMaxBuckets = std::size_t{1} << 20;
  float width_factor_;
  float inv_width_ = 1.0f;
  std::vector<std::vector<Index>> buckets_;
  std::size_t used_ = 0;  ///< buckets [0, used_) may hold entries
  std::size_t cur_ = 0;   ///< bucket being processed
  std::size_t pos_ = 0;   ///< next entry in buckets_[cur_]
  std::size_t size_ = 0;
};

}  // namespace tc::detail
