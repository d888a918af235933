// Torus, major radius 0.3 m, minor radius 0.1 m, centred at the origin, axis z.
// Paper Fig. 13 ("a torus (7000 tetrahedrons) breaks on a cube").
// Target: about 7,000 linear tets. Mesh size h (m) can be overridden: -setnumber h 0.03
SetFactory("OpenCASCADE");
Include "common_options.geo";
If (!Exists(h)) h = 0.035; EndIf
Torus(1) = {0, 0, 0, 0.3, 0.1};
Mesh.MeshSizeMin = h;
Mesh.MeshSizeMax = h;
Physical Volume("body", 1) = {1};
bnd() = Boundary{ Volume{1}; };
Physical Surface("boundary", 2) = bnd();
