// Small ellipsoid, semi-axes 0.05 x 0.03 x 0.03 m, centred at the origin (paper Fig. 15).
// Target: about 100 linear tets. Mesh size h (m): -setnumber h 0.025
SetFactory("OpenCASCADE");
Include "common_options.geo";
If (!Exists(h)) h = 0.025; EndIf
Sphere(1) = {0, 0, 0, 1.0};
Dilate {{0, 0, 0}, {0.05, 0.03, 0.03}} { Volume{1}; }
Mesh.MeshSizeMin = h;
Mesh.MeshSizeMax = h;
Physical Volume("body", 1) = {1};
bnd() = Boundary{ Volume{1}; };
Physical Surface("boundary", 2) = bnd();
