// Fuzz target: mesh validation and the topology build on meshes made from the input
// (up to 48 nodes on a small grid with hard values mixed in, up to 96 tets whose indices
// are mostly in range). validate_mesh() must classify any mesh; a mesh it does not call
// structurally invalid must build a topology whose lists are consistent.
#include <Eigen/Geometry>

#include <algorithm>
#include <cstdint>

#include "core/mesh/shape_check.hpp"
#include "core/mesh/topology.hpp"
#include "core/mesh/validate.hpp"
#include "fuzz_input.hpp"

namespace {

void check_topology(const tc::TetMesh& mesh, const tc::Topology& topo) {
  const auto n = static_cast<std::size_t>(mesh.num_nodes());
  const auto m = static_cast<std::size_t>(mesh.num_tets());
  TC_FUZZ_CHECK(topo.num_nodes == mesh.num_nodes() && topo.num_tets == mesh.num_tets());
  TC_FUZZ_CHECK(topo.boundary_face_tet.size() == topo.boundary_faces.size());
  TC_FUZZ_CHECK(topo.is_boundary_node.size() == n);
  TC_FUZZ_CHECK(topo.tet_neighbors.size() == m && topo.tet_component.size() == m);
  TC_FUZZ_CHECK(topo.node_adjacency.rows() == mesh.num_nodes());
  TC_FUZZ_CHECK(topo.node_tets.rows() == mesh.num_nodes());
  TC_FUZZ_CHECK(std::is_sorted(topo.edges.begin(), topo.edges.end()));
  TC_FUZZ_CHECK(std::is_sorted(topo.boundary_nodes.begin(), topo.boundary_nodes.end()));
  for (std::size_t f = 0; f < topo.boundary_faces.size(); ++f) {
    const tc::Index t = topo.boundary_face_tet[f];
    TC_FUZZ_CHECK(t >= 0 && static_cast<std::size_t>(t) < m);
    for (const tc::Index v : topo.boundary_faces[f]) {
      TC_FUZZ_CHECK(v >= 0 && static_cast<std::size_t>(v) < n);
      TC_FUZZ_CHECK(topo.is_boundary_node[static_cast<std::size_t>(v)] == 1);
      // The face's nodes belong to its tet.
      const tc::Tet& tet = mesh.tets[static_cast<std::size_t>(t)];
      TC_FUZZ_CHECK(std::find(tet.begin(), tet.end(), v) != tet.end());
    }
  }
  for (std::size_t t = 0; t < m; ++t) {
    TC_FUZZ_CHECK(topo.tet_component[t] >= 0 && topo.tet_component[t] < topo.num_components);
    for (const tc::Index other : topo.tet_neighbors[t]) {
      if (other < 0) continue;
      TC_FUZZ_CHECK(static_cast<std::size_t>(other) < m);
      // Neighbours are mutual and in the same component.
      const auto& back = topo.tet_neighbors[static_cast<std::size_t>(other)];
      TC_FUZZ_CHECK(std::find(back.begin(), back.end(), static_cast<tc::Index>(t)) != back.end());
      TC_FUZZ_CHECK(topo.tet_component[static_cast<std::size_t>(other)] == topo.tet_component[t]);
    }
  }
  for (const tc::Index v : topo.orphan_nodes) TC_FUZZ_CHECK(topo.node_tets.row(v).empty());
  (void)tc::boundary_euler_characteristic(topo);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  tc::fuzz::FuzzInput in(data, size);
  const std::uint32_t n = in.small(49);
  const std::uint32_t m = in.small(97);
  tc::TetMesh mesh;
  mesh.positions.resize(3, static_cast<Eigen::Index>(n));
  mesh.node_ids.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    mesh.node_ids[i] = static_cast<std::int64_t>(i) + 1;
    for (int k = 0; k < 3; ++k) mesh.positions(k, static_cast<Eigen::Index>(i)) = in.coordinate();
  }
  mesh.tets.resize(m);
  for (tc::Tet& tet : mesh.tets) {
    for (std::int32_t& v : tet) {
      const std::uint8_t selector = in.take<std::uint8_t>();
      // Mostly in range; now and then a raw index (negative, just past the end, huge).
      v = selector < 248 || n == 0
              ? static_cast<std::int32_t>(selector % std::max<std::uint32_t>(n, 1))
              : in.take<std::int32_t>();
    }
  }
  const tc::ValidationReport report = tc::validate_mesh(mesh);
  (void)report.summary();
  const bool bad = report.structurally_invalid();
  // The report's own rules: a clean report has no defect and valid quality bounds.
  if (report.clean()) TC_FUZZ_CHECK(!bad);
  if (!bad) {
    const tc::Topology topo = tc::build_topology(mesh.tets, mesh.num_nodes());
    check_topology(mesh, topo);
    // The per-frame check agrees with the full one on positions.
    const tc::ValidationReport frame = tc::validate_positions(mesh.positions, mesh.tets);
    TC_FUZZ_CHECK(frame.degenerate.count == report.degenerate.count);
    TC_FUZZ_CHECK(frame.inverted.count == report.inverted.count);
    // The pipeline's incremental check (tc::ShapeCheck) agrees with the full one on a
    // sequence of states: each moves one node to a coordinate taken from the input.
    tc::ValidationOptions options;
    options.compute_min_quality = false;
    const tc::TetCheckOrder order = tc::make_tet_check_order(mesh.positions, mesh.tets);
    tc::ShapeCheck check(order, topo.node_tets, mesh.num_nodes(), options);
    tc::Positions x = mesh.positions;
    const auto agree = [&] {
      const tc::ValidationReport got = check.check(x);
      const tc::ValidationReport want = tc::validate_positions(x, order, options);
      TC_FUZZ_CHECK(got.nonfinite_node.count == want.nonfinite_node.count &&
                    got.nonfinite_node.first == want.nonfinite_node.first);
      TC_FUZZ_CHECK(got.degenerate.count == want.degenerate.count &&
                    got.degenerate.first == want.degenerate.first);
      TC_FUZZ_CHECK(got.inverted.count == want.inverted.count &&
                    got.inverted.first == want.inverted.first);
      TC_FUZZ_CHECK(got.sliver.count == want.sliver.count && got.sliver.first == want.sliver.first);
    };
    for (int step = 0; step < 8; ++step) {
      agree();
      if (n == 0 || in.remaining() == 0) break;
      const auto node = static_cast<Eigen::Index>(in.small(n));
      x(static_cast<Eigen::Index>(in.small(3)), node) = in.coordinate();
    }
    // Then (input left over) the whole state turned and shifted, now and then with one node
    // moved too: the check's fitted rigid motion. After the steps above, so that the
    // inputs found before read as they did.
    for (int step = 0; step < 6 && n > 0 && in.remaining() > 0; ++step) {
      const std::uint8_t turn = in.take<std::uint8_t>();
      const Eigen::Vector3d axis[3] = {Eigen::Vector3d::UnitZ(), Eigen::Vector3d(1, 2, 3),
                                       Eigen::Vector3d(-2, 1, 0.5)};
      const Eigen::Matrix3d rotation =
          Eigen::AngleAxisd(0.02 * (turn % 64), axis[turn / 64 % 3].normalized())
              .toRotationMatrix();
      const Eigen::Vector3d shift(0.01 * (turn % 7), -0.02 * (turn % 5), 0.0);
      x = (rotation * x).colwise() + shift;
      if (turn >= 192) {
        const auto node = static_cast<Eigen::Index>(in.small(n));
        x(static_cast<Eigen::Index>(in.small(3)), node) = in.coordinate();
      }
      agree();
    }
  }
  return 0;
}
