// tc::client::read_mesh / read_surface: the service's readers (core/io, compiled into
// this library privately as tc_client_mesh_io, hidden), their results copied into the
// flat arrays of tc::client::Mesh and their errors thrown as MeshError with the reader's
// message unchanged.
#include "tetcollide/mesh.hpp"

#include <cstring>

#include "core/io/mesh_io.hpp"
#include "core/io/surface_io.hpp"

namespace tc::client {
namespace {

/// The protocol's status code of a reader's error (the readers return these four).
StatusCode status_of(ErrorCode code) {
  switch (code) {
    case ErrorCode::kIo:
      return StatusCode::kIo;
    case ErrorCode::kParse:
      return StatusCode::kParse;
    case ErrorCode::kUnsupported:
      return StatusCode::kUnsupported;
    case ErrorCode::kInvalidMesh:
      return StatusCode::kInvalidMesh;
    case ErrorCode::kInvalidArgument:
      return StatusCode::kInvalidArgument;
    case ErrorCode::kUnknownObject:
      return StatusCode::kUnknownObject;
    case ErrorCode::kStaleVersion:
      return StatusCode::kStaleVersion;
    case ErrorCode::kOversized:
      return StatusCode::kOversized;
  }
  return StatusCode::kInternal;
}

[[noreturn]] void throw_error(const Error& error) {
  throw MeshError(status_of(error.code), error.message);
}

/// Copies 3 x n column-major positions (x0 y0 z0 x1 ...) into `out` (3n doubles).
void copy_positions(const Positions& positions, std::vector<double>& out) {
  out.resize(static_cast<std::size_t>(positions.size()));
  if (!out.empty()) std::memcpy(out.data(), positions.data(), out.size() * sizeof(double));
}

/// Flattens k index arrays of N entries into `out` (N k indices).
template <std::size_t N>
void flatten(const std::vector<std::array<std::int32_t, N>>& cells,
             std::vector<std::int32_t>& out) {
  out.reserve(N * cells.size());
  for (const auto& cell : cells) out.insert(out.end(), cell.begin(), cell.end());
}

}  // namespace

MeshError::MeshError(StatusCode code, const std::string& message)
    : std::runtime_error(message), code_(code) {}

MeshError::~MeshError() = default;

Mesh read_mesh(const std::filesystem::path& path) {
  Expected<TetMesh> read = tc::read_mesh(path);
  if (!read) throw_error(read.error());
  Mesh mesh;
  mesh.node_ids = std::move(read->node_ids);
  copy_positions(read->positions, mesh.rest_positions);
  flatten(read->tets, mesh.tets);
  return mesh;
}

Mesh read_surface(const std::filesystem::path& path) {
  Expected<SurfaceMesh> read = tc::read_surface(path);
  if (!read) throw_error(read.error());
  Mesh mesh;
  mesh.node_ids = std::move(read->node_ids);
  copy_positions(read->positions, mesh.rest_positions);
  flatten(read->triangles, mesh.triangles);
  return mesh;
}

}  // namespace tc::client
