// Options shared by every tetcollide mesh (included by each .geo file).
// They pin down everything that could make two runs differ: one thread, a fixed random
// seed, fixed 2D/3D algorithms, and the output format (Gmsh 4.1 ASCII).
General.NumThreads = 1;
Mesh.RandomSeed = 1;
Mesh.Algorithm = 6;              // 2D: Frontal-Delaunay
Mesh.Algorithm3D = 1;            // 3D: Delaunay
Mesh.Optimize = 1;               // tetgen-style optimisation of poor tets
Mesh.OptimizeNetgen = 0;
Mesh.ElementOrder = 1;
Mesh.MeshSizeFromCurvature = 0;
Mesh.MeshSizeExtendFromBoundary = 1;
Mesh.MshFileVersion = 4.1;
Mesh.Binary = 0;
Mesh.SaveAll = 0;                // save only elements in physical groups
