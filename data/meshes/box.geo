// Box 1.0 x 1.0 x 0.3 m centred at the origin (the "cube" of paper Fig. 13, a floor).
// Target: 2,000-5,000 linear tets. Mesh size h (m): -setnumber h 0.1
SetFactory("OpenCASCADE");
Include "common_options.geo";
If (!Exists(h)) h = 0.1; EndIf
Box(1) = {-0.5, -0.5, -0.15, 1.0, 1.0, 0.3};
Mesh.MeshSizeMin = h;
Mesh.MeshSizeMax = h;
Physical Volume("body", 1) = {1};
bnd() = Boundary{ Volume{1}; };
Physical Surface("boundary", 2) = bnd();
