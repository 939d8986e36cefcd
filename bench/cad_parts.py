"""Three realistic link shapes made with Gmsh's OpenCASCADE kernel (issue 18),
written as STEP files for bench/bench_cad.py. Lengths in mm; every part
starts at x = 0 so its clamp face is the bounding-box plane x-min.

* ``arm``: an L-shaped hollow cast arm (40 x 30 mm hollow section, 8 mm
  walls) ending in two bearing housings (bore 40 mm, wall 10 mm): the first
  housing's axis is x (its end annulus is the plane x-min), the second's is
  y (its end annulus is the plane y-max).
* ``clevis``: a bolted flange (diameter 100 mm, six 9 mm bolt holes on a
  76 mm circle) on a block carrying two pin lugs (16 mm pin hole through
  both), flat-ended at x = 110 (the plane x-max takes both lug ends).
* ``tapered``: a tapered hollow box beam (60 x 40 mm at the root to 36 x 24
  mm at x = 200, 6 mm walls) with three lightening holes through its webs
  and 4 mm fillets on its four outer longitudinal edges.
"""

from __future__ import annotations

import math
from pathlib import Path

#: the parts: name -> ([support] table, [load] table) with the face selectors
#: (bores and pin holes as cylinders, the flange's bolt holes, end planes), mm
PARTS = {
    "arm": (
        {"cylinder": {"axis": [1.0, 0.0, 0.0], "point": [0.0, 0.0, 0.0], "radius": 20.0}},
        {"cylinder": {"axis": [0.0, 1.0, 0.0], "point": [110.0, 90.0, 0.0], "radius": 20.0}, "coupling": "rigid"},
    ),
    "clevis": (
        {
            "cylinder": [
                {"axis": [1.0, 0.0, 0.0], "point": [0.0, 38.0 * math.cos(a), 38.0 * math.sin(a)], "radius": 4.5}
                for a in (math.pi / 6 + k * math.pi / 3 for k in range(6))
            ]
        },
        {"cylinder": {"axis": [0.0, 0.0, 1.0], "point": [90.0, 0.0, 0.0], "radius": 8.0}, "coupling": "rigid"},
    ),
    "tapered": (
        {"plane": "x-min"},
        {"plane": "x-max", "reference_point": [200.0, 0.0, 0.0], "coupling": "distributing"},
    ),
}


def _arm(occ) -> None:
    b, h, t = 40.0, 30.0, 8.0  # the arm's hollow section and wall
    ro, ri, w = 30.0, 20.0, 40.0  # bearing housings: outer and bore radius, width
    X, Y = 110.0, 110.0  # the second housing: its axis at x = X, its end at y = Y
    # arm A along x from the first housing, arm B along y into the second
    a = occ.addBox(w - 10.0, -b / 2, -h / 2, X + b / 2 - w + 10.0, b, h)
    c = occ.addBox(X - b / 2, -b / 2, -h / 2, b, Y - w + 10.0 + b / 2, h)
    h1 = occ.addCylinder(0.0, 0.0, 0.0, w, 0.0, 0.0, ro)
    h2 = occ.addCylinder(X, Y - w, 0.0, 0.0, w, 0.0, ro)
    body, _ = occ.fuse([(3, a), (3, c)], [(3, h1), (3, h2)])
    cavity_a = occ.addBox(w + t, -b / 2 + t, -h / 2 + t, X + b / 2 - t - w - t, b - 2 * t, h - 2 * t)
    cavity_b = occ.addBox(X - b / 2 + t, -b / 2 + t, -h / 2 + t, b - 2 * t, Y - w - t + b / 2 - t, h - 2 * t)
    bores = [
        occ.addCylinder(-1.0, 0.0, 0.0, w + 1, 0.0, 0.0, ri),
        occ.addCylinder(X, Y - w, 0.0, 0.0, w + 1, 0.0, ri),
    ]
    occ.cut(body, [(3, cavity_a), (3, cavity_b)] + [(3, x) for x in bores])


def _clevis(occ) -> None:
    flange = occ.addCylinder(0.0, 0.0, 0.0, 12.0, 0.0, 0.0, 50.0)
    block = occ.addBox(12.0, -25.0, -25.0, 40.0, 50.0, 50.0)
    lug1 = occ.addBox(52.0, -25.0, 9.0, 58.0, 50.0, 16.0)
    lug2 = occ.addBox(52.0, -25.0, -25.0, 58.0, 50.0, 16.0)
    body, _ = occ.fuse([(3, flange)], [(3, block), (3, lug1), (3, lug2)])
    holes = [occ.addCylinder(90.0, 0.0, -30.0, 0.0, 0.0, 60.0, 8.0)]
    for k in range(6):
        a = 2 * math.pi * k / 6 + math.pi / 6
        holes.append(occ.addCylinder(-1.0, 38.0 * math.cos(a), 38.0 * math.sin(a), 14.0, 0.0, 0.0, 4.5))
    occ.cut(body, [(3, x) for x in holes])


def _rect(occ, x: float, b: float, h: float) -> int:
    p = [occ.addPoint(x, sy * b / 2, sz * h / 2) for sy, sz in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    lines = [occ.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]
    return occ.addWire(lines)


def _tapered(occ, gmsh) -> None:
    L, t = 200.0, 6.0
    ends = [_rect(occ, 0.0, 60.0, 40.0), _rect(occ, L, 36.0, 24.0)]
    outer = occ.addThruSections(ends, makeSolid=True, makeRuled=True)
    occ.synchronize()
    edges = []
    for _d, e in gmsh.model.getEntities(1):
        lo = gmsh.model.getBoundingBox(1, e)
        if lo[3] - lo[0] > L / 2:  # the four longitudinal edges
            edges.append(e)
    outer = occ.fillet([outer[0][1]], edges, [4.0])
    inner = occ.addThruSections(
        [_rect(occ, 0.0, 60.0 - 2 * t, 40.0 - 2 * t), _rect(occ, L, 36.0 - 2 * t, 24.0 - 2 * t)],
        makeSolid=True,
        makeRuled=True,
    )
    holes = [
        occ.addCylinder(x, -40.0, 0.0, 0.0, 80.0, 0.0, r)
        for x, r in ((50.0, 9.0), (120.0, 8.0), (190.0, 7.0), (250.0, 5.0))
    ]
    occ.cut(outer, [(3, inner[0][1])] + [(3, x) for x in holes])


def write_part(name: str, path: Path | str) -> Path:
    """Make part ``name`` and write it as STEP (mm)."""
    import gmsh

    path = Path(path)
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(name)
        occ = gmsh.model.occ
        if name == "arm":
            _arm(occ)
        elif name == "clevis":
            _clevis(occ)
        elif name == "tapered":
            _tapered(occ, gmsh)
        else:
            raise ValueError(f"unknown part {name!r}: one of {', '.join(PARTS)}")
        occ.synchronize()
        if len(gmsh.model.getEntities(3)) != 1:
            raise RuntimeError(f"part {name!r}: {len(gmsh.model.getEntities(3))} solids, expected one")
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path
