// Cylinder radius 0.05 m, height 0.15 m, axis z from z = 0, made with Gmsh's built-in
// kernel (not OpenCASCADE) and meshed with the HXT 3D algorithm (not Delaunay), with no
// physical groups, so Gmsh saves every element: points (type 15), lines (type 1),
// triangles (type 2) and tets (type 4). Different on purpose from data/meshes/.
// Made with: gmsh cylinder_hxt.geo -3 -nt 1 -format msh41 -o cylinder_hxt.msh
General.NumThreads = 1;
Mesh.RandomSeed = 1;
Mesh.Algorithm = 5;      // 2D: Delaunay
Mesh.Algorithm3D = 10;   // 3D: HXT
Mesh.MeshSizeMin = 0.02;
Mesh.MeshSizeMax = 0.02;
r = 0.05;
Point(1) = {0, 0, 0};
Point(2) = {r, 0, 0};
Point(3) = {0, r, 0};
Point(4) = {-r, 0, 0};
Point(5) = {0, -r, 0};
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Circle(3) = {4, 1, 5};
Circle(4) = {5, 1, 2};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Extrude {0, 0, 0.15} { Surface{1}; }
