// libtetcollide_client's mesh readers (client/lib/include/tetcollide/mesh.hpp):
// tc::client::read_mesh and read_surface against the core's readers they are built from,
// on every format and on every broken file of tests/data: the same ids, positions (bit
// for bit), tets and triangles, and the same error messages, thrown as MeshError with the
// protocol's status code. Also that the library exports its own API and keeps the core's
// readers hidden. Needs no DDS daemon.
#include <dlfcn.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tetcollide/mesh.hpp>

#include <cctype>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/io/mesh_io.hpp"
#include "core/io/surface_io.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

using ::testing::HasSubstr;

std::filesystem::path mesh_path(const std::string& name) {
  return test::data_path("meshes/" + name);
}
std::filesystem::path surface_path(const std::string& name) {
  return test::data_path("surfaces/" + name);
}

/// `out` holds the positions of `positions` (3 x n) bit for bit, x0 y0 z0 x1 ...
void expect_same_positions(const std::vector<double>& out, const Positions& positions) {
  ASSERT_EQ(out.size(), static_cast<std::size_t>(positions.size()));
  EXPECT_EQ(std::memcmp(out.data(), positions.data(), out.size() * sizeof(double)), 0);
}

template <std::size_t N>
std::vector<std::int32_t> flat(const std::vector<std::array<std::int32_t, N>>& cells) {
  std::vector<std::int32_t> out;
  for (const auto& c : cells) out.insert(out.end(), c.begin(), c.end());
  return out;
}

/// What a MeshError thrown by `read` says, or a test failure when nothing is thrown.
template <typename Read>
client::MeshError thrown_by(Read read) {
  try {
    read();
  } catch (const client::MeshError& e) {
    return e;
  }
  ADD_FAILURE() << "no MeshError";
  return client::MeshError(client::StatusCode::kInternal, "no error");
}

/// The client's mesh has the core reader's node ids and positions.
template <typename CoreMesh>
void expect_same_nodes(const client::Mesh& mesh, const CoreMesh& core) {
  EXPECT_EQ(mesh.node_ids, core.node_ids);
  expect_same_positions(mesh.rest_positions, core.positions);
}

client::StatusCode status_of(ErrorCode code) {
  return static_cast<client::StatusCode>(static_cast<int>(code) + 1);
}

class ClientReadMesh : public ::testing::TestWithParam<const char*> {};

TEST_P(ClientReadMesh, GivesTheCoreReadersMesh) {
  const auto path = mesh_path(GetParam());
  auto core = read_mesh(path);
  ASSERT_TRUE(core.has_value()) << core.error().message;
  const client::Mesh mesh = client::read_mesh(path);
  expect_same_nodes(mesh, *core);
  EXPECT_EQ(mesh.tets, flat(core->tets));
  EXPECT_TRUE(mesh.triangles.empty());
  EXPECT_GT(mesh.tets.size(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Formats, ClientReadMesh,
                         ::testing::Values("box_v22.msh", "box_v41.msh", "box_v41_bin.msh",
                                           "two_tets_v22.msh", "two_tets_crlf_v22.msh",
                                           "tetgen_cubez.1.node", "tetgen_cube.1.ele",
                                           "tetgen_marked.node", "tetgen_cubep.1.ele"));

TEST(ClientReadMesh, TheBoxAsTheFileHoldsIt) {
  // box_v41_bin.msh: 45 nodes tagged 1..45, 100 tets (tests/data/meshes/README.md).
  const client::Mesh mesh = client::read_mesh(mesh_path("box_v41_bin.msh"));
  ASSERT_EQ(mesh.node_ids.size(), 45u);
  EXPECT_EQ(mesh.rest_positions.size(), 3u * 45u);
  EXPECT_EQ(mesh.tets.size(), 4u * 100u);
  for (std::size_t i = 0; i < mesh.node_ids.size(); ++i)
    EXPECT_EQ(mesh.node_ids[i], static_cast<std::int64_t>(i) + 1);
  for (const std::int32_t v : mesh.tets) {
    EXPECT_GE(v, 0);
    EXPECT_LT(v, 45);
  }
}

class ClientReadSurface : public ::testing::TestWithParam<std::filesystem::path> {};

TEST_P(ClientReadSurface, GivesTheCoreReadersSurface) {
  auto core = read_surface(GetParam());
  ASSERT_TRUE(core.has_value()) << core.error().message;
  const client::Mesh mesh = client::read_surface(GetParam());
  expect_same_nodes(mesh, *core);
  EXPECT_EQ(mesh.triangles, flat(core->triangles));
  EXPECT_TRUE(mesh.tets.empty());
  EXPECT_GT(mesh.triangles.size(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Formats, ClientReadSurface,
                         ::testing::Values(surface_path("cube.stl"), surface_path("cube_bin.stl"),
                                           surface_path("octahedron.obj"),
                                           surface_path("plate.obj"),
                                           mesh_path("square_v41_bin.msh")));

TEST(ClientReadSurface, TheCubeAsTheFileHoldsIt) {
  // 36 corners merged into 8 nodes (ids 1..8), 12 triangles.
  const client::Mesh cube = client::read_surface(surface_path("cube.stl"));
  EXPECT_EQ(cube.node_ids.size(), 8u);
  EXPECT_EQ(cube.rest_positions.size(), 24u);
  EXPECT_EQ(cube.triangles.size(), 36u);
}

/// Broken files of both kinds: the client throws the core reader's message unchanged.
struct Broken {
  const char* file;
  bool surface;
};

class ClientReadErrors : public ::testing::TestWithParam<Broken> {};

TEST_P(ClientReadErrors, ThrowTheCoreReadersMessage) {
  const Broken b = GetParam();
  const auto path = b.surface ? surface_path(b.file) : mesh_path(b.file);
  const Error core = b.surface ? read_surface(path).error() : read_mesh(path).error();
  const client::MeshError e = b.surface ? thrown_by([&] { client::read_surface(path); })
                                        : thrown_by([&] { client::read_mesh(path); });
  EXPECT_EQ(std::string(e.what()), core.message);
  EXPECT_EQ(e.code(), status_of(core.code));
  // The file, or for a TetGen pair the file of the two that is at fault.
  EXPECT_THAT(e.what(), HasSubstr(std::filesystem::path(b.file).stem().string()))
      << "the message names the file";
}

INSTANTIATE_TEST_SUITE_P(
    Files, ClientReadErrors,
    ::testing::Values(
        Broken{"broken_bad_node.msh", false}, Broken{"broken_bin_bad_node.msh", false},
        Broken{"broken_bin_datasize.msh", false}, Broken{"broken_bin_endian.msh", false},
        Broken{"broken_bin_huge_count.msh", false}, Broken{"broken_duplicate_tag.msh", false},
        Broken{"broken_empty.msh", false}, Broken{"broken_garbage.msh", false},
        Broken{"broken_nan.msh", false}, Broken{"broken_tet_3_nodes.msh", false},
        Broken{"broken_truncated.msh", false}, Broken{"broken_truncated_bin.msh", false},
        Broken{"broken_v41_short_block.msh", false}, Broken{"broken_version.msh", false},
        Broken{"broken_wrong_count.msh", false}, Broken{"broken_tetgen_range.ele", false},
        Broken{"broken_tetgen_truncated.node", false}, Broken{"tetgen_o2.1.ele", false},
        Broken{"tetgen_cube.node", false}, Broken{"nowhere.msh", false}, Broken{"box.geo", false},
        Broken{"broken_truncated.stl", true}, Broken{"broken_vertex.stl", true},
        Broken{"broken_count.stl", true}, Broken{"broken_nan.stl", true},
        Broken{"broken_empty.stl", true}, Broken{"broken_index.obj", true},
        Broken{"broken_face.obj", true}, Broken{"broken_nan.obj", true},
        Broken{"nowhere.stl", true}, Broken{"cube.ply", true}),
    [](const ::testing::TestParamInfo<Broken>& param) {
      std::string name = param.param.file;
      for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return name;
    });

TEST(ClientReadErrors, MissingAndMalformedFilesSayWhatIsWrong) {
  const auto missing = mesh_path("nowhere.msh");
  client::MeshError e = thrown_by([&] { client::read_mesh(missing); });
  EXPECT_EQ(std::string(e.what()), missing.string() + ": cannot open file");
  EXPECT_EQ(e.code(), client::StatusCode::kIo);

  const auto range = mesh_path("broken_tetgen_range.ele");
  e = thrown_by([&] { client::read_mesh(range); });
  EXPECT_THAT(e.what(), HasSubstr("broken_tetgen_range.ele:3: tet 2 refers to point 12"));
  EXPECT_EQ(e.code(), client::StatusCode::kInvalidMesh);

  const auto truncated = mesh_path("broken_tetgen_truncated.node");
  e = thrown_by([&] { client::read_mesh(truncated); });
  EXPECT_THAT(e.what(), HasSubstr("broken_tetgen_truncated.ele:12: unexpected end of file"));
  EXPECT_EQ(e.code(), client::StatusCode::kParse);

  // The wrong reader for the file: an unknown extension, a tet mesh as a surface.
  e = thrown_by([&] { client::read_mesh(surface_path("cube.stl")); });
  EXPECT_THAT(e.what(), HasSubstr("unknown mesh file extension '.stl'"));
  EXPECT_EQ(e.code(), client::StatusCode::kUnsupported);
  e = thrown_by([&] { client::read_surface(mesh_path("box_v22.msh")); });
  EXPECT_THAT(e.what(), HasSubstr("a tet mesh, not a surface"));
  EXPECT_EQ(e.code(), client::StatusCode::kUnsupported);

  // A MeshError is a std::runtime_error (one catch for a simulator's start-up).
  try {
    client::read_mesh(missing);
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& err) {
    EXPECT_THAT(err.what(), HasSubstr("nowhere.msh: cannot open file"));
  }
}

TEST(ClientLibrary, ExportsItsReadersAndHidesTheCores) {
  void* lib = dlopen(TC_CLIENT_LIBRARY, RTLD_NOW | RTLD_NOLOAD);
  ASSERT_NE(lib, nullptr) << "the test links " << TC_CLIENT_LIBRARY << ": " << dlerror();
  // tc::client::read_mesh(std::filesystem::path const&) and read_surface: exported.
  EXPECT_NE(dlsym(lib, "_ZN2tc6client9read_meshERKNSt10filesystem7__cxx114pathE"), nullptr);
  EXPECT_NE(dlsym(lib, "_ZN2tc6client12read_surfaceERKNSt10filesystem7__cxx114pathE"), nullptr);
  // tc::read_mesh and tc::read_surface of the core inside it: hidden.
  EXPECT_EQ(dlsym(lib, "_ZN2tc9read_meshERKNSt10filesystem7__cxx114pathE"), nullptr);
  EXPECT_EQ(dlsym(lib, "_ZN2tc12read_surfaceERKNSt10filesystem7__cxx114pathE"), nullptr);
  dlclose(lib);
}

}  // namespace
}  // namespace tc
