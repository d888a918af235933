// Chess pawn (a revolved solid, one of the paper's Fig. 7 "large objects": horse, pawn,
// ...), made of OpenCASCADE primitives fused into one volume; axis z, base at z = 0,
// height 0.36 m. Used by make_large.sh for the ~300,000-tet benchmark object.
// Mesh size h (m): -setnumber h 0.0062
SetFactory("OpenCASCADE");
Include "common_options.geo";
If (!Exists(h)) h = 0.0062; EndIf
Cylinder(1) = {0, 0, 0, 0, 0, 0.03, 0.12};              // base plate
Torus(2) = {0, 0, 0.03, 0.095, 0.02};                     // rounded foot ring
Cone(3) = {0, 0, 0.03, 0, 0, 0.2, 0.1, 0.035};            // body
Cylinder(4) = {0, 0, 0.22, 0, 0, 0.02, 0.065};            // collar
Sphere(5) = {0, 0, 0.30, 0.065};                          // head
BooleanUnion(10) = { Volume{1}; Delete; }{ Volume{2, 3, 4, 5}; Delete; };
Mesh.MeshSizeMin = h;
Mesh.MeshSizeMax = h;
Physical Volume("body", 1) = {10};
bnd() = Boundary{ Volume{10}; };
Physical Surface("boundary", 2) = bnd();
