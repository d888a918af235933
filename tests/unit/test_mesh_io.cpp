// Mesh file layer: Gmsh 2.2/4.1 (ASCII and binary) and TetGen readers on files written
// by Gmsh and TetGen themselves and by hand, every broken file, the Gmsh, TetGen and
// VTU writers on round trips, and a seeded sweep of truncated and corrupted files.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/io/mesh_io.hpp"
#include "core/mesh/geometry.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

std::filesystem::path mesh_path(const std::string& name) {
  return test::data_path("meshes/" + name);
}

std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in) << path;
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TetMesh read_ok(const std::string& name) {
  auto mesh = read_mesh(mesh_path(name));
  EXPECT_TRUE(mesh.has_value()) << (mesh ? "" : mesh.error().message);
  return mesh ? std::move(*mesh) : TetMesh{};
}

/// Structural invariants every mesh a reader returns must satisfy.
void expect_consistent(const TetMesh& mesh) {
  ASSERT_EQ(mesh.node_ids.size(), static_cast<std::size_t>(mesh.positions.cols()));
  EXPECT_TRUE(mesh.positions.allFinite());
  for (const Tet& t : mesh.tets)
    for (const Index v : t) {
      ASSERT_GE(v, 0);
      ASSERT_LT(v, mesh.num_nodes());
    }
}

void expect_same_mesh(const TetMesh& a, const TetMesh& b) {
  EXPECT_EQ(a.node_ids, b.node_ids);
  ASSERT_EQ(a.positions.cols(), b.positions.cols());
  EXPECT_TRUE(a.positions == b.positions);  // bit-identical
  EXPECT_EQ(a.tets, b.tets);
}

double total_volume(const TetMesh& mesh) {
  double v = 0.0;
  for (const Tet& t : mesh.tets) v += signed_volume(mesh.positions, t);
  return v;
}

std::vector<std::int64_t> iota_ids(std::int64_t first, std::size_t n) {
  std::vector<std::int64_t> ids(n);
  std::iota(ids.begin(), ids.end(), first);
  return ids;
}

// ---- Gmsh files written by Gmsh -----------------------------------------------------

class GmshBox : public ::testing::TestWithParam<const char*> {};

TEST_P(GmshBox, ReadsTheUnitCubeMesh) {
  const TetMesh mesh = read_ok(GetParam());
  expect_consistent(mesh);
  EXPECT_EQ(mesh.num_nodes(), 45);
  EXPECT_EQ(mesh.num_tets(), 100);
  EXPECT_EQ(mesh.node_ids, iota_ids(1, 45));
  EXPECT_EQ(mesh.positions.col(0), Eigen::Vector3d(0, 0, 0));
  EXPECT_EQ(mesh.positions.col(6), Eigen::Vector3d(1, 1, 1));
  EXPECT_EQ(mesh.positions.col(8), Eigen::Vector3d(0.4999999999986918, 0, 0));
  EXPECT_EQ(mesh.positions.col(44),
            Eigen::Vector3d(0.5078335741809469, 0.513055956968315, 0.5130559569683161));
  for (const Tet& t : mesh.tets) EXPECT_GT(signed_volume(mesh.positions, t), 0.0);
  EXPECT_NEAR(total_volume(mesh), 1.0, 1e-12);
}

TEST_P(GmshBox, EveryFormatGivesTheSameMesh) {
  // ASCII files hold 16 significant digits, binary files the exact doubles.
  const TetMesh mesh = read_ok(GetParam());
  const TetMesh ref = read_ok("box_v22.msh");
  EXPECT_EQ(mesh.node_ids, ref.node_ids);
  EXPECT_EQ(mesh.tets, ref.tets);
  ASSERT_EQ(mesh.positions.cols(), ref.positions.cols());
  EXPECT_LE((mesh.positions - ref.positions).cwiseAbs().maxCoeff(), 1e-15);
}

TEST_P(GmshBox, TrianglesOfTheSameFileAreItsBoundary) {
  auto tri = read_gmsh_triangles(mesh_path(GetParam()));
  ASSERT_TRUE(tri.has_value()) << tri.error().message;
  EXPECT_EQ(tri->node_ids.size(), 45u);
  EXPECT_EQ(tri->triangles.size(), 84u);
}

INSTANTIATE_TEST_SUITE_P(Formats, GmshBox,
                         ::testing::Values("box_v22.msh", "box_v41.msh", "box_v41_bin.msh"));

class GmshSecondOrder : public ::testing::TestWithParam<const char*> {};

TEST_P(GmshSecondOrder, SkipsType11TetsAndKeepsEveryNode) {
  const TetMesh mesh = read_ok(GetParam());
  expect_consistent(mesh);
  EXPECT_EQ(mesh.num_nodes(), 231);
  EXPECT_EQ(mesh.num_tets(), 0);
  EXPECT_EQ(mesh.node_ids, iota_ids(1, 231));
}

INSTANTIATE_TEST_SUITE_P(Formats, GmshSecondOrder,
                         ::testing::Values("box_order2_v22.msh", "box_order2_v41_bin.msh"));

TEST(GmshMixedOrder, ReadsOnlyThe4NodeTet) {
  const TetMesh mesh = read_ok("mixed_order_v22.msh");
  EXPECT_EQ(mesh.num_nodes(), 11);
  ASSERT_EQ(mesh.num_tets(), 1);
  EXPECT_EQ(mesh.tets[0], (Tet{4, 1, 3, 2}));
}

class GmshSquare : public ::testing::TestWithParam<const char*> {};

TEST_P(GmshSquare, ReadsTrianglesIn2D) {
  auto tri = read_gmsh_triangles(mesh_path(GetParam()));
  ASSERT_TRUE(tri.has_value()) << tri.error().message;
  EXPECT_EQ(tri->node_ids, iota_ids(1, 20));
  ASSERT_EQ(tri->positions.cols(), 20);
  ASSERT_EQ(tri->triangles.size(), 26u);
  EXPECT_EQ(tri->positions.col(2), Eigen::Vector2d(1, 1));
  double area = 0.0;
  for (const auto& t : tri->triangles) {
    for (const Index v : t) ASSERT_TRUE(v >= 0 && v < 20);
    const Eigen::Vector2d a = tri->positions.col(t[1]) - tri->positions.col(t[0]);
    const Eigen::Vector2d b = tri->positions.col(t[2]) - tri->positions.col(t[0]);
    area += 0.5 * std::abs(a.x() * b.y() - a.y() * b.x());
  }
  EXPECT_NEAR(area, 1.0, 1e-12);
  // Same mesh whatever the format.
  auto ref = read_gmsh_triangles(mesh_path("square_v22.msh"));
  ASSERT_TRUE(ref.has_value());
  EXPECT_LE((tri->positions - ref->positions).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(tri->triangles, ref->triangles);
  // The tet reader sees the same nodes and no tet.
  const TetMesh mesh = read_ok(GetParam());
  EXPECT_EQ(mesh.num_nodes(), 20);
  EXPECT_EQ(mesh.num_tets(), 0);
}

INSTANTIATE_TEST_SUITE_P(Formats, GmshSquare,
                         ::testing::Values("square_v22.msh", "square_v41.msh",
                                           "square_v41_bin.msh"));

// ---- Hand-written files: the two_tets_sharing_face fixture --------------------------

TEST(HandWritten, TwoTetsV22WithSparseTagsOrphanAndMixedElements) {
  const TetMesh mesh = read_ok("two_tets_v22.msh");
  const TetMesh ref = test::two_tets_sharing_face();
  EXPECT_EQ(mesh.node_ids, (std::vector<std::int64_t>{10, 20, 30, 40, 50, 99}));
  ASSERT_EQ(mesh.num_nodes(), 6);
  EXPECT_TRUE(mesh.positions.leftCols(5) == ref.positions);
  EXPECT_EQ(mesh.positions.col(5), Eigen::Vector3d(5, 5, 5));
  EXPECT_EQ(mesh.tets, ref.tets);
}

TEST(HandWritten, TwoTetsV41EqualsV22) {
  expect_same_mesh(read_ok("two_tets_v41.msh"), read_ok("two_tets_v22.msh"));
}

TEST(HandWritten, CrlfLineEnds) {
  const TetMesh mesh = read_ok("two_tets_crlf_v22.msh");
  const TetMesh ref = test::two_tets_sharing_face();
  EXPECT_EQ(mesh.node_ids, iota_ids(1, 5));
  EXPECT_TRUE(mesh.positions == ref.positions);
  EXPECT_EQ(mesh.tets, ref.tets);
}

TEST(HandWritten, TetGenWithCommentsAttributesAndMarkers) {
  TetMesh mesh = read_ok("tetgen_marked.node");
  EXPECT_EQ(mesh.node_ids, iota_ids(1, 6));
  TetMesh gmsh = read_ok("two_tets_v22.msh");
  gmsh.node_ids = mesh.node_ids;
  expect_same_mesh(mesh, gmsh);
}

// ---- TetGen files written by TetGen -------------------------------------------------

TEST(TetGen, OneBasedAndZeroBasedGiveTheSameMesh) {
  const TetMesh one = read_ok("tetgen_cube.1.ele");
  const TetMesh zero = read_ok("tetgen_cubez.1.node");
  expect_consistent(one);
  EXPECT_EQ(one.num_nodes(), 11);
  EXPECT_EQ(one.num_tets(), 17);
  EXPECT_EQ(one.node_ids, iota_ids(1, 11));
  EXPECT_EQ(zero.node_ids, iota_ids(0, 11));
  EXPECT_TRUE(one.positions == zero.positions);
  EXPECT_EQ(one.tets, zero.tets);
  // First tet of the file: "1  11 10 9 2" -> 0-based 10 9 8 1.
  EXPECT_EQ(one.tets[0], (Tet{10, 9, 8, 1}));
  EXPECT_EQ(one.positions.col(10), Eigen::Vector3d(0.5, 0, 0.5));
  for (const Tet& t : one.tets) EXPECT_GT(signed_volume(one.positions, t), 0.0);
  EXPECT_NEAR(total_volume(one), 1.0, 1e-12);
}

TEST(TetGen, QualityMeshWithRegionAttribute) {
  const TetMesh mesh = read_ok("tetgen_cubep.1.ele");
  expect_consistent(mesh);
  EXPECT_EQ(mesh.num_nodes(), 50);
  EXPECT_EQ(mesh.num_tets(), 68);
  for (const Tet& t : mesh.tets) EXPECT_GT(signed_volume(mesh.positions, t), 0.0);
  EXPECT_NEAR(total_volume(mesh), 1.0, 1e-12);
}

TEST(TetGen, StemPathWithoutExtension) {
  auto mesh = read_tetgen(mesh_path("tetgen_cube.1"));
  ASSERT_TRUE(mesh.has_value()) << mesh.error().message;
  EXPECT_EQ(mesh->num_tets(), 17);
}

// ---- read_mesh dispatch -------------------------------------------------------------

TEST(ReadMesh, UnknownExtensionIsAnError) {
  auto mesh = read_mesh("some/where/part.stl");
  ASSERT_FALSE(mesh.has_value());
  EXPECT_EQ(mesh.error().code, ErrorCode::kUnsupported);
  EXPECT_THAT(mesh.error().message, HasSubstr("part.stl"));
  EXPECT_THAT(mesh.error().message, HasSubstr("'.stl'"));
  EXPECT_THAT(read_mesh("noext").error().message, HasSubstr("(none)"));
}

TEST(ReadMesh, MissingFileIsAnIoError) {
  for (const char* name : {"nowhere.msh", "nowhere.node", "tetgen_cube.node"}) {
    auto mesh = read_mesh(mesh_path(name));
    ASSERT_FALSE(mesh.has_value()) << name;
    EXPECT_EQ(mesh.error().code, ErrorCode::kIo) << name;
    EXPECT_THAT(mesh.error().message, HasSubstr("cannot open")) << name;
  }
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / "tc_test_mesh_io_dir.msh";
  std::filesystem::create_directories(dir);
  auto from_dir = read_mesh(dir);
  std::filesystem::remove(dir);
  ASSERT_FALSE(from_dir.has_value());
  EXPECT_EQ(from_dir.error().message, dir.string() + ": is a directory, expected a mesh file");
}

TEST(ReadMesh, UppercaseExtension) {
  const std::filesystem::path tmp =
      std::filesystem::temp_directory_path() / "tc_test_mesh_io_upper.MSH";
  std::filesystem::copy_file(mesh_path("box_v41.msh"), tmp,
                             std::filesystem::copy_options::overwrite_existing);
  auto mesh = read_mesh(tmp);
  std::filesystem::remove(tmp);
  ASSERT_TRUE(mesh.has_value()) << mesh.error().message;
  EXPECT_EQ(mesh->num_tets(), 100);
}

// ---- Broken files -------------------------------------------------------------------

struct BrokenCase {
  const char* file;
  ErrorCode code;
  const char* message;  ///< expected right after the path: ":line: ..." or ": byte N: ..."
};

void PrintTo(const BrokenCase& c, std::ostream* os) {
  *os << c.file;
}

class BrokenFile : public ::testing::TestWithParam<BrokenCase> {};

TEST_P(BrokenFile, IsAnErrorNamingFileAndPlace) {
  const BrokenCase& c = GetParam();
  const std::filesystem::path path = mesh_path(c.file);
  auto mesh = read_mesh(path);
  ASSERT_FALSE(mesh.has_value()) << c.file << " was read";
  EXPECT_EQ(error_code_name(mesh.error().code), error_code_name(c.code));
  // TetGen errors name the .node or .ele file of the pair: the expected message then
  // starts with that extension.
  const bool tetgen = path.extension() != ".msh";
  const std::string base = tetgen ? (path.parent_path() / path.stem()).string() : path.string();
  EXPECT_THAT(mesh.error().message, StartsWith(base + c.message));
}

INSTANTIATE_TEST_SUITE_P(
    Files, BrokenFile,
    ::testing::Values(
        BrokenCase{"broken_empty.msh", ErrorCode::kParse,
                   ":1: unexpected end of file, expected $MeshFormat"},
        BrokenCase{"broken_garbage.msh", ErrorCode::kParse,
                   ":1: expected $MeshFormat, got 'hello, this is not a mesh'"},
        BrokenCase{"broken_truncated.msh", ErrorCode::kParse,
                   ":269: expected 4 node tags for element 216, got 0"},
        BrokenCase{"broken_truncated_bin.msh", ErrorCode::kParse,
                   ": byte 7896: unexpected end of file, expected 100 elements of type 4"},
        BrokenCase{"broken_wrong_count.msh", ErrorCode::kParse,
                   ":11: expected node 6 of 6, got '$EndNodes'"},
        BrokenCase{"broken_v41_short_block.msh", ErrorCode::kParse,
                   ":397: expected element 99 of block 27, got '$EndElements'"},
        BrokenCase{"broken_bad_node.msh", ErrorCode::kInvalidMesh,
                   ":15: element 12 refers to unknown node tag 999"},
        BrokenCase{"broken_bin_bad_node.msh", ErrorCode::kInvalidMesh,
                   ": byte 7904: element 117 refers to unknown node tag 4000"},
        BrokenCase{"broken_nan.msh", ErrorCode::kInvalidMesh,
                   ":8: node tag 3 has a non-finite coordinate"},
        BrokenCase{"broken_tet_3_nodes.msh", ErrorCode::kParse,
                   ":15: expected 4 node tags for element 12, got 3"},
        BrokenCase{"broken_duplicate_tag.msh", ErrorCode::kInvalidMesh, ":8: duplicate node tag 2"},
        BrokenCase{"broken_version.msh", ErrorCode::kUnsupported,
                   ":2: MSH version 4 is not supported"},
        BrokenCase{"broken_bin_endian.msh", ErrorCode::kUnsupported,
                   ": byte 20: big-endian binary file"},
        BrokenCase{"broken_bin_datasize.msh", ErrorCode::kUnsupported,
                   ": byte 12: data-size 4 is not supported"},
        BrokenCase{"broken_bin_huge_count.msh", ErrorCode::kParse,
                   ": byte 1899: $Nodes header announces 27 blocks and 1152921504606846976 "
                   "nodes, more than the remaining"},
        BrokenCase{"broken_tetgen_range.ele", ErrorCode::kInvalidMesh,
                   ".ele:3: tet 2 refers to point 12, outside [1, 11]"},
        BrokenCase{"broken_tetgen_truncated.node", ErrorCode::kParse,
                   ".ele:12: unexpected end of file, expected tet 11 of 17"},
        BrokenCase{"tetgen_o2.1.ele", ErrorCode::kUnsupported,
                   ".ele:1: 10-node (second-order) tets are not supported"}));

// ---- Edge cases from memory ---------------------------------------------------------

Error gmsh_error(const std::string& text) {
  auto mesh = read_gmsh_buffer(text, "mem.msh");
  EXPECT_FALSE(mesh.has_value()) << text;
  return mesh ? Error{ErrorCode::kIo, "(no error)"} : mesh.error();
}

const char* const kV41Head = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
const char* const kV22Head = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";

TEST(GmshBuffer, V41HeaderCountMustMatchTheBlocks) {
  const Error e = gmsh_error(std::string(kV41Head) +
                             "$Nodes\n1 3 1 3\n3 1 0 2\n1\n2\n0 0 0\n1 0 0\n$EndNodes\n");
  EXPECT_EQ(e.message, "mem.msh:5: $Nodes header announces 3 nodes, its blocks hold 2");
}

TEST(GmshBuffer, V41NodeTagOutsideTheAnnouncedRange) {
  const Error e =
      gmsh_error(std::string(kV41Head) + "$Nodes\n1 1 1 1\n3 1 0 1\n7\n0 0 0\n$EndNodes\n");
  EXPECT_EQ(e.message,
            "mem.msh:7: node tag 7 outside the range [1, 1] announced in the $Nodes header");
}

TEST(GmshBuffer, V41ParametricCoordinatesCount) {
  const Error e =
      gmsh_error(std::string(kV41Head) + "$Nodes\n1 1 1 1\n2 1 1 1\n1\n0 0 0 0.5\n$EndNodes\n");
  EXPECT_EQ(e.message, "mem.msh:8: expected 5 coordinates for node tag 1, got 4");
}

TEST(GmshBuffer, UnknownElementTypeIsSkippedInAscii) {
  auto mesh = read_gmsh_buffer(std::string(kV22Head) +
                                   "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n"
                                   "$Elements\n2\n1 250 0 whatever tokens here\n"
                                   "2 4 0 1 2 3 4\n$EndElements\n",
                               "mem.msh");
  ASSERT_TRUE(mesh.has_value()) << mesh.error().message;
  EXPECT_EQ(mesh->num_tets(), 1);
}

TEST(GmshBuffer, KnownElementTypeWithWrongNodeCount) {
  const Error e = gmsh_error(std::string(kV22Head) +
                             "$Nodes\n2\n1 0 0 0\n2 1 0 0\n$EndNodes\n"
                             "$Elements\n1\n1 1 2 0 1 1 2 2\n$EndElements\n");
  EXPECT_EQ(e.message, "mem.msh:11: expected 2 node tags for element 1 (type 1), got 3");
}

TEST(GmshBuffer, UnsupportedFlavours) {
  EXPECT_THAT(gmsh_error("$MeshFormat\n2.2 1 8\n").message, HasSubstr("binary MSH 2.2"));
  EXPECT_THAT(gmsh_error("$NOD\n1\n1 0 0 0\n$ENDNOD\n").message, HasSubstr("MSH version 1"));
  EXPECT_EQ(gmsh_error("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n").code, ErrorCode::kParse);
  EXPECT_EQ(gmsh_error("$MeshFormat\n3 0 8\n$EndMeshFormat\n").code, ErrorCode::kUnsupported);
  EXPECT_EQ(gmsh_error("$MeshFormat\n4.1 2 8\n$EndMeshFormat\n").code, ErrorCode::kParse);
}

TEST(GmshBuffer, MissingSections) {
  EXPECT_THAT(gmsh_error(kV22Head).message, HasSubstr("expected a $Nodes section"));
  EXPECT_THAT(gmsh_error(std::string(kV22Head) + "$Nodes\n0\n$EndNodes\n").message,
              HasSubstr("expected an $Elements section"));
  EXPECT_THAT(gmsh_error(std::string(kV22Head) + "$Foo\nbar\n").message,
              HasSubstr("expected $EndFoo to close the section $Foo at line 4"));
  EXPECT_THAT(gmsh_error(std::string(kV22Head) + "$EndNodes\n").message,
              HasSubstr("unexpected '$EndNodes' outside its section"));
}

TEST(GmshBuffer, RepeatedNodeSectionsAppend) {
  auto mesh = read_gmsh_buffer(std::string(kV22Head) +
                                   "$Nodes\n2\n1 0 0 0\n2 1 0 0\n$EndNodes\n"
                                   "$Nodes\n2\n3 0 1 0\n4 0 0 1\n$EndNodes\n"
                                   "$Elements\n1\n1 4 0 1 2 3 4\n$EndElements\n",
                               "mem.msh");
  ASSERT_TRUE(mesh.has_value()) << mesh.error().message;
  EXPECT_EQ(mesh->num_nodes(), 4);
  EXPECT_EQ(mesh->tets[0], (Tet{0, 1, 2, 3}));
}

TEST(GmshBuffer, HugeAndSparseTagsMapToFileOrder) {
  const std::int64_t big = 1'000'000'000'000'000;
  const std::string text = std::string(kV22Head) + "$Nodes\n5\n" + std::to_string(big) +
                           " 0 0 0\n0 1 0 0\n3000000 0 1 0\n5 0 0 1\n" + std::to_string(big - 1) +
                           " 1 1 1\n$EndNodes\n$Elements\n2\n1 4 0 " + std::to_string(big) +
                           " 0 3000000 5\n2 4 0 " + std::to_string(big - 1) +
                           " 0 5 3000000\n$EndElements\n";
  auto mesh = read_gmsh_buffer(text, "mem.msh");
  ASSERT_TRUE(mesh.has_value()) << mesh.error().message;
  EXPECT_EQ(mesh->node_ids, (std::vector<std::int64_t>{big, 0, 3000000, 5, big - 1}));
  EXPECT_EQ(mesh->tets, (std::vector<Tet>{{0, 1, 2, 3}, {4, 1, 3, 2}}));
}

TEST(GmshBuffer, BadNumbers) {
  const std::string nodes = "$Nodes\n1\n";
  EXPECT_EQ(gmsh_error(std::string(kV22Head) + nodes + "-1 0 0 0\n").message,
            "mem.msh:6: expected a non-negative node tag, got '-1'");
  EXPECT_EQ(gmsh_error(std::string(kV22Head) + nodes + "1 0 0x1 0\n").message,
            "mem.msh:6: expected a coordinate of node tag 1, got '0x1'");
  EXPECT_EQ(gmsh_error(std::string(kV22Head) + nodes + "1 0 1e999 0\n").message,
            "mem.msh:6: node tag 1 has a non-finite coordinate");
  EXPECT_EQ(gmsh_error(std::string(kV22Head) + nodes + "1 0 1e-400 0\n$EndNodes\n").message,
            "mem.msh:8: unexpected end of file, expected an $Elements section");
  EXPECT_EQ(gmsh_error(std::string(kV22Head) + nodes + "1 0 inf 0\n").code,
            ErrorCode::kInvalidMesh);
  EXPECT_EQ(gmsh_error(std::string(kV22Head) + nodes + "1 0 0\n$EndNodes\n").message,
            "mem.msh:6: expected 'tag x y z' for node 1 of 1, got '1 0 0'");
  EXPECT_EQ(gmsh_error(std::string(kV22Head) + "$Nodes\n99999999999999999999\n").code,
            ErrorCode::kParse);
  // Counts far beyond the data never allocate.
  EXPECT_THAT(gmsh_error(std::string(kV22Head) + "$Nodes\n4611686018427387904\n").message,
              HasSubstr("4611686018427387904 nodes announced, more than the remaining"));
  EXPECT_THAT(gmsh_error(std::string(kV41Head) + "$Elements\n0 4611686018427387904 1 1\n").message,
              HasSubstr("4611686018427387904 elements announced"));
}

/// A 4.1 binary file from pieces, for forged headers.
class BinaryFile {
 public:
  BinaryFile() { text("$MeshFormat\n4.1 1 8\n").i32(1).text("\n$EndMeshFormat\n"); }
  BinaryFile& text(const std::string& s) {
    data_ += s;
    return *this;
  }
  BinaryFile& i32(std::int32_t v) { return raw(&v, 4); }
  BinaryFile& u64(std::uint64_t v) { return raw(&v, 8); }
  BinaryFile& f64(double v) { return raw(&v, 8); }
  [[nodiscard]] const std::string& str() const { return data_; }

 private:
  BinaryFile& raw(const void* p, std::size_t n) {
    data_.append(static_cast<const char*>(p), n);
    return *this;
  }
  std::string data_;
};

BinaryFile one_node_binary() {
  BinaryFile f;
  f.text("$Nodes\n").u64(1).u64(4).u64(1).u64(4).i32(3).i32(1).i32(0).u64(4);
  for (std::uint64_t t = 1; t <= 4; ++t) f.u64(t);
  for (int i = 0; i < 4; ++i) f.f64(i == 1).f64(i == 2).f64(i == 3);
  f.text("\n$EndNodes\n");
  return f;
}

TEST(GmshBinary, ForgedFileReads) {
  BinaryFile f = one_node_binary();
  f.text("$Elements\n").u64(2).u64(2).u64(1).u64(2);
  f.i32(2).i32(1).i32(2).u64(1).u64(1).u64(1).u64(2).u64(3);         // a triangle
  f.i32(3).i32(1).i32(4).u64(1).u64(2).u64(4).u64(3).u64(2).u64(1);  // a tet
  f.text("\n$EndElements\n");
  auto mesh = read_gmsh_buffer(f.str(), "mem.msh");
  ASSERT_TRUE(mesh.has_value()) << mesh.error().message;
  EXPECT_EQ(mesh->tets, (std::vector<Tet>{{3, 2, 1, 0}}));
  auto tri = read_gmsh_triangles_buffer(f.str(), "mem.msh");
  ASSERT_TRUE(tri.has_value());
  EXPECT_EQ(tri->triangles, (std::vector<std::array<Index, 3>>{{0, 1, 2}}));
  EXPECT_EQ(tri->positions.col(1), Eigen::Vector2d(1, 0));
}

TEST(GmshBinary, PolygonBlockCannotBeSkipped) {
  BinaryFile f = one_node_binary();
  f.text("$Elements\n").u64(1).u64(1).u64(1).u64(1).i32(2).i32(1).i32(34).u64(1).u64(1);
  auto mesh = read_gmsh_buffer(f.str(), "mem.msh");
  ASSERT_FALSE(mesh.has_value());
  EXPECT_EQ(mesh.error().code, ErrorCode::kUnsupported);
  EXPECT_THAT(mesh.error().message, HasSubstr("element type 34 has no known fixed node count"));
}

TEST(GmshBinary, BlockCountsBeyondTheData) {
  BinaryFile f = one_node_binary();
  f.text("$Elements\n").u64(1).u64(1).u64(1).u64(1).i32(3).i32(1).i32(4).u64(1ull << 62);
  auto mesh = read_gmsh_buffer(f.str(), "mem.msh");
  ASSERT_FALSE(mesh.has_value());
  EXPECT_THAT(mesh.error().message, HasSubstr("element blocks hold more than the 1 elements"));
  BinaryFile g;
  g.text("$Nodes\n").u64(1).u64(0).u64(0).u64(0).i32(3).i32(1).i32(0).u64(1ull << 62);
  auto nodes = read_gmsh_buffer(g.str(), "mem.msh");
  ASSERT_FALSE(nodes.has_value());
  EXPECT_THAT(nodes.error().message, HasSubstr("node blocks hold more than the 0 nodes"));
}

TEST(GmshBinary, EntitiesAreParsedNotSearched) {
  // The $Entities payload contains the bytes "\n$EndEntities\n" inside a physical tag
  // list; a reader that searched for the marker would stop there.
  BinaryFile f;
  f.text("$Entities\n").u64(1).u64(0).u64(0).u64(0);
  const std::string fake = "\n$EndEntities\n..";  // 16 bytes = 4 ints
  f.i32(1).f64(0).f64(0).f64(0).u64(4).text(fake);
  f.text("\n$EndEntities\n");
  const BinaryFile nodes = one_node_binary();
  const std::string tail = nodes.str().substr(nodes.str().find("$Nodes"));
  f.text(tail).text("$Elements\n").u64(0).u64(0).u64(0).u64(0).text("\n$EndElements\n");
  auto mesh = read_gmsh_buffer(f.str(), "mem.msh");
  ASSERT_TRUE(mesh.has_value()) << mesh.error().message;
  EXPECT_EQ(mesh->num_nodes(), 4);
}

// ---- TetGen from memory -------------------------------------------------------------

Error tetgen_error(const std::string& node, const std::string& ele) {
  auto mesh = read_tetgen_buffers(node, ele, "mem");
  EXPECT_FALSE(mesh.has_value()) << node << "\n---\n" << ele;
  return mesh ? Error{ErrorCode::kIo, "(no error)"} : mesh.error();
}

const char* const kNode4 = "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n";
const char* const kEle1 = "1 4 0\n0 0 1 2 3\n";

TEST(TetGenBuffer, ZeroBasedMinimalHeaders) {
  auto mesh =
      read_tetgen_buffers("4\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n", "1\n0 0 1 2 3\n", "mem");
  ASSERT_TRUE(mesh.has_value()) << mesh.error().message;
  expect_same_mesh(*mesh, [] {
    TetMesh m = test::single_tet();
    m.node_ids = iota_ids(0, 4);
    return m;
  }());
}

TEST(TetGenBuffer, MissingAttributesAreAccepted) {
  auto mesh = read_tetgen_buffers("4 3 2 1\n1 0 0 0 7\n2 1 0 0\n3 0 1 0 1 2 1\n4 0 0 1\n",
                                  "1 4 1\n1 1 2 3 4\n", "mem");
  ASSERT_TRUE(mesh.has_value()) << mesh.error().message;
  EXPECT_EQ(mesh->tets[0], (Tet{0, 1, 2, 3}));
}

// Found by fuzz/fuzz_tetgen (fuzz/regressions/tetgen/): an attribute count near 2^63
// overflowed the per-line token limit (signed overflow, UB).
TEST(TetGenBuffer, HugeAttributeCountsAreErrors) {
  EXPECT_EQ(tetgen_error("4 3 9223372036854775807 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n", kEle1)
                .message,
            "mem.node:1: expected at most 2147483647 attributes per point, got "
            "9223372036854775807");
  EXPECT_EQ(tetgen_error(kNode4, "1 4 9223372036854775807\n0 0 1 2 3\n").message,
            "mem.ele:1: expected at most 2147483647 attributes per tet, got 9223372036854775807");
}

TEST(TetGenBuffer, Errors) {
  EXPECT_EQ(tetgen_error("4 3 0 0\n0 0 0 0\n1 1 0 0\n3 0 1 0\n2 0 0 1\n", kEle1).message,
            "mem.node:4: expected point index 2 (points are numbered consecutively), got 3");
  EXPECT_EQ(tetgen_error("1 3 0 0\n5 0 0 0\n", kEle1).message,
            "mem.node:2: the first point index must be 0 or 1 (it sets the numbering base), "
            "got 5");
  EXPECT_EQ(tetgen_error("1 2 0 0\n0 0 0\n", kEle1).code, ErrorCode::kUnsupported);
  EXPECT_EQ(tetgen_error("1 3 0 0\n0 0 0 0 9\n", kEle1).message,
            "mem.node:2: point 0 has more than the 4 values the header allows");
  EXPECT_EQ(tetgen_error(std::string(kNode4) + "4 1 1 1\n", kEle1).message,
            "mem.node:6: unexpected line after the 4 points announced: '4 1 1 1'");
  EXPECT_EQ(tetgen_error("2 3 0 0\n0 0 0 0\n1 nan 0 0\n", kEle1).message,
            "mem.node:3: point 1 has a non-finite coordinate");
  EXPECT_EQ(tetgen_error("", kEle1).message,
            "mem.node:1: unexpected end of file, expected '<#points> <dim> <#attributes> "
            "<#markers>' (empty file)");
  EXPECT_EQ(tetgen_error("# nothing\n\n", kEle1).code, ErrorCode::kParse);
  EXPECT_EQ(tetgen_error("1 3 0 2\n0 0 0 0\n", kEle1).code, ErrorCode::kParse);
  EXPECT_THAT(tetgen_error("4611686018427387904 3 0 0\n", kEle1).message,
              HasSubstr("4611686018427387904 points announced"));
  EXPECT_EQ(tetgen_error(kNode4, "1 4 0\n0 0 1 2 # short\n").message,
            "mem.ele:2: expected 4 point indices for tet 0, got 3");
  EXPECT_EQ(tetgen_error(kNode4, "1 4 0\n0 0 1 2 3 9\n").message,
            "mem.ele:2: tet 0 has more than the 5 values the header allows");
  EXPECT_EQ(tetgen_error(kNode4, "1 4 0\n0 0 1 2 -1\n").message,
            "mem.ele:2: tet 0 refers to point -1, outside [0, 3]");
  EXPECT_EQ(tetgen_error(kNode4, "1 3 0\n").code, ErrorCode::kParse);
  EXPECT_EQ(tetgen_error(kNode4, "1 10 0\n").code, ErrorCode::kUnsupported);
  EXPECT_EQ(tetgen_error(kNode4, "2 4 0\n0 0 1 2 3\n# no second tet\n").message,
            "mem.ele:4: unexpected end of file, expected tet 2 of 2");
  EXPECT_EQ(tetgen_error(kNode4, "1 4 0\n0 0 1 2 3\n1 0 1 2 3\n").message,
            "mem.ele:3: unexpected line after the 1 tets announced: '1 0 1 2 3'");
}

// ---- Gmsh writer round trips --------------------------------------------------------

/// structured_box with scattered, non-contiguous ids in shuffled order.
TetMesh scattered_box() {
  TetMesh mesh = test::structured_box(4, 3, 2, Eigen::Vector3d(-1e6, 0.1, 3.0),
                                      Eigen::Vector3d(-1e6 + 1e-3, 0.7, 1e6));
  std::mt19937_64 rng(7);
  for (std::size_t i = 0; i < mesh.node_ids.size(); ++i)
    mesh.node_ids[i] = static_cast<std::int64_t>(1 + 13 * i + (i % 5) * 1'000'000'000'000ll);
  std::shuffle(mesh.node_ids.begin(), mesh.node_ids.end(), rng);
  return mesh;
}

class GmshRoundTrip : public ::testing::TestWithParam<GmshFormat> {};

TEST_P(GmshRoundTrip, WriteThenReadIsExact) {
  const TetMesh empty;
  TetMesh nodes_only = test::single_tet();
  nodes_only.tets.clear();
  for (const TetMesh& mesh : {scattered_box(), test::cube_five_tets(1e-6), nodes_only, empty}) {
    auto text = format_gmsh(mesh, GetParam());
    ASSERT_TRUE(text.has_value()) << text.error().message;
    auto back = read_gmsh_buffer(*text, "roundtrip.msh");
    ASSERT_TRUE(back.has_value()) << back.error().message;
    expect_same_mesh(*back, mesh);
  }
}

TEST_P(GmshRoundTrip, FileRoundTripMatchesGmshOutput) {
  const TetMesh box = read_ok("box_v41_bin.msh");
  const std::filesystem::path tmp =
      std::filesystem::temp_directory_path() /
      ("tc_test_mesh_io_" + std::to_string(static_cast<int>(GetParam())) + ".msh");
  ASSERT_TRUE(write_gmsh(tmp, box, GetParam()).ok());
  auto back = read_mesh(tmp);
  std::filesystem::remove(tmp);
  ASSERT_TRUE(back.has_value()) << back.error().message;
  expect_same_mesh(*back, box);
}

INSTANTIATE_TEST_SUITE_P(Formats, GmshRoundTrip,
                         ::testing::Values(GmshFormat::kMsh22Ascii, GmshFormat::kMsh41Ascii,
                                           GmshFormat::kMsh41Binary));

TEST(GmshWriter, RejectsWhatGmshCannotHold) {
  TetMesh mesh = test::single_tet();
  mesh.node_ids[2] = 0;
  EXPECT_THAT(format_gmsh(mesh, GmshFormat::kMsh41Ascii).error().message,
              HasSubstr("node 2 has id 0"));
  mesh.node_ids[2] = 1;
  EXPECT_THAT(format_gmsh(mesh, GmshFormat::kMsh41Ascii).error().message,
              HasSubstr("duplicate node id 1"));
  mesh = test::single_tet();
  mesh.positions(1, 3) = std::nan("");
  EXPECT_EQ(format_gmsh(mesh, GmshFormat::kMsh22Ascii).error().code, ErrorCode::kInvalidArgument);
  mesh = test::single_tet();
  mesh.tets[0][3] = 4;
  EXPECT_THAT(format_gmsh(mesh, GmshFormat::kMsh41Binary).error().message,
              HasSubstr("tet 0 refers to node 4"));
  const Status st =
      write_gmsh("/nonexistent-dir/x.msh", test::single_tet(), GmshFormat::kMsh41Binary);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kIo);
  EXPECT_THAT(st.error().message, HasSubstr("/nonexistent-dir/x.msh"));
}

// ---- TetGen writer round trips ------------------------------------------------------

/// Same node ids, same tets, and positions equal bit for bit (-0.0 is not 0.0 here).
void expect_identical_mesh(const TetMesh& a, const TetMesh& b) {
  EXPECT_EQ(a.node_ids, b.node_ids);
  ASSERT_EQ(a.positions.cols(), b.positions.cols());
  if (a.positions.size() > 0) {  // memcmp must not be given the null data of an empty matrix
    EXPECT_EQ(std::memcmp(a.positions.data(), b.positions.data(),
                          sizeof(double) * static_cast<std::size_t>(a.positions.size())),
              0);
  }
  EXPECT_EQ(a.tets, b.tets);
}

/// Coordinates that only the shortest round-trip form (or 17 digits) keeps: -0, the
/// smallest subnormal, the largest double, 0.1, 1/3, huge offsets, tiny scales.
TetMesh awkward_numbers_mesh() {
  TetMesh mesh = test::cube_five_tets(1e-6);
  const double values[] = {-0.0,
                           std::numeric_limits<double>::denorm_min(),
                           std::numeric_limits<double>::max(),
                           -std::numeric_limits<double>::min(),
                           0.1,
                           1.0 / 3.0,
                           -1e6 + 1e-9,
                           std::nextafter(1.0, 2.0),
                           6.02214076e23,
                           -2.718281828459045e-300};
  for (Eigen::Index i = 0; i < mesh.positions.size(); ++i)
    mesh.positions.data()[i] =
        values[static_cast<std::size_t>(i) % std::size(values)] * (i % 3 == 0 ? 1.0 : -1.0);
  return mesh;
}

TetMesh zero_based(TetMesh mesh) {
  std::iota(mesh.node_ids.begin(), mesh.node_ids.end(), std::int64_t{0});
  return mesh;
}

TEST(TetGenWriter, WriteThenReadIsExact) {
  const TetMesh empty;
  TetMesh nodes_only = test::single_tet();
  nodes_only.tets.clear();
  const TetMesh box = test::structured_box(4, 3, 2, Eigen::Vector3d(-1e6, 0.1, 3.0),
                                           Eigen::Vector3d(-1e6 + 1e-3, 0.7, 1e6));
  for (const TetMesh& mesh :
       {box, zero_based(box), awkward_numbers_mesh(), zero_based(awkward_numbers_mesh()),
        test::cube_five_tets(1e-6), nodes_only, zero_based(nodes_only), empty}) {
    auto text = format_tetgen(mesh);
    ASSERT_TRUE(text.has_value()) << text.error().message;
    auto back = read_tetgen_buffers(text->node, text->ele, "roundtrip");
    ASSERT_TRUE(back.has_value()) << back.error().message << "\n" << text->node << text->ele;
    expect_identical_mesh(*back, mesh);
  }
}

TEST(TetGenWriter, TheTextIsWhatTetGenWrites) {
  auto text = format_tetgen(test::single_tet());
  ASSERT_TRUE(text.has_value()) << text.error().message;
  EXPECT_EQ(text->node, "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
  EXPECT_EQ(text->ele, "1 4 0\n1 1 2 3 4\n");
  text = format_tetgen(zero_based(test::single_tet()));
  ASSERT_TRUE(text.has_value()) << text.error().message;
  EXPECT_EQ(text->node, "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n");
  EXPECT_EQ(text->ele, "1 4 0\n0 0 1 2 3\n");
}

TEST(TetGenWriter, IdsTetGenCannotHoldBecomeOneToN) {
  const TetMesh mesh = scattered_box();
  EXPECT_EQ(tetgen_base(mesh), 1);
  auto text = format_tetgen(mesh);
  ASSERT_TRUE(text.has_value()) << text.error().message;
  auto back = read_tetgen_buffers(text->node, text->ele, "scattered");
  ASSERT_TRUE(back.has_value()) << back.error().message;
  EXPECT_EQ(back->node_ids, iota_ids(1, mesh.node_ids.size()));
  EXPECT_EQ(std::memcmp(back->positions.data(), mesh.positions.data(),
                        sizeof(double) * static_cast<std::size_t>(mesh.positions.size())),
            0);
  EXPECT_EQ(back->tets, mesh.tets);
  // Ids 0..n-1 in another order are not 0-based numbering either.
  TetMesh swapped = zero_based(test::single_tet());
  std::swap(swapped.node_ids[0], swapped.node_ids[1]);
  EXPECT_EQ(tetgen_base(swapped), 1);
  EXPECT_EQ(tetgen_base(zero_based(test::single_tet())), 0);
  EXPECT_EQ(tetgen_base(TetMesh{}), 0);
}

TEST(TetGenWriter, FilesOfTetGenAndGmshRoundTrip) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("tc_test_tetgen_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  // A 0-based file TetGen wrote, a 1-based one, and a Gmsh file (tags 1..45).
  for (const char* name : {"tetgen_cubez.1.node", "tetgen_cube.1.ele", "box_v41_bin.msh"}) {
    const TetMesh mesh = read_ok(name);
    // OUT given as the .node, the .ele or the stem: the same two files.
    for (const char* out : {"copy.node", "copy.ELE", "copy"}) {
      std::filesystem::remove(dir / "copy.node");
      std::filesystem::remove(dir / "copy.ele");
      const Status st = write_tetgen(dir / out, mesh);
      ASSERT_TRUE(st.ok()) << st.error().message;
      EXPECT_TRUE(std::filesystem::exists(dir / "copy.node")) << name << " " << out;
      EXPECT_TRUE(std::filesystem::exists(dir / "copy.ele")) << name << " " << out;
      for (const char* back_name : {"copy.node", "copy.ele"}) {
        auto back = read_mesh(dir / back_name);
        ASSERT_TRUE(back.has_value()) << back.error().message;
        expect_identical_mesh(*back, mesh);
      }
    }
  }
  EXPECT_EQ(tetgen_stem("a/b.1.node"), std::filesystem::path("a/b.1"));
  EXPECT_EQ(tetgen_stem("a/b.1.Ele"), std::filesystem::path("a/b.1"));
  EXPECT_EQ(tetgen_stem("a/b.1"), std::filesystem::path("a/b.1"));
  std::filesystem::remove_all(dir);
}

TEST(TetGenWriter, RejectsWhatTheReaderWouldRefuse) {
  TetMesh mesh = test::single_tet();
  mesh.positions(1, 3) = std::numeric_limits<double>::infinity();
  auto text = format_tetgen(mesh);
  ASSERT_FALSE(text.has_value());
  EXPECT_EQ(text.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(text.error().message, "node 3 has a non-finite coordinate");
  mesh = test::single_tet();
  mesh.tets[0][3] = 4;
  EXPECT_EQ(format_tetgen(mesh).error().message, "tet 0 refers to node 4, outside [0, 4)");
  mesh = test::single_tet();
  mesh.node_ids.pop_back();
  EXPECT_EQ(format_tetgen(mesh).error().message, "mesh has 3 node ids for 4 nodes");
  Status st = write_tetgen("/nonexistent-dir/x.ele", mesh);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().message, "/nonexistent-dir/x.node: mesh has 3 node ids for 4 nodes");
  st = write_tetgen("/nonexistent-dir/x.ele", test::single_tet());
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kIo);
  EXPECT_EQ(st.error().message, "/nonexistent-dir/x.node: cannot open file for writing");
}

TEST(GmshElementTypes, NodeCounts) {
  EXPECT_EQ(gmsh_element_node_count(1), 2);
  EXPECT_EQ(gmsh_element_node_count(2), 3);
  EXPECT_EQ(gmsh_element_node_count(4), 4);
  EXPECT_EQ(gmsh_element_node_count(11), 10);
  EXPECT_EQ(gmsh_element_node_count(15), 1);
  EXPECT_EQ(gmsh_element_node_count(29), 20);
  EXPECT_EQ(gmsh_element_node_count(92), 64);
  EXPECT_EQ(gmsh_element_node_count(140), 4);
  for (const int unknown : {-1, 0, 34, 35, 69, 76, 138, 141, 1 << 30})
    EXPECT_EQ(gmsh_element_node_count(unknown), 0) << unknown;
}

// ---- VTU writer ---------------------------------------------------------------------

/// Minimal XML reader for the files write_vtu produces: checks that tags nest and
/// close properly, and collects each DataArray's attributes and numbers.
struct VtuArray {
  std::map<std::string, std::string> attributes;
  std::vector<double> values;
};

struct VtuDocument {
  std::vector<std::string> path_of_arrays;  ///< parent element of each DataArray
  std::vector<VtuArray> arrays;
  std::map<std::string, std::string> piece;
  std::map<std::string, std::string> root;
};

std::map<std::string, std::string> parse_attributes(const std::string& tag) {
  std::map<std::string, std::string> out;
  std::size_t i = tag.find(' ');
  while (i != std::string::npos && i < tag.size()) {
    const std::size_t eq = tag.find('=', i);
    if (eq == std::string::npos) break;
    const std::size_t q1 = tag.find('"', eq);
    const std::size_t q2 = tag.find('"', q1 + 1);
    std::string key = tag.substr(i, eq - i);
    key.erase(0, key.find_first_not_of(' '));
    out[key] = tag.substr(q1 + 1, q2 - q1 - 1);
    i = q2 + 1;
  }
  return out;
}

VtuDocument parse_vtu(const std::string& xml) {
  VtuDocument doc;
  EXPECT_EQ(xml.rfind("<?xml version=\"1.0\"?>\n", 0), 0u);
  std::vector<std::string> stack;
  std::size_t pos = xml.find("?>") + 2;
  while ((pos = xml.find('<', pos)) != std::string::npos) {
    const std::size_t end = xml.find('>', pos);
    EXPECT_NE(end, std::string::npos);
    std::string tag = xml.substr(pos + 1, end - pos - 1);
    if (tag.front() == '/') {
      EXPECT_FALSE(stack.empty());
      if (stack.empty()) return doc;
      EXPECT_EQ(stack.back(), tag.substr(1)) << "mismatched closing tag";
      stack.pop_back();
    } else {
      const std::string name = tag.substr(0, tag.find(' '));
      const auto attributes = parse_attributes(tag);
      if (name == "VTKFile") doc.root = attributes;
      if (name == "Piece") doc.piece = attributes;
      if (name == "DataArray") {
        VtuArray a;
        a.attributes = attributes;
        const std::size_t close = xml.find("</DataArray>", end);
        std::istringstream values(xml.substr(end + 1, close - end - 1));
        std::string token;
        while (values >> token) a.values.push_back(std::stod(token));
        doc.arrays.push_back(std::move(a));
        doc.path_of_arrays.push_back(stack.empty() ? "" : stack.back());
      }
      stack.push_back(name);
    }
    pos = end + 1;
  }
  EXPECT_TRUE(stack.empty()) << "unclosed element " << (stack.empty() ? "" : stack.back());
  return doc;
}

const VtuArray* find_array(const VtuDocument& doc, const std::string& parent,
                           const std::string& name) {
  for (std::size_t i = 0; i < doc.arrays.size(); ++i)
    if (doc.path_of_arrays[i] == parent && doc.arrays[i].attributes.at("Name") == name)
      return &doc.arrays[i];
  return nullptr;
}

class VtuTest : public ::testing::Test {
 protected:
  void TearDown() override { std::filesystem::remove(path_); }
  std::string write(const TetMesh& mesh, const std::vector<VtuField>& points,
                    const std::vector<VtuField>& cells) {
    const Status st = write_vtu(path_, mesh, points, cells);
    EXPECT_TRUE(st.ok()) << (st.ok() ? "" : st.error().message);
    return slurp(path_);
  }
  Error write_error(const TetMesh& mesh, const std::vector<VtuField>& points,
                    const std::vector<VtuField>& cells) {
    const Status st = write_vtu(path_, mesh, points, cells);
    EXPECT_FALSE(st.ok());
    return st.ok() ? Error{ErrorCode::kIo, "(no error)"} : st.error();
  }
  // One file per process: ctest runs the tests of this fixture in parallel processes.
  std::filesystem::path path_ = std::filesystem::temp_directory_path() /
                                ("tc_test_mesh_io_" + std::to_string(::getpid()) + ".vtu");
};

TEST_F(VtuTest, RoundTripOfPointsCellsAndFields) {
  const TetMesh mesh = scattered_box();
  std::vector<VtuField> points(2);
  points[0].name = "temperature";
  points[1].name = "velocity <&\"'>";
  points[1].components = 3;
  for (Index i = 0; i < mesh.num_nodes(); ++i) {
    points[0].values.push_back(0.1 * i - 3.0);
    for (int k = 0; k < 3; ++k) points[1].values.push_back(1e-300 * (i + k));
  }
  std::vector<VtuField> cells(1);
  cells[0].name = "quality";
  for (const Tet& t : mesh.tets) cells[0].values.push_back(tet_quality(mesh.positions, t));

  const std::string xml = write(mesh, points, cells);
  EXPECT_THAT(xml, HasSubstr("Name=\"velocity &lt;&amp;&quot;&apos;&gt;\""));
  const VtuDocument doc = parse_vtu(xml);
  EXPECT_EQ(doc.root.at("type"), "UnstructuredGrid");
  EXPECT_EQ(doc.root.at("byte_order"), "LittleEndian");
  EXPECT_EQ(doc.piece.at("NumberOfPoints"), std::to_string(mesh.num_nodes()));
  EXPECT_EQ(doc.piece.at("NumberOfCells"), std::to_string(mesh.num_tets()));

  const VtuArray* pts = find_array(doc, "Points", "Points");
  ASSERT_NE(pts, nullptr);
  EXPECT_EQ(pts->attributes.at("type"), "Float64");
  EXPECT_EQ(pts->attributes.at("NumberOfComponents"), "3");
  ASSERT_EQ(pts->values.size(), 3u * static_cast<std::size_t>(mesh.num_nodes()));
  for (Index i = 0; i < mesh.num_nodes(); ++i)
    for (int k = 0; k < 3; ++k)
      ASSERT_EQ(pts->values[static_cast<std::size_t>(3 * i + k)], mesh.positions(k, i));

  const VtuArray* conn = find_array(doc, "Cells", "connectivity");
  const VtuArray* offsets = find_array(doc, "Cells", "offsets");
  const VtuArray* types = find_array(doc, "Cells", "types");
  ASSERT_TRUE(conn && offsets && types);
  EXPECT_EQ(conn->attributes.at("type"), "Int64");
  EXPECT_EQ(offsets->attributes.at("type"), "Int64");
  EXPECT_EQ(types->attributes.at("type"), "UInt8");
  ASSERT_EQ(conn->values.size(), 4u * mesh.tets.size());
  ASSERT_EQ(offsets->values.size(), mesh.tets.size());
  ASSERT_EQ(types->values.size(), mesh.tets.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    for (std::size_t j = 0; j < 4; ++j) ASSERT_EQ(conn->values[4 * t + j], mesh.tets[t][j]);
    ASSERT_EQ(offsets->values[t], 4.0 * static_cast<double>(t + 1));
    ASSERT_EQ(types->values[t], 10.0);
  }

  const VtuArray* ids = find_array(doc, "PointData", "node_id");
  ASSERT_NE(ids, nullptr);
  EXPECT_EQ(ids->attributes.at("type"), "Int64");
  for (std::size_t i = 0; i < mesh.node_ids.size(); ++i)
    ASSERT_EQ(static_cast<std::int64_t>(ids->values[i]), mesh.node_ids[i]);
  const VtuArray* temperature = find_array(doc, "PointData", "temperature");
  ASSERT_NE(temperature, nullptr);
  EXPECT_EQ(temperature->values, points[0].values);
  const VtuArray* velocity = find_array(doc, "PointData", "velocity &lt;&amp;&quot;&apos;&gt;");
  ASSERT_NE(velocity, nullptr);
  EXPECT_EQ(velocity->attributes.at("NumberOfComponents"), "3");
  EXPECT_EQ(velocity->values, points[1].values);
  const VtuArray* quality = find_array(doc, "CellData", "quality");
  ASSERT_NE(quality, nullptr);
  EXPECT_EQ(quality->values, cells[0].values);
}

TEST_F(VtuTest, TrianglesFollowTheTetsInAMixedGrid) {
  // Two tets (5 nodes) and a triangle surface of 3 more nodes in one grid, as the demo
  // writes a tet object beside a shell.
  TetMesh mesh = test::two_tets_sharing_face();
  mesh.positions.conservativeResize(3, 8);
  mesh.positions.rightCols<3>() << 2, 3, 2, 0, 0, 1, 5, 5, 5;
  for (std::int64_t id = 6; id <= 8; ++id) mesh.node_ids.push_back(id);
  const std::vector<std::array<Index, 3>> triangles{{5, 6, 7}};
  const std::vector<VtuField> cells{{"object", 1, {0.0, 0.0, 1.0}}};
  ASSERT_TRUE(write_vtu(path_, mesh, triangles, {}, cells).ok());
  const VtuDocument doc = parse_vtu(slurp(path_));
  EXPECT_EQ(doc.piece.at("NumberOfCells"), "3");
  const VtuArray* conn = find_array(doc, "Cells", "connectivity");
  const VtuArray* offsets = find_array(doc, "Cells", "offsets");
  const VtuArray* types = find_array(doc, "Cells", "types");
  ASSERT_TRUE(conn && offsets && types);
  EXPECT_EQ(offsets->values, (std::vector<double>{4, 8, 11}));
  EXPECT_EQ(types->values, (std::vector<double>{10, 10, 5}));  // VTK_TETRA, VTK_TRIANGLE
  EXPECT_EQ(std::vector<double>(conn->values.end() - 3, conn->values.end()),
            (std::vector<double>{5, 6, 7}));
  // A triangle naming a node outside the grid is refused, as a tet is.
  const Status bad =
      write_vtu(path_, mesh, std::vector<std::array<Index, 3>>{{5, 6, 8}}, {}, cells);
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.error().message, HasSubstr("triangle 0 refers to node 8, outside [0, 8)"));
}

TEST_F(VtuTest, EmptyMeshIsAValidFile) {
  const VtuDocument doc = parse_vtu(write(TetMesh{}, {}, {}));
  EXPECT_EQ(doc.piece.at("NumberOfPoints"), "0");
  EXPECT_EQ(doc.piece.at("NumberOfCells"), "0");
  EXPECT_EQ(doc.arrays.size(), 5u);  // node_id, Points, connectivity, offsets, types
}

TEST_F(VtuTest, FieldErrors) {
  const TetMesh mesh = test::two_tets_sharing_face();
  VtuField good{"f", 1, std::vector<double>(5, 1.0)};
  VtuField short_field{"short", 1, std::vector<double>(4, 1.0)};
  EXPECT_EQ(write_error(mesh, {short_field}, {}).message,
            path_.string() + ": point field 'short' has 4 values, expected 5 (5 x 1)");
  VtuField vec{"v", 3, std::vector<double>(2, 1.0)};
  EXPECT_THAT(write_error(mesh, {}, {vec}).message,
              HasSubstr("cell field 'v' has 2 values, expected 6 (2 x 3)"));
  VtuField two{"two", 2, std::vector<double>(10, 1.0)};
  EXPECT_THAT(write_error(mesh, {two}, {}).message,
              HasSubstr("has 2 components (expected 1 or 3)"));
  VtuField id_clash{"node_id", 1, std::vector<double>(5, 1.0)};
  EXPECT_THAT(write_error(mesh, {id_clash}, {}).message,
              HasSubstr("point field name 'node_id' used twice"));
  EXPECT_THAT(write_error(mesh, {good, good}, {}).message, HasSubstr("'f' used twice"));
  VtuField unnamed{"", 1, std::vector<double>(5, 1.0)};
  EXPECT_THAT(write_error(mesh, {unnamed}, {}).message, HasSubstr("empty name"));
  VtuField nan_field = good;
  nan_field.values[3] = std::nan("");
  EXPECT_THAT(write_error(mesh, {nan_field}, {}).message,
              HasSubstr("point field 'f' value 3 is not finite"));
  TetMesh bad = mesh;
  bad.tets[1][0] = 5;
  EXPECT_THAT(write_error(bad, {}, {}).message, HasSubstr("tet 1 refers to node 5"));
  bad = mesh;
  bad.node_ids.pop_back();
  EXPECT_EQ(write_error(bad, {}, {}).code, ErrorCode::kInvalidArgument);
  const Status st = write_vtu("/nonexistent-dir/out.vtu", mesh);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kIo);
  // A field's cell count is per tet: cell fields on a mesh with orphans work.
  EXPECT_TRUE(
      write_vtu(path_, read_ok("two_tets_v22.msh"), {}, std::vector<VtuField>{{"c", 1, {1.0, 2.0}}})
          .ok());
}

// ---- Robustness sweep: truncations and corruptions never crash ----------------------

/// Checks a reader's outcome on hostile input: a consistent mesh or an error that
/// names the input.
template <typename Result>
void check_outcome(const Result& result, const std::string& name, int& errors) {
  if (result.has_value()) {
    if constexpr (std::is_same_v<Result, Expected<TetMesh>>) expect_consistent(*result);
  } else {
    ++errors;
    ASSERT_THAT(result.error().message, StartsWith(name)) << result.error().message;
  }
}

/// Random damage: a cut, or a few bytes replaced by characters a parser cares about.
std::string damage(const std::string& data, std::mt19937_64& rng) {
  std::string s = data;
  if (s.empty()) return s;
  std::uniform_int_distribution<std::size_t> where(0, s.size() - 1);
  switch (rng() % 3) {
    case 0:
      s.resize(where(rng));
      break;
    case 1: {
      static const std::string kInteresting = "0123456789 \n\r\t$-+.eE#nanif";
      const std::size_t flips = 1 + rng() % 8;
      for (std::size_t i = 0; i < flips; ++i)
        s[where(rng)] =
            rng() % 2 ? kInteresting[rng() % kInteresting.size()] : static_cast<char>(rng() % 256);
      break;
    }
    default: {
      // Overwrite an aligned 8-byte word with a huge or negative count.
      const std::size_t at = where(rng) & ~std::size_t{7};
      const std::uint64_t values[] = {~0ull, 1ull << 62, 1ull << 31, 0x7fffffffull, 0};
      const std::uint64_t v = values[rng() % 5];
      for (std::size_t i = 0; i < 8 && at + i < s.size(); ++i)
        s[at + i] = static_cast<char>((v >> (8 * i)) & 0xff);
    }
  }
  return s;
}

class Robustness : public ::testing::TestWithParam<const char*> {};

TEST_P(Robustness, DamagedGmshFilesGiveAMeshOrAnError) {
  const std::string data = slurp(mesh_path(GetParam()));
  std::mt19937_64 rng(20240601);
  int errors = 0;
  constexpr int kTrials = 400;
  for (int trial = 0; trial < kTrials; ++trial) {
    const std::string bad = damage(data, rng);
    check_outcome(read_gmsh_buffer(bad, "fuzz.msh"), "fuzz.msh", errors);
    check_outcome(read_gmsh_triangles_buffer(bad, "fuzz.msh"), "fuzz.msh", errors);
    if (HasFatalFailure()) return;
  }
  // Most damage is detected (a flipped digit in a coordinate is not).
  EXPECT_GT(errors, kTrials / 2);
}

INSTANTIATE_TEST_SUITE_P(Files, Robustness,
                         ::testing::Values("box_v22.msh", "box_v41.msh", "box_v41_bin.msh",
                                           "box_order2_v41_bin.msh", "two_tets_v22.msh",
                                           "two_tets_v41.msh", "square_v41_bin.msh"));

TEST(RobustnessTetGen, DamagedTetGenFilesGiveAMeshOrAnError) {
  const std::string node = slurp(mesh_path("tetgen_cubep.1.node"));
  const std::string ele = slurp(mesh_path("tetgen_cubep.1.ele"));
  std::mt19937_64 rng(99);
  int errors = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const bool hit_node = trial % 2 == 0;
    check_outcome(read_tetgen_buffers(hit_node ? damage(node, rng) : node,
                                      hit_node ? ele : damage(ele, rng), "fuzz"),
                  "fuzz", errors);
    if (::testing::Test::HasFatalFailure()) return;
  }
  EXPECT_GT(errors, 100);
}

TEST(RobustnessBinary, EveryWordSetToAHugeCount) {
  // Each aligned 8-byte word of a binary file in turn set to 2^62: no allocation of
  // that size, no read out of bounds (ASan checks), and an error or a mesh.
  const std::string data = slurp(mesh_path("box_order2_v41_bin.msh"));
  int errors = 0;
  for (std::size_t at = 0; at + 8 <= data.size(); at += 4) {
    std::string bad = data;
    const std::uint64_t v = 1ull << 62;
    std::memcpy(bad.data() + at, &v, 8);
    check_outcome(read_gmsh_buffer(bad, "fuzz.msh"), "fuzz.msh", errors);
    if (::testing::Test::HasFatalFailure()) return;
  }
  EXPECT_GT(errors, 100);
}

}  // namespace
}  // namespace tc
