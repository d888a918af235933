// Thin tissue slab 1.0 x 1.0 x 0.02 m centred at the origin (paper Fig. 14: a sphere
// falls on a tissue that breaks). Structured through the thickness: an unstructured
// triangle mesh of the bottom face is extruded in `layers` layers (default 2); each
// prism is split into 3 tets, so the slab has exactly `layers` tet layers.
// Mesh size h (m) of the triangles: -setnumber h 0.05 ; layers: -setnumber layers 2
SetFactory("OpenCASCADE");
Include "common_options.geo";
If (!Exists(h)) h = 0.05; EndIf
If (!Exists(layers)) layers = 2; EndIf
Rectangle(1) = {-0.5, -0.5, -0.01, 1.0, 1.0};
Mesh.MeshSizeMin = h;
Mesh.MeshSizeMax = h;
ext[] = Extrude {0, 0, 0.02} { Surface{1}; Layers{layers}; };
// ext[0] = top surface, ext[1] = volume, ext[2..] = lateral surfaces
Physical Volume("body", 1) = {ext[1]};
bnd() = Boundary{ Volume{ext[1]}; };
Physical Surface("boundary", 2) = bnd();
