// Ball of radius 0.2 m centred at the origin (the falling sphere of paper Fig. 14).
// Target: 3,000-8,000 linear tets. Mesh size h (m): -setnumber h 0.04
SetFactory("OpenCASCADE");
Include "common_options.geo";
If (!Exists(h)) h = 0.04; EndIf
Sphere(1) = {0, 0, 0, 0.2};
Mesh.MeshSizeMin = h;
Mesh.MeshSizeMax = h;
Physical Volume("body", 1) = {1};
bnd() = Boundary{ Volume{1}; };
Physical Surface("boundary", 2) = bnd();
