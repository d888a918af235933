// 2D rectangle 2.0 x 1.0 m centred at the origin, in the plane z = 0 (paper Fig. 10:
// "a rectangular object of 1000 nodes"). Linear triangles (Gmsh element type 2).
// Mesh size h (m) tuned so the mesh has about 1,000 nodes: -setnumber h 0.05
SetFactory("OpenCASCADE");
Include "common_options.geo";
If (!Exists(h)) h = 0.05; EndIf
Rectangle(1) = {-1.0, -0.5, 0, 2.0, 1.0};
Mesh.MeshSizeMin = h;
Mesh.MeshSizeMax = h;
Physical Surface("body", 1) = {1};
bnd() = Boundary{ Surface{1}; };
Physical Curve("boundary", 2) = bnd();
