// Small meshes built in code for the unit tests (no files needed).
#pragma once

#include <filesystem>
#include <string>

#include "core/mesh/tet_mesh.hpp"

namespace tc::test {

/// The unit tet (0,0,0), (1,0,0), (0,1,0), (0,0,1), positively oriented.
TetMesh single_tet();

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

/// Path of a file in tests/data (from the TC_TEST_DATA environment variable, set by
/// CTest, else the source tree path compiled in).
std::filesystem::path data_path(const std::string& name);

/// Path of a mesh in the repository's data/meshes folder (torus.msh, ball.msh, ...).
std::filesystem::path mesh_path(const std::string& name);

}  // namespace tc::test
