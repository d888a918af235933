// 2D disc of radius 1.0 m centred at the origin, in the plane z = 0 (paper Fig. 8/9:
// "the disc object of 486 nodes"). Linear triangles (Gmsh element type 2).
// Mesh size h (m) tuned so the mesh has 486 nodes: -setnumber h 0.0875
SetFactory("OpenCASCADE");
Include "common_options.geo";
If (!Exists(h)) h = 0.0875; EndIf
Disk(1) = {0, 0, 0, 1.0};
Mesh.MeshSizeMin = h;
Mesh.MeshSizeMax = h;
Physical Surface("body", 1) = {1};
bnd() = Boundary{ Surface{1}; };
Physical Curve("boundary", 2) = bnd();
