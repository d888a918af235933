// Internal to service/core/detect (include from .cpp files only: it pulls in TBB).
//
// Deterministic parallel loops: [0, n) is cut into chunks of a fixed size, whatever the
// thread count; each chunk writes its own buffer and the buffers are concatenated in
// chunk order, so the output is bit-identical with 1, 2 or N threads.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include <algorithm>
#include <cstddef>
#include <vector>

#include "core/detect/chunk_buffer.hpp"

namespace tc::detail {

/// Number of chunks of size `chunk` covering n items.
inline std::size_t num_chunks(std::size_t n, std::size_t chunk) {
  return (n + chunk - 1) / chunk;
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

/// Resizes `parts` to `count` buffers and clears each (capacity is kept).
template <typename T>
void reset_parts(ChunkBuffers<T>& parts, std::size_t count) {
  if (parts.size() < count) parts.resize(count);
  for (std::size_t i = 0; i < count; ++i) parts[i].clear();
}

/// out = parts[0] + parts[1] + ... + parts[count - 1] (parallel copy).
template <typename T>
void concat_parts(const ChunkBuffers<T>& parts, std::size_t count, std::vector<T>& out) {
  std::vector<std::size_t> offset(count + 1, 0);
  for (std::size_t i = 0; i < count; ++i) offset[i + 1] = offset[i] + parts[i].size();
  out.resize(offset[count]);
  if (offset[count] == 0) return;
  for_chunks(count, 16, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t i = begin; i < end; ++i)
      std::copy(parts[i].begin(), parts[i].end(),
                out.begin() + static_cast<std::ptrdiff_t>(offset[i]));
  });
}

}  // namespace tc::detail
