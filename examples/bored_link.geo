// A bored link (the built-in example of `stiffkit link` with CAD faces):
// a 16 mm thick web between a bearing boss (bore 16 mm at x = 20) and a
// pin boss (pin hole 8 mm at x = 140), both bores along z. Gmsh script,
// OpenCASCADE kernel; the bearing bore is the physical group "bearing_bore".
SetFactory("OpenCASCADE");
Box(1) = {20, -10, -8, 120, 20, 16};
Cylinder(2) = {20, 0, -8, 0, 0, 16, 16};
Cylinder(3) = {140, 0, -8, 0, 0, 16, 10};
BooleanUnion(4) = { Volume{1}; Delete; }{ Volume{2, 3}; Delete; };
Cylinder(5) = {20, 0, -9, 0, 0, 18, 8};
Cylinder(6) = {140, 0, -9, 0, 0, 18, 4};
BooleanDifference(7) = { Volume{4}; Delete; }{ Volume{5, 6}; Delete; };
bore[] = Surface In BoundingBox{11.9, -8.1, -8.1, 28.1, 8.1, 8.1};
Physical Surface("bearing_bore") = {bore[]};
