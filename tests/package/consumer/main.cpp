// A simulator outside this project: `consumer DOMAIN [MESH]` registers two overlapping
// boxes with the tetcollided service on DDS domain DOMAIN, publishes one frame of positions
// and checks the answer: every object answered with status ok, contact forces on both, and
// pushing them apart along x (a at x < b). With MESH, it first reads that file with
// tc::client::read_mesh, prints its counts, and checks that a missing file throws a
// MeshError naming it. Exit 0 when all holds, 1 otherwise. Built by tests/package with
// find_package(tetcollide) and with pkg-config against installed trees and against the
// build tree: it uses nothing but <tetcollide/client.hpp>, <tetcollide/mesh.hpp> and the
// standard library.
#include <tetcollide/client.hpp>
#include <tetcollide/mesh.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <utility>

namespace {

namespace tcc = tc::client;

/// A box of n x n x n cubes over [lo, lo + size]^3, each cube split into 6 tetrahedra
/// around its main diagonal, every tet positively oriented.
tcc::Mesh box(int n, std::array<double, 3> lo, double size) {
  tcc::Mesh m;
  const auto id = [n](int i, int j, int k) { return (k * (n + 1) + j) * (n + 1) + i; };
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        m.node_ids.push_back(id(i, j, k));
        for (int d = 0; d < 3; ++d)
          m.rest_positions.push_back(lo[d] + size * (d == 0 ? i : d == 1 ? j : k) / n);
      }
  const auto volume6 = [&m](const std::array<int, 4>& t) {
    const auto p = [&m](int v, int d) { return m.rest_positions[3 * v + d]; };
    double a[3], b[3], c[3];
    for (int d = 0; d < 3; ++d) {
      a[d] = p(t[1], d) - p(t[0], d);
      b[d] = p(t[2], d) - p(t[0], d);
      c[d] = p(t[3], d) - p(t[0], d);
    }
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
           a[2] * (b[0] * c[1] - b[1] * c[0]);
  };
  const int paths[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        for (const auto& path : paths) {
          // Walk from corner (i, j, k) to the opposite one, one axis at a time.
          std::array<int, 3> c{i, j, k};
          std::array<int, 4> t{id(i, j, k), 0, 0, 0};
          for (int s = 0; s < 3; ++s) {
            ++c[path[s]];
            t[s + 1] = id(c[0], c[1], c[2]);
          }
          if (volume6(t) < 0) std::swap(t[2], t[3]);
          m.tets.insert(m.tets.end(), t.begin(), t.end());
        }
  return m;
}

int fail(const std::string& what) {
  std::fprintf(stderr, "consumer: %s\n", what.c_str());
  return 1;
}

/// Reads `path` with the library's reader and prints its counts; checks the error of a
/// file beside it that does not exist. 0 when both behave, else 1.
int read_mesh_file(const std::string& path) {
  const tcc::Mesh mesh = tcc::read_mesh(path);
  std::printf("consumer: %s: %zu nodes, %zu tets\n", path.c_str(), mesh.rest_positions.size() / 3,
              mesh.tets.size() / 4);
  if (mesh.node_ids.size() * 3 != mesh.rest_positions.size() || mesh.tets.empty())
    return fail(path + ": not a tet mesh");
  const std::string missing = path + ".missing.msh";
  try {
    tcc::read_mesh(missing);
  } catch (const tcc::MeshError& e) {
    if (e.code() != tcc::StatusCode::kIo || std::string(e.what()) != missing + ": cannot open file")
      return fail(std::string("unexpected error for a missing file: ") + e.what());
    return 0;
  }
  return fail("no MeshError for " + missing);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace std::chrono_literals;
  if (argc != 2 && argc != 3) return fail("usage: consumer DOMAIN [MESH]");
  try {
    if (argc == 3 && read_mesh_file(argv[2]) != 0) return 1;
    auto client = tcc::Client::connect(static_cast<std::uint32_t>(std::atoi(argv[1])), "consumer");
    if (!client->wait_for_service(10s)) return fail("no tetcollided on this domain");
    const tcc::Mesh a = box(3, {0.0, 0.0, 0.0}, 1.0);
    const tcc::Mesh b = box(3, {0.8, 0.1, 0.1}, 1.0);
    client->register_object("a", a, {});
    client->register_object("b", b, {});
    for (const char* object : {"a", "b"}) {
      const tcc::Registration r = client->wait_registered(object, 10s);
      if (!r.ok) return fail(std::string(object) + " not registered: " + r.message);
    }
    client->publish_states(0, {{"a", a.rest_positions}, {"b", b.rest_positions}});
    const auto answer = client->wait_forces(0, 10s);
    if (!answer) return fail("no forces for frame 0");
    double fx[2] = {0.0, 0.0};
    for (int o = 0; o < 2; ++o) {
      const tcc::ObjectForces* f = answer->find(o == 0 ? "a" : "b");
      if (f == nullptr) return fail(std::string("no answer for ") + (o == 0 ? "a" : "b"));
      if (f->status != 0) return fail(f->object + ": status " + tcc::status_name(f->status));
      if (f->nodes.empty()) return fail(f->object + ": no contact forces");
      for (std::size_t k = 0; k < f->nodes.size(); ++k) fx[o] += f->forces[3 * k];
      std::printf("consumer: frame %lld, %s: %zu nodes, sum fx %.6g N\n",
                  static_cast<long long>(answer->frame), f->object.c_str(), f->nodes.size(), fx[o]);
    }
    if (!(fx[0] < 0.0 && fx[1] > 0.0)) return fail("the forces do not push a and b apart");
  } catch (const std::exception& e) {
    return fail(e.what());
  }
  return 0;
}
