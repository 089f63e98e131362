// Interference fit: a steel hub shrunk onto a solid steel shaft, axisymmetric (x = r, y = the axis) [mm].
// Shaft 0 <= r <= 10.01, -15 <= y <= 45; hub 10 <= r <= 20, 0 <= y <= 30: the 0.01 mm radial interference is
// the overlap of the two meshes (the shaft's surface lies 0.01 mm inside the hub's bore).
// Shaft and hub are separate surfaces with their own nodes; the bore and the shaft surface under it carry the
// same number of nodes per 10 mm section, so each bore node faces a shaft node at the same y (node-to-node).
// Element size h (1 mm here; hub_fine.geo sets 0.5 before including this file), h / 2 on the interface;
// quadratic triangles.
If (!Exists(h))
  h = 1.0;
EndIf
a = 10.0; b = 20.0; delta = 0.01; L = 30.0; y0 = -15.0; y1 = 45.0;
n = Round(10.0 / (h / 2)) + 1;           // nodes per 10 mm section of the interface

// shaft
Point(1) = {0, y0, 0, h};        Point(2) = {a + delta, y0, 0, h};
Point(3) = {a + delta, 0, 0, h / 2};      Point(4) = {a + delta, 10, 0, h / 2};
Point(5) = {a + delta, 20, 0, h / 2};     Point(6) = {a + delta, L, 0, h / 2};
Point(7) = {a + delta, y1, 0, h};  Point(8) = {0, y1, 0, h};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 5}; Line(5) = {5, 6};
Line(6) = {6, 7}; Line(7) = {7, 8}; Line(8) = {8, 1};
Curve Loop(1) = {1, 2, 3, 4, 5, 6, 7, 8};
Plane Surface(1) = {1};

// hub
Point(11) = {a, 0, 0, h / 2};    Point(12) = {b, 0, 0, h};
Point(13) = {b, L, 0, h};        Point(14) = {a, L, 0, h / 2};
Point(15) = {a, 20, 0, h / 2};   Point(16) = {a, 10, 0, h / 2};
Line(11) = {11, 12}; Line(12) = {12, 13}; Line(13) = {13, 14}; Line(14) = {14, 15}; Line(15) = {15, 16};
Line(16) = {16, 11};
Curve Loop(2) = {11, 12, 13, 14, 15, 16};
Plane Surface(2) = {2};

Transfinite Curve{3, 4, 5, 14, 15, 16} = n;

Physical Surface("shaft") = {1};
Physical Surface("hub") = {2};
Physical Curve("shaft_bottom") = {1};
Physical Curve("shaft_surface") = {3, 4, 5};   // the target: the shaft under the hub
Physical Curve("hub_top") = {13};              // pushed down the shaft
Physical Curve("bore") = {14, 15, 16};         // the whole bore, for zone rules
Physical Curve("Z1") = {16};                   // 0 <= y <= 10, the hub's lower end (the free end face y = 0)
Physical Curve("Z2") = {15};                   // 10 <= y <= 20
Physical Curve("Z3") = {14};                   // 20 <= y <= 30, next to the pushed face

Mesh.ElementOrder = 2;
Mesh.SecondOrderLinear = 1;                    // straight edges: midside nodes at the middle
