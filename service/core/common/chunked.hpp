// Internal to service/core (include from .cpp files only: it pulls in TBB).
//
// The chunk buffers of the deterministic parallel loops (core/common/parallel_chunks.hpp):
// each chunk writes its own buffer and the buffers are concatenated in chunk order.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

#include "core/common/chunk_buffer.hpp"
#include "core/common/parallel_chunks.hpp"

namespace tc::detail {

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
