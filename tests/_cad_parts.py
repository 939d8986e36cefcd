"""CAD parts with known faces, made with Gmsh's OpenCASCADE kernel for the
face-selector and coupling tests (lengths in mm)."""

from __future__ import annotations

import math
from pathlib import Path

#: the plate: 100 x 40 x 20 mm box with two through-holes along z
PLATE = {"size": (100.0, 40.0, 20.0), "holes": [((70.0, 20.0), 5.0), ((20.0, 20.0), 8.0)]}


def _gmsh():
    import gmsh

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    return gmsh


def plate_step(path: Path) -> Path:
    """The plate as a STEP file."""
    gmsh = _gmsh()
    try:
        occ = gmsh.model.occ
        L, b, h = PLATE["size"]
        box = occ.addBox(0, 0, 0, L, b, h)
        holes = [(3, occ.addCylinder(x, y, 0, 0, 0, h, r)) for (x, y), r in PLATE["holes"]]
        occ.cut([(3, box)], holes)
        occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def plate_geo(path: Path) -> Path:
    """The plate as a Gmsh .geo script naming its faces: "bores" (both
    holes), "small_bore", "end" (the x = 0 face)."""
    L, b, h = PLATE["size"]
    (x1, y1), r1 = PLATE["holes"][0]
    (x2, y2), r2 = PLATE["holes"][1]
    e = 0.01
    path.write_text(
        f"""SetFactory("OpenCASCADE");
Box(1) = {{0, 0, 0, {L}, {b}, {h}}};
Cylinder(2) = {{{x1}, {y1}, 0, 0, 0, {h}, {r1}}};
Cylinder(3) = {{{x2}, {y2}, 0, 0, 0, {h}, {r2}}};
BooleanDifference(4) = {{ Volume{{1}}; Delete; }}{{ Volume{{2, 3}}; Delete; }};
s1[] = Surface In BoundingBox{{{x1 - r1 - e}, {y1 - r1 - e}, {-e}, {x1 + r1 + e}, {y1 + r1 + e}, {h + e}}};
s2[] = Surface In BoundingBox{{{x2 - r2 - e}, {y2 - r2 - e}, {-e}, {x2 + r2 + e}, {y2 + r2 + e}, {h + e}}};
s3[] = Surface In BoundingBox{{{-e}, {-e}, {-e}, {e}, {b + e}, {h + e}}};
Physical Surface("bores") = {{s1[], s2[]}};
Physical Surface("small_bore") = {{s1[]}};
Physical Surface("end") = {{s3[]}};
"""
    )
    return path


def plate_areas() -> dict:
    """Exact areas (mm^2) of the plate's faces."""
    L, b, h = PLATE["size"]
    r1, r2 = PLATE["holes"][0][1], PLATE["holes"][1][1]
    return {
        "hole1": 2 * math.pi * r1 * h,
        "hole2": 2 * math.pi * r2 * h,
        "top": L * b - math.pi * (r1**2 + r2**2),
        "end_x": b * h,
        "side_y": L * h,
    }


def shell_step(path: Path) -> Path:
    """A STEP holding a surface only (no solid)."""
    gmsh = _gmsh()
    try:
        gmsh.model.occ.addRectangle(0, 0, 0, 50, 20)
        gmsh.model.occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def pinned_tube_step(path: Path, L: float, Do: float, Di: float, pin_x: tuple, d_pin: float) -> Path:
    """A tube along +x (outer/inner diameters Do, Di) with transverse pin
    holes along z (diameter d_pin) through both walls at each x of pin_x."""
    gmsh = _gmsh()
    try:
        occ = gmsh.model.occ
        o = occ.addCylinder(0, 0, 0, L, 0, 0, Do / 2)
        i = occ.addCylinder(0, 0, 0, L, 0, 0, Di / 2)
        t, _ = occ.cut([(3, o)], [(3, i)])
        pins = [(3, occ.addCylinder(x, 0, -Do, 0, 0, 2 * Do, d_pin / 2)) for x in pin_x]
        occ.cut(t, pins)
        occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def bored_tube_step(
    path: Path, L: float, Do: float, Di: float, Dc: float, Lc: float, pin_x: float, d_pin: float
) -> Path:
    """A tube along +x (outer/inner diameters Do, Di) whose first Lc of bore
    is a seat of diameter Dc > Di (the clamped bore: a shaft fitted in it),
    with a transverse pin hole along z (diameter d_pin) through both walls
    at x = pin_x."""
    gmsh = _gmsh()
    try:
        occ = gmsh.model.occ
        o = occ.addCylinder(0, 0, 0, L, 0, 0, Do / 2)
        i = occ.addCylinder(0, 0, 0, L, 0, 0, Di / 2)
        seat = occ.addCylinder(0, 0, 0, Lc, 0, 0, Dc / 2)
        t, _ = occ.cut([(3, o)], [(3, i), (3, seat)])
        pin = occ.addCylinder(pin_x, 0, -Do, 0, 0, 2 * Do, d_pin / 2)
        occ.cut(t, [(3, pin)])
        occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path
