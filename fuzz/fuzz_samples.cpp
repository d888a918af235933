// Fuzz target: the daemon's handling of every incoming topic type, MeshTopology and
// MeshState (service/daemon/samples.*). The input builds the generated C samples as the
// DDS reader hands them over (raw name bytes, sequences of any length, any parameter
// values and enum values in their storage range), then runs what the router and the
// scene runner do with them: validate_topology -> to_mesh/to_params ->
// Pipeline::set_topology, then validate_state_header/validate_state -> to_positions ->
// Pipeline::run_frame against a fixed second object. A sample that validates must
// convert to consistent core types, and a frame must give finite forces.
#include <oneapi/tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <span>
#include <variant>
#include <vector>

#include "fuzz_input.hpp"
#include "protocol.hpp"
#include "samples.hpp"

namespace {

using tc::fuzz::FuzzInput;

/// Fills a bounded string field: a fixed valid name, or raw bytes (no terminator
/// needed: the view never reads past the field).
template <std::size_t N>
void fill_name(char (&field)[N], FuzzInput& in, const char* valid) {
  std::memset(field, 0, N);
  if (in.take<std::uint8_t>() < 224) {
    std::strncpy(field, valid, N - 1);
    return;
  }
  const std::string raw = in.text(N);
  std::memcpy(field, raw.data(), raw.size());
}

/// Length of a sequence: usually `expected`, sometimes anything up to `max`.
std::size_t length(FuzzInput& in, std::size_t expected, std::uint32_t max) {
  return in.take<std::uint8_t>() < 232 ? expected : in.small(max + 1);
}

/// A tet at x = 1.5 .. 2.5 the fuzzed object can run into.
tc::TetMesh fixed_tet() {
  tc::TetMesh m;
  m.node_ids = {1, 2, 3, 4};
  m.positions.resize(3, 4);
  m.positions << 1.5, 2.5, 1.5, 1.5,  //
      0.0, 0.0, 1.0, 0.0,             //
      0.0, 0.0, 0.0, 1.0;
  m.tets = {{0, 1, 2, 3}};
  return m;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // One worker: the pipeline's results do not depend on it, and the fuzzer runs faster.
  static const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  // TC_FUZZ_VERBOSE=1: say how far each input got (to check what the seeds reach).
  static const bool verbose = std::getenv("TC_FUZZ_VERBOSE") != nullptr;
  FuzzInput in(data, size);

  tc::daemon::Limits limits;
  if (in.take<std::uint8_t>() >= 192) {  // tight limits, to reach the size checks
    limits.max_nodes = 4 + in.small(32);
    limits.max_tets = 1 + in.small(32);
  }

  // ---- MeshTopology ----------------------------------------------------------------
  tetcollide_MeshTopology topology{};
  fill_name(topology.scene, in, "scene");
  fill_name(topology.object, in, "object");
  topology.version = in.take<std::uint8_t>() < 240 ? 1 + in.small(4) : in.take<std::uint32_t>();
  const std::size_t n = in.small(33);
  const std::size_t m = in.small(65);
  std::vector<std::int64_t> node_ids(in.take<std::uint8_t>() < 128 ? 0 : length(in, n, 40));
  for (std::size_t i = 0; i < node_ids.size(); ++i)
    node_ids[i] =
        in.take<std::uint8_t>() < 240 ? static_cast<std::int64_t>(i) + 1 : in.take<std::int64_t>();
  std::vector<double> rest(length(in, 3 * n, 120));
  for (double& x : rest) x = in.coordinate();
  std::vector<std::int32_t> tets(length(in, 4 * m, 300));
  for (std::int32_t& v : tets) {
    const std::uint8_t selector = in.take<std::uint8_t>();
    v = selector < 248 ? static_cast<std::int32_t>(selector % std::max<std::size_t>(n, 1))
                       : in.take<std::int32_t>();
  }
  // A surface object (protocol 2) takes the same indices as triangles: the stream's
  // lengths then need not be multiples of 3, which validation must catch.
  std::vector<std::int32_t> triangles;
  if (in.take<std::uint8_t>() >= 208) triangles = std::move(tets);
  std::array<std::int32_t, 4> one_tet{0, 1, 2, 3};
  const bool both = !triangles.empty() && in.take<std::uint8_t>() >= 240;  // must be refused
  const std::span<std::int32_t> sent_tets =
      both ? std::span<std::int32_t>(one_tet) : std::span<std::int32_t>(tets);
  tc::protocol::borrow(topology.node_ids, node_ids.data(), node_ids.size());
  tc::protocol::borrow(topology.rest_positions, rest.data(), rest.size());
  tc::protocol::borrow(topology.tets, sent_tets.data(), sent_tets.size());
  tc::protocol::borrow(topology.triangles, triangles.data(), triangles.size());
  topology.params.stiffness = in.take<std::uint8_t>() < 200 ? 1e4 : in.coordinate();
  topology.params.damping = in.take<std::uint8_t>() < 200 ? 0.0 : in.coordinate();
  topology.params.max_force = in.take<std::uint8_t>() < 200 ? 0.0 : in.coordinate();
  topology.params.is_static = (in.take<std::uint8_t>() & 1) != 0;
  // Enums: any value of their storage range (the three named ones, and 3).
  topology.params.depth = static_cast<tetcollide_DepthMethod>(in.small(4));
  topology.params.response = static_cast<tetcollide_ResponseKind>(in.small(4));

  const tc::daemon::TopologyView tv = tc::daemon::view_of(topology);
  TC_FUZZ_CHECK(tv.scene.size() <= sizeof(topology.scene));
  TC_FUZZ_CHECK(tv.object.size() <= sizeof(topology.object));
  const tc::Status topology_ok = tc::daemon::validate_topology(tv, limits);
  if (!topology_ok) {
    if (verbose)
      std::fprintf(stderr, "topology rejected: %s\n", topology_ok.error().message.c_str());
    TC_FUZZ_CHECK(!topology_ok.error().message.empty());
    TC_FUZZ_CHECK(tc::daemon::status_code(topology_ok.error().code) != tetcollide_STATUS_OK);
    return 0;
  }
  TC_FUZZ_CHECK(tv.tets.empty() || tv.triangles.empty());
  tc::ObjectMesh object_mesh = tc::daemon::to_mesh(tv);
  const tc::ObjectParams params = tc::daemon::to_params(tv.params);
  tc::Index nodes = 0;
  if (auto* surface = std::get_if<tc::SurfaceMesh>(&object_mesh)) {
    TC_FUZZ_CHECK(!tv.triangles.empty());
    TC_FUZZ_CHECK(static_cast<std::size_t>(surface->num_triangles()) * 3 == tv.triangles.size());
    TC_FUZZ_CHECK(surface->num_triangles() <= limits.max_tets);
    nodes = surface->num_nodes();
    TC_FUZZ_CHECK(surface->node_ids.size() == static_cast<std::size_t>(nodes));
  } else {
    const tc::TetMesh& mesh = std::get<tc::TetMesh>(object_mesh);
    TC_FUZZ_CHECK(static_cast<std::size_t>(mesh.num_tets()) * 4 == tv.tets.size());
    TC_FUZZ_CHECK(mesh.num_tets() <= limits.max_tets);
    nodes = mesh.num_nodes();
    TC_FUZZ_CHECK(mesh.node_ids.size() == static_cast<std::size_t>(nodes));
  }
  TC_FUZZ_CHECK(static_cast<std::size_t>(nodes) * 3 == tv.rest_positions.size());
  TC_FUZZ_CHECK(nodes <= limits.max_nodes);

  tc::Pipeline pipeline;
  TC_FUZZ_CHECK(pipeline.set_topology("fixed", 1, fixed_tet(), tc::ObjectParams{}).ok());
  const std::string object(tv.object);
  const tc::Status set =
      std::holds_alternative<tc::SurfaceMesh>(object_mesh)
          ? pipeline.set_surface(object, tv.version,
                                 std::get<tc::SurfaceMesh>(std::move(object_mesh)), params)
          : pipeline.set_topology(object, tv.version, std::get<tc::TetMesh>(std::move(object_mesh)),
                                  params);
  const bool registered = set.ok();
  if (verbose)
    std::fprintf(stderr, "topology: %s\n", registered ? "registered" : set.error().message.c_str());

  // ---- MeshState ---------------------------------------------------------------------
  tetcollide_MeshState state{};
  if (in.take<std::uint8_t>() < 224) {
    std::memcpy(state.scene, topology.scene, sizeof(state.scene));
    std::memcpy(state.object, topology.object, sizeof(state.object));
  } else {
    fill_name(state.scene, in, "scene");
    fill_name(state.object, in, "object");
  }
  state.frame = in.take<std::uint8_t>() < 240 ? in.small(100) : in.take<std::int64_t>();
  state.topology_version = in.take<std::uint8_t>() < 240 ? topology.version : in.small(6);
  // Positions: the rest positions moved by a grid step, or fuzzed values.
  std::vector<double> positions(length(in, 3 * static_cast<std::size_t>(nodes), 120));
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const std::uint8_t selector = in.take<std::uint8_t>();
    positions[i] = selector < 200 && i < rest.size()
                       ? rest[i] + static_cast<double>(selector % 9) * 0.25 - 1.0
                       : in.coordinate();
  }
  std::vector<double> velocities(in.take<std::uint8_t>() < 160 ? 0
                                                               : length(in, positions.size(), 120));
  for (double& v : velocities) v = in.coordinate();
  tc::protocol::borrow(state.positions, positions.data(), positions.size());
  tc::protocol::borrow(state.velocities, velocities.data(), velocities.size());

  const tc::daemon::StateView sv = tc::daemon::view_of(state);
  const tc::Status header_ok = tc::daemon::validate_state_header(sv, limits);
  if (!header_ok) {
    if (verbose) std::fprintf(stderr, "state rejected: %s\n", header_ok.error().message.c_str());
    TC_FUZZ_CHECK(!header_ok.error().message.empty());
    return 0;
  }
  const tc::Status state_ok = tc::daemon::validate_state(sv, limits, nodes);
  if (!state_ok) {
    if (verbose) std::fprintf(stderr, "state rejected: %s\n", state_ok.error().message.c_str());
    TC_FUZZ_CHECK(!state_ok.error().message.empty());
    return 0;
  }
  const tc::Positions p = tc::daemon::to_positions(sv.positions);
  TC_FUZZ_CHECK(p.cols() == nodes);
  TC_FUZZ_CHECK(p.allFinite());
  if (!registered) return 0;

  // The fuzzed object and the fixed tet, in one frame (the fixed one at rest).
  std::vector<tc::FrameObjectInput> inputs(2);
  inputs[0].object = "fixed";
  inputs[0].topology_version = 1;
  inputs[0].positions = fixed_tet().positions;
  inputs[1].object = object;
  inputs[1].topology_version = sv.topology_version;
  inputs[1].positions = p;
  const tc::FrameOutput out = pipeline.run_frame(sv.frame, inputs);
  if (verbose)
    std::fprintf(stderr, "frame: %zu objects with forces, %zu errors, %zu contacts\n",
                 out.forces.size(), out.errors.size(), out.stats.contacts);
  for (const tc::ObjectForces& f : out.forces) {
    TC_FUZZ_CHECK(f.nodes.size() == f.forces.size());
    for (const Eigen::Vector3d& force : f.forces) TC_FUZZ_CHECK(force.allFinite());
  }
  return 0;
}
