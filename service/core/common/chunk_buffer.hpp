// One output buffer per fixed chunk of a parallel loop (see chunked.hpp).
#pragma once

#include <vector>

namespace tc::detail {

/// A vector on its own cache line: neighbouring chunks run on different threads, and
/// vector headers packed together would make every push_back bounce one cache line
/// between the cores (false sharing).
template <typename T>
struct alignas(64) ChunkBuffer : std::vector<T> {};

/// The buffers of one parallel loop, one per chunk.
template <typename T>
using ChunkBuffers = std::vector<ChunkBuffer<T>>;

}  // namespace tc::detail
