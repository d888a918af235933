// Small meshes built in code for the unit tests (no files needed).
#pragma once

#include <filesystem>
#include <string>

#include "core/io/mesh_io.hpp"
#include "core/mesh/surface_mesh.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"

namespace tc::test {

/// A mesh from points and tets as given (no reorientation: tests control the order);
/// node ids 1..n.
TetMesh mesh_from(const std::vector<Eigen::Vector3d>& points, std::vector<Tet> tets);

/// The squared distance from `p` to the nearest boundary face of `topology` (of mesh
/// `m`), face by face: the brute-force reference of the BVHs and distance tests.
double brute_force_sq_distance_to_boundary(const TetMesh& m, const Topology& topology,
                                           const Eigen::Vector3d& p);

/// The unit tet (0,0,0), (1,0,0), (0,1,0), (0,0,1), positively oriented.
TetMesh single_tet();

/// The regular tet on alternate corners of [-1, 1]^3 (edge 2 sqrt(2)), positively oriented.
TetMesh regular_tet();

/// Two tets sharing the face (1,2,3).
TetMesh two_tets_sharing_face();

/// The cube [0, s]^3 split into 5 tets (one central, four corners).
TetMesh cube_five_tets(double s = 1.0);

/// The cube [0, s]^3 split into 6 tets around the main diagonal.
TetMesh cube_six_tets(double s = 1.0);

/// A structured box of nx * ny * nz cubes, each split into 6 tets (conforming), over
/// [lo, hi]. Node ids are 1-based in x-fastest order.
TetMesh structured_box(int nx, int ny, int nz, const Eigen::Vector3d& lo,
                       const Eigen::Vector3d& hi);

/// A ball of radius r centred at the origin: structured_box(n, n, n) over [-1, 1]^3
/// mapped onto the ball by the smooth cube-to-ball map x sqrt(1 - y^2/2 - z^2/2 +
/// y^2 z^2/3) (and cyclic), scaled by r. The boundary is a triangulated sphere whose
/// vertices lie on the sphere; 6 n^3 tets.
TetMesh ball_mesh(int n, double r);

/// A torus of tube radius a around the z axis at distance big_r from it: ring_cells
/// cells around, tube_cells x tube_cells cells in the cross-section (a square mapped
/// onto the disc of radius a). Boundary vertices lie on the torus; 6 * ring_cells *
/// tube_cells^2 tets.
TetMesh torus_mesh(int ring_cells, int tube_cells, double big_r, double a);

/// A 2D disc of radius r: the square [-1, 1]^2 in n x n cells, two triangles each,
/// mapped onto the disc by (x sqrt(1 - y^2/2), y sqrt(1 - x^2/2)) and scaled by r.
TriMesh2 disc_mesh_2d(int n, double r);

/// The rectangle [0, w] x [0, h] in nx x ny cells, two triangles each.
TriMesh2 rect_mesh_2d(int nx, int ny, double w, double h);

/// The cube [0, s]^3 + o as a closed surface: 8 nodes (node i at o + s (i&1, i>>1&1,
/// i>>2&1)), 12 triangles with outward right-hand normals.
SurfaceMesh cube_surface(double s = 1.0, const Eigen::Vector3d& o = Eigen::Vector3d::Zero());

/// The square [0, w]^2 at height z in n x n cells, two triangles each, normals +z (an open
/// surface); node (i, j) is j (n + 1) + i.
SurfaceMesh square_surface(int n = 1, double w = 1.0, double z = 0.0);

/// The boundary of a tet mesh as a surface: every node of the mesh (interior ones unused),
/// the boundary faces as triangles (outward normals for positive tets).
SurfaceMesh boundary_surface_of(const TetMesh& mesh);

/// Path of a file in tests/data (from the TC_TEST_DATA environment variable, set by
/// CTest, else the source tree path compiled in).
std::filesystem::path data_path(const std::string& name);

/// Path of a mesh in the repository's data/meshes folder (torus.msh, ball.msh, ...).
std::filesystem::path mesh_path(const std::string& name);

}  // namespace tc::test
