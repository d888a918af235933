// Internal to service/core (include from .cpp files only: it pulls in TBB).
//
// Deterministic parallel loops: [0, n) is cut into chunks of a fixed size, whatever the
// thread count; each chunk writes its own buffer (or its own indices) and buffers are
// merged in chunk order, so the output is bit-identical with 1, 2 or N threads.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstddef>

namespace tc::detail {

/// Number of chunks of size `chunk` covering n items.
inline std::size_t num_chunks(std::size_t n, std::size_t chunk) {
  return (n + chunk - 1) / chunk;
}

/// True when loops here run on the calling thread only: the arena, or TBB's global limit,
/// allows one thread.
inline bool single_thread() {
  return tbb::this_task_arena::max_concurrency() == 1 ||
         tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism) == 1;
}

/// Calls body(begin, end, chunk_index) for each fixed chunk of [0, n), in parallel.
template <typename Body>
void for_chunks(std::size_t n, std::size_t chunk, const Body& body) {
  const std::size_t chunks = num_chunks(n, chunk);
  if (chunks == 0) return;
  if (chunks == 1) {
    body(std::size_t{0}, n, std::size_t{0});
    return;
  }
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, chunks, 1),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t c = r.begin(); c != r.end(); ++c)
          body(c * chunk, std::min(n, (c + 1) * chunk), c);
      },
      tbb::simple_partitioner());
}

}  // namespace tc::detail
