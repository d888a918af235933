// service/core/io/surface_io: STL (ASCII, binary), OBJ and Gmsh surface readers. Files
// are written here from a known surface, read back and compared; hostile variants must
// give an error naming the file and the line or byte, never a crash.
#include "core/io/surface_io.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "test_meshes.hpp"

namespace tc {
namespace {

using Eigen::Vector3d;

/// ASCII STL of a surface, one facet per triangle, every corner written out.
std::string ascii_stl(const SurfaceMesh& m, const char* solid = "solid cube",
                      const char* newline = "\n") {
  std::ostringstream out;
  out.precision(17);
  out << solid << newline;
  for (const Triangle& t : m.triangles) {
    out << "  facet normal 0 0 0" << newline << "    outer loop" << newline;
    for (const Index v : t)
      out << "      vertex " << m.positions(0, v) << ' ' << m.positions(1, v) << ' '
          << m.positions(2, v) << newline;
    out << "    endloop" << newline << "  endfacet" << newline;
  }
  out << "endsolid cube" << newline;
  return out.str();
}

void put_u32(std::string& s, std::uint32_t v) {
  char b[4];
  std::memcpy(b, &v, 4);
  s.append(b, 4);
}
void put_f32(std::string& s, float v) {
  char b[4];
  std::memcpy(b, &v, 4);
  s.append(b, 4);
}

/// Binary STL of a surface; the 80-byte header starts with `header` (a binary file may
/// begin with "solid").
std::string binary_stl(const SurfaceMesh& m, const std::string& header = "solid binary") {
  std::string s = header;
  s.resize(80, ' ');
  put_u32(s, static_cast<std::uint32_t>(m.triangles.size()));
  for (const Triangle& t : m.triangles) {
    for (int k = 0; k < 3; ++k) put_f32(s, 0.0f);
    for (const Index v : t)
      for (int k = 0; k < 3; ++k) put_f32(s, static_cast<float>(m.positions(k, v)));
    s.append(2, '\0');
  }
  return s;
}

/// Expects the same triangles over the same points (node numbering may differ).
void expect_same_surface(const SurfaceMesh& got, const SurfaceMesh& want) {
  ASSERT_EQ(got.triangles.size(), want.triangles.size());
  for (std::size_t t = 0; t < got.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(got.positions.col(got.triangles[t][k]), want.positions.col(want.triangles[t][k]))
          << "triangle " << t << " corner " << k;
}

std::string error_of(const Expected<SurfaceMesh>& r) {
  EXPECT_FALSE(r.has_value());
  return r.has_value() ? std::string() : r.error().message;
}

// ---------------------------------------------------------------------------- STL

TEST(ReadStl, AsciiCubeMergesItsCornersInOrderOfFirstAppearance) {
  const SurfaceMesh cube = test::cube_surface(0.5, Vector3d(1, 2, 3));
  for (const char* newline : {"\n", "\r\n"}) {
    auto m = read_stl_buffer(ascii_stl(cube, "solid cube", newline), "cube.stl");
    ASSERT_TRUE(m.has_value()) << m.error().message;
    EXPECT_EQ(m->num_nodes(), 8);  // 36 corners, 8 points
    expect_same_surface(*m, cube);
    // Node 0 is the first corner of the file, node 1 the next new point, ...
    EXPECT_EQ(m->positions.col(0), cube.positions.col(cube.triangles[0][0]));
    EXPECT_EQ(m->triangles[0], (Triangle{0, 1, 2}));
    EXPECT_EQ(m->node_ids, (std::vector<std::int64_t>{1, 2, 3, 4, 5, 6, 7, 8}));
    const SurfaceStats s =
        compute_surface_stats(*m, build_surface_edges(m->triangles), validate_surface(*m));
    EXPECT_TRUE(s.closed);
    EXPECT_TRUE(s.outward);
  }
}

TEST(ReadStl, BinaryBeginningWithSolidIsBinaryAndEqualsTheAscii) {
  const SurfaceMesh cube = test::cube_surface(0.25, Vector3d(-1, 0.5, 7));  // float-exact
  auto a = read_stl_buffer(ascii_stl(cube), "a.stl");
  for (const std::string header : {"solid binary", "binary", ""}) {
    auto b = read_stl_buffer(binary_stl(cube, header), "b.stl");
    ASSERT_TRUE(b.has_value()) << header << ": " << b.error().message;
    EXPECT_EQ(b->positions, a->positions);
    EXPECT_EQ(b->triangles, a->triangles);
  }
}

TEST(ReadStl, MergesBitIdenticalCornersOnlyAndSignedZerosAsOne) {
  SurfaceMesh m;
  m.positions.resize(3, 6);
  const double next = std::nextafter(1.0f, 2.0f);  // one float ulp above 1
  m.positions << 0, 1, 0, -0.0, 1, 0,              //
      0, 0, 1, 0, 0, 1,                            //
      0, 0, 0, -0.0, next, 1;
  m.triangles = {{0, 1, 2}, {3, 4, 5}};
  auto r = read_stl_buffer(binary_stl(m), "z.stl");
  ASSERT_TRUE(r.has_value()) << r.error().message;
  // (0,0,0) and (-0,0,-0) merge; (1,0,0) and (1,0,1+ulp) do not; (0,1,0), (0,1,1) differ.
  EXPECT_EQ(r->num_nodes(), 5);
  EXPECT_EQ(r->triangles[1][0], 0);
}

TEST(ReadStl, AsciiKeywordsAnyCaseAndSeveralSolids) {
  const SurfaceMesh cube = test::cube_surface();
  std::string text = ascii_stl(cube);
  std::string upper = text;
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  auto u = read_stl_buffer(upper, "u.stl");
  ASSERT_TRUE(u.has_value()) << u.error().message;
  EXPECT_EQ(u->num_triangles(), 12);
  auto two = read_stl_buffer(text + "\n" + text, "two.stl");
  ASSERT_TRUE(two.has_value()) << two.error().message;
  EXPECT_EQ(two->num_triangles(), 24);
  EXPECT_EQ(two->num_nodes(), 8);
}

TEST(ReadStl, HostileAsciiNamesTheLine) {
  const SurfaceMesh cube = test::cube_surface();
  const std::string good = ascii_stl(cube);
  // Line 1 solid, then 7 lines per facet: facet, outer loop, 3 vertex, endloop, endfacet.
  const auto replace_line = [&](int line, const std::string& with) {
    std::istringstream in(good);
    std::string out, l;
    for (int i = 1; std::getline(in, l); ++i) out += (i == line ? with : l) + "\n";
    return out;
  };
  EXPECT_EQ(error_of(read_stl_buffer(replace_line(4, "vertex 1 2"), "c.stl")),
            "c.stl:4: expected 'vertex x y z', got 'vertex 1 2'");
  EXPECT_EQ(error_of(read_stl_buffer(replace_line(5, "vertex 1 2 x"), "c.stl")),
            "c.stl:5: expected 'vertex x y z', got 'vertex 1 2 x'");
  EXPECT_EQ(error_of(read_stl_buffer(replace_line(6, "endloop"), "c.stl")),
            "c.stl:6: expected 'vertex x y z' (a facet has 3 vertices), got 'endloop'");
  EXPECT_EQ(error_of(read_stl_buffer(replace_line(7, "vertex 0 0 0"), "c.stl")),
            "c.stl:7: expected 'endloop', got 'vertex 0 0 0'");
  EXPECT_EQ(error_of(read_stl_buffer(replace_line(9, "facet"), "c.stl")),
            "c.stl:9: expected 'facet normal nx ny nz'");
  EXPECT_EQ(error_of(read_stl_buffer(replace_line(11, "vertex nan 0 0"), "c.stl")),
            "c.stl:11: vertex has a non-finite coordinate");
  EXPECT_EQ(error_of(read_stl_buffer(replace_line(12, "vertex 1e999 0 0"), "c.stl")),
            "c.stl:12: vertex has a non-finite coordinate");
  EXPECT_EQ(error_of(read_stl_buffer(replace_line(16, "face"), "c.stl")),
            "c.stl:16: expected 'facet normal nx ny nz' or 'endsolid', got 'face'");
  // Truncated: no endsolid.
  const std::string cut = good.substr(0, good.rfind("endsolid"));
  EXPECT_EQ(error_of(read_stl_buffer(cut, "c.stl")),
            "c.stl:86: unexpected end of file, expected 'facet normal nx ny nz' or 'endsolid'");
  EXPECT_EQ(error_of(read_stl_buffer("solid x\nendsolid x\n", "e.stl")),
            "e.stl:2: no facets: an empty surface");
  EXPECT_EQ(error_of(read_stl_buffer("solid x\nendsolid x\nfacet\n", "e.stl")),
            "e.stl:3: expected 'solid' or the end of the file after 'endsolid', got 'facet'");
}

TEST(ReadStl, HostileBinaryNamesTheByte) {
  const SurfaceMesh cube = test::cube_surface();
  std::string bin = binary_stl(cube, "binary");
  EXPECT_EQ(error_of(read_stl_buffer(bin.substr(0, bin.size() - 1), "b.stl")),
            "b.stl: byte 80: binary STL header announces 12 triangles (684 bytes), the file "
            "has 683");
  std::string nan = bin;
  const float q = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(nan.data() + 84 + 50 * 3 + 12 + 4 * 4, &q, 4);  // triangle 4, vertex 2, y
  EXPECT_EQ(error_of(read_stl_buffer(nan, "b.stl")),
            "b.stl: byte 262: vertex 2 of triangle 4 has a non-finite coordinate");
  std::string huge = bin;
  const std::uint32_t many = 0xffffffffu;
  std::memcpy(huge.data() + 80, &many, 4);
  EXPECT_EQ(error_of(read_stl_buffer(huge, "b.stl")),
            "b.stl: byte 80: binary STL header announces 4294967295 triangles (214748364834 "
            "bytes), the file has 684");
  EXPECT_EQ(error_of(read_stl_buffer(bin.substr(0, 84), "b.stl")),
            "b.stl: byte 80: binary STL header announces 12 triangles (684 bytes), the file "
            "has 84");
  std::string empty = bin.substr(0, 80);
  put_u32(empty, 0);
  EXPECT_EQ(error_of(read_stl_buffer(empty, "b.stl")),
            "b.stl: byte 80: the binary STL header announces 0 triangles: an empty surface");
  EXPECT_EQ(error_of(read_stl_buffer("abc", "s.stl")),
            "s.stl: byte 3: unexpected end of file: shorter than the 84-byte binary STL header, "
            "and not ASCII STL (no 'solid')");
  EXPECT_EQ(error_of(read_stl_buffer("", "s.stl")), "s.stl: empty file, expected an STL");
  // A "solid" header whose size does not fit the count is read as ASCII, fails there, and
  // the message says why it was not read as binary.
  std::string solid = binary_stl(cube, "solid x");
  solid.pop_back();
  const std::string message = error_of(read_stl_buffer(solid, "b.stl"));
  EXPECT_EQ(message.rfind("b.stl:", 0), 0u) << message;
  EXPECT_NE(message.find("(read as ASCII STL: it begins with 'solid' and its size 683 is not the "
                         "binary 84 + 50 x 12 = 684)"),
            std::string::npos)
      << message;
}

TEST(ReadStl, EveryTruncationIsAnErrorOrASurfaceNeverACrash) {
  const SurfaceMesh cube = test::cube_surface();
  for (const std::string& full : {ascii_stl(cube), binary_stl(cube, "solid")}) {
    for (std::size_t n = 0; n < full.size(); ++n) {
      const auto r = read_stl_buffer(std::string_view(full).substr(0, n), "t.stl");
      if (r.has_value()) {
        EXPECT_GT(r->num_triangles(), 0);
        EXPECT_EQ(validate_surface(*r).index_out_of_range.count, 0u);
      } else {
        EXPECT_EQ(r.error().message.rfind("t.stl", 0), 0u) << r.error().message;
      }
    }
  }
}

// ---------------------------------------------------------------------------- OBJ

TEST(ReadObj, CornerFormsNegativeIndicesPolygonsAndIgnoredStatements) {
  const std::string text =
      "# a unit cube\n"
      "mtllib cube.mtl\n"
      "o cube\n"
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
      "v 0 0 1 1.0\nv 1 0 1 0.5 0.5 0.5\nv 0 1 1\nv 1 1 1  # trailing comment\n"
      "vt 0 0\nvn 0 0 1\ng side\ns off\nusemtl steel\nl 1 2\n"
      "f 1 3 4 2\n"            // quad -> 2 triangles
      "f 5/1 6/1 8/1 7/1\n"    // v/vt
      "f 1//1 2//1 6//1\n"     // v//vn
      "f 1/1/1 6/1/1 5/1/1\n"  // v/vt/vn
      "f -6 -2 -1 -5\n"        // 3 7 8 4, relative to the 8 vertices read
      "f 1 5 7 3\n"
      "f 2 4 8 6\n";
  auto m = read_obj_buffer(text, "cube.obj");
  ASSERT_TRUE(m.has_value()) << m.error().message;
  EXPECT_EQ(m->num_nodes(), 8);
  EXPECT_EQ(m->node_ids, (std::vector<std::int64_t>{1, 2, 3, 4, 5, 6, 7, 8}));
  ASSERT_EQ(m->num_triangles(), 12);
  EXPECT_EQ(m->triangles[0], (Triangle{0, 2, 3}));
  EXPECT_EQ(m->triangles[1], (Triangle{0, 3, 1}));
  EXPECT_EQ(m->triangles[6], (Triangle{2, 6, 7}));
  EXPECT_EQ(m->triangles[7], (Triangle{2, 7, 3}));
  EXPECT_EQ(m->positions.col(5), Vector3d(1, 0, 1));
  const SurfaceStats s =
      compute_surface_stats(*m, build_surface_edges(m->triangles), validate_surface(*m));
  EXPECT_TRUE(s.closed);
  EXPECT_TRUE(s.oriented);
  EXPECT_TRUE(s.outward);
  EXPECT_NEAR(s.enclosed_volume, 1.0, 1e-15);
}

TEST(ReadObj, FacesMayReferToVerticesDefinedLater) {
  auto m = read_obj_buffer("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", "late.obj");
  ASSERT_TRUE(m.has_value()) << m.error().message;
  EXPECT_EQ(m->positions.col(1), Vector3d(1, 0, 0));
}

TEST(ReadObj, HostileLinesAreNamed) {
  const std::string v = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  const auto err = [&](const std::string& tail) {
    return error_of(read_obj_buffer(v + tail, "o.obj"));
  };
  EXPECT_EQ(err("f 1 2 4\n"), "o.obj:4: face corner '4' refers to vertex 4, but the file has 3");
  EXPECT_EQ(err("f 0 1 2\n"),
            "o.obj:4: expected a vertex index (1-based, or negative) in face corner '0'");
  EXPECT_EQ(err("f -1 -2 -4\n"),
            "o.obj:4: face corner '-4' refers to vertex -4, but only 3 vertices precede it");
  EXPECT_EQ(err("f 1 2\n"), "o.obj:4: a face needs at least 3 vertices, got 2");
  EXPECT_EQ(err("f 1/2/3/4 2 3\n"), "o.obj:4: bad face corner '1/2/3/4'");
  EXPECT_EQ(err("f 1/x 2 3\n"), "o.obj:4: expected 'v', 'v/vt', 'v//vn' or 'v/vt/vn', got '1/x'");
  EXPECT_EQ(err("f 1/ 2 3\n"), "o.obj:4: expected 'v', 'v/vt', 'v//vn' or 'v/vt/vn', got '1/'");
  EXPECT_EQ(err("f 1//  2 3\n"), "o.obj:4: expected 'v', 'v/vt', 'v//vn' or 'v/vt/vn', got '1//'");
  EXPECT_EQ(err("f a 2 3\n"),
            "o.obj:4: expected a vertex index (1-based, or negative) in face corner 'a'");
  EXPECT_EQ(err("v 1 2\nf 1 2 3\n"),
            "o.obj:4: expected 'v x y z [w]' or 'v x y z r g b', got 'v 1 2'");
  EXPECT_EQ(err("v 1 2 3 4 5\nf 1 2 3\n"),
            "o.obj:4: expected 'v x y z [w]' or 'v x y z r g b', got 'v 1 2 3 4 5'");
  EXPECT_EQ(err("v 1 nan 3\nf 1 2 3\n"), "o.obj:4: vertex 4 has a non-finite coordinate");
  EXPECT_EQ(err("vt 0 0\n"), "o.obj: no faces ('f' lines): an empty surface");
  EXPECT_EQ(error_of(read_obj_buffer("", "o.obj")),
            "o.obj: no faces ('f' lines): an empty surface");
}

TEST(ReadObj, EveryTruncationIsAnErrorOrASurfaceNeverACrash) {
  const std::string full =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1/1/1 2/2/2 4/4/4 3//3\nf -1 -2 -3\n";
  for (std::size_t n = 0; n < full.size(); ++n) {
    const auto r = read_obj_buffer(std::string_view(full).substr(0, n), "t.obj");
    if (r.has_value()) {
      EXPECT_EQ(validate_surface(*r).index_out_of_range.count, 0u);
    } else {
      EXPECT_EQ(r.error().message.rfind("t.obj", 0), 0u) << r.error().message;
    }
  }
}

// ---------------------------------------------------------------------------- Gmsh

TEST(ReadGmshSurface, TrianglesWithoutTetsInEveryFormat) {
  for (const char* file : {"square_v22.msh", "square_v41.msh", "square_v41_bin.msh"}) {
    auto m = read_gmsh_surface(test::data_path(std::string("meshes/") + file));
    ASSERT_TRUE(m.has_value()) << m.error().message;
    EXPECT_EQ(m->num_nodes(), 20) << file;
    EXPECT_EQ(m->num_triangles(), 26) << file;
    const SurfaceStats s =
        compute_surface_stats(*m, build_surface_edges(m->triangles), validate_surface(*m));
    EXPECT_FALSE(s.closed);
    EXPECT_NEAR(s.area, 1.0, 1e-12) << file;  // the unit square (square.geo)
    EXPECT_EQ(s.bbox_lo.z(), 0.0);
    EXPECT_EQ(s.bbox_hi.z(), 0.0);
  }
}

TEST(ReadGmshSurface, TetMeshesAndFilesWithoutTrianglesAreRefused) {
  auto tets = read_gmsh_surface(test::data_path("meshes/box_v41.msh"));
  ASSERT_FALSE(tets.has_value());
  EXPECT_EQ(tets.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(tets.error().message.find("box_v41.msh: holds 100 tetrahedra: a tet mesh"),
            std::string::npos)
      << tets.error().message;
  auto none = read_gmsh_surface(test::data_path("meshes/box_order2_v41_bin.msh"));
  ASSERT_FALSE(none.has_value());
  EXPECT_NE(none.error().message.find("no 3-node triangles"), std::string::npos)
      << none.error().message;
  // Parse errors are the tet reader's, with its file and line.
  auto broken = read_gmsh_surface(test::data_path("meshes/broken_nan.msh"));
  ASSERT_FALSE(broken.has_value());
  EXPECT_NE(broken.error().message.find("broken_nan.msh:8: node tag 3 has a non-finite"),
            std::string::npos)
      << broken.error().message;
}

// ---------------------------------------------------------------------------- dispatch

TEST(ReadSurface, DispatchesByExtension) {
  const auto dir =
      std::filesystem::temp_directory_path() /
      ("tc_surface_io_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  std::filesystem::create_directories(dir);
  const SurfaceMesh cube = test::cube_surface();
  {
    std::ofstream(dir / "c.STL", std::ios::binary) << binary_stl(cube);
    std::ofstream(dir / "c.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    std::ofstream(dir / "c.ply") << "ply\n";
  }
  auto stl = read_surface(dir / "c.STL");
  ASSERT_TRUE(stl.has_value()) << stl.error().message;
  EXPECT_EQ(stl->num_triangles(), 12);
  auto obj = read_surface(dir / "c.obj");
  ASSERT_TRUE(obj.has_value()) << obj.error().message;
  EXPECT_EQ(obj->num_triangles(), 1);
  auto msh = read_surface(test::data_path("meshes/square_v41.msh"));
  ASSERT_TRUE(msh.has_value()) << msh.error().message;
  auto ply = read_surface(dir / "c.ply");
  ASSERT_FALSE(ply.has_value());
  EXPECT_EQ(ply.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(ply.error().message.find("unknown surface file extension '.ply' (expected .stl, "
                                     ".obj or .msh)"),
            std::string::npos);
  auto missing = read_surface(dir / "missing.stl");
  ASSERT_FALSE(missing.has_value());
  EXPECT_EQ(missing.error().code, ErrorCode::kIo);
  EXPECT_TRUE(is_surface_extension("a.Obj"));
  EXPECT_FALSE(is_surface_extension("a.msh"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace tc
