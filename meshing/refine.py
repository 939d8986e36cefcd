"""Meshes that resolve a part's features (issue 18): Gmsh size fields.

On the current Gmsh model (OpenCASCADE), :func:`find_features` measures every
face: its kind, its smallest radius of curvature (a hole, a bore, a fillet)
and the local wall thickness behind it (the distance to the nearest face
straight across the material, found by closest points and checked to pass
through the solid). :func:`feature_fields` turns them into a background size
field, the minimum of

* ``2 pi r / around`` on each curved face (at least ``around`` elements
  around a hole or a fillet's full circle),
* ``t / across`` through each wall thinner than ``across`` elements of the
  nominal size (``across`` elements across the thinnest wall),
* ``SELECTED_FACTOR * size`` near the selected (support and load) faces,

each growing back to the nominal size over ``GROWTH`` nominal sizes. A
built-in box is prismatic: :func:`prism_across_factor` gives the structured
(transfinite) mesh its ``across`` elements over the section instead.
"""

from __future__ import annotations

import math
from types import ModuleType

import numpy as np

from .mesh import Mesh

#: elements across the thinnest wall: a structured prism (hex cells, each six
#: tets: cheap) and an unstructured tet mesh. On the paper's beam the torsion
#: term needs about six quadratic elements across the section; eight give
#: 0.04 % (docs/link.md, "Meshes that resolve the features")
ACROSS_PRISM, ACROSS_TETS = 8, 3
#: the split of a structured prism's hex cells (bump when it changes: cache keys)
PRISM_ARRANGEMENT = "kuhn"
#: elements around a full circle of a hole's (or fillet's) radius
AROUND = 16
#: element size near the selected faces, as a fraction of the nominal size
SELECTED_FACTOR = 0.5
#: a refined size grows back to the nominal one over this many nominal sizes
GROWTH = 2.0
#: no field asks for less than this fraction of the nominal size (the node
#: limit [mesh] max_nodes stops a mesh that would still be too large)
FLOOR = 0.05
#: two faces are straight across a wall when the line between them is within
#: this cosine of both faces' normals
ACROSS_COS = 0.95


def default_across(geometry: dict) -> int:
    """The default ``across`` of a part: a built-in box is meshed structured."""
    return ACROSS_PRISM if geometry.get("shape") == "box" else ACROSS_TETS


def prism_across_factor(extent: list[float] | np.ndarray, size: float, across: int) -> float:
    """The ``across_factor`` of a structured box: ``across`` elements over its
    smallest side (the section), never coarser than ``size`` itself."""
    return min(1.0, float(min(extent)) / (across * size))


def _outward_normal(gmsh: ModuleType, tag: int, uv: list[float], p: np.ndarray, vol: int, eps: float) -> np.ndarray:
    n = np.asarray(gmsh.model.getNormal(tag, uv), dtype=float)[:3]
    n /= max(np.linalg.norm(n), 1e-300)
    if gmsh.model.isInside(3, vol, list(p - eps * n)) <= 0 and gmsh.model.isInside(3, vol, list(p + eps * n)) > 0:
        n = -n
    return n


def _samples(gmsh: ModuleType, tag: int) -> list[tuple[np.ndarray, list[float]]]:
    """Points on the face with their uv: the closest to its centre of mass,
    and those of a 2 x 2 grid over its parameter range that lie on the
    (trimmed) face."""
    c = gmsh.model.occ.getCenterOfMass(2, tag)
    p, uv = gmsh.model.getClosestPoint(2, tag, list(c))
    out = [(np.asarray(p, dtype=float), list(uv))]
    lo, hi = gmsh.model.getParametrizationBounds(2, tag)
    for a in (0.25, 0.75):
        for b in (0.25, 0.75):
            uv = [lo[0] + a * (hi[0] - lo[0]), lo[1] + b * (hi[1] - lo[1])]
            if gmsh.model.isInside(2, tag, uv, parametric=True) > 0:
                out.append((np.asarray(gmsh.model.getValue(2, tag, uv), dtype=float), uv))
    return out


def find_features(gmsh: ModuleType) -> list[dict]:
    """Every face of the model's solid: ``tag``, ``kind`` (Gmsh's type
    name), ``radius`` (smallest radius of curvature at its sample point, inf
    for a plane) and ``wall`` (local thickness of the material behind it, inf
    when no face lies straight across). Lengths in geometry units."""
    vol = gmsh.model.getEntities(3)[0][1]
    box = np.array(gmsh.model.getBoundingBox(-1, -1))
    diag = float(np.linalg.norm(box[3:] - box[:3]))
    eps = 1e-6 * diag
    faces = [t for _d, t in gmsh.model.getEntities(2)]
    boxes = np.array([gmsh.model.getBoundingBox(2, t) for t in faces], dtype=float)
    out = []
    for t in faces:
        samples = _samples(gmsh, t)
        kind = gmsh.model.getType(2, t)
        k = 0.0
        wall = math.inf
        for p, uv in samples:
            kmax, kmin, *_ = gmsh.model.getPrincipalCurvatures(t, uv)
            k = max(k, abs(float(kmax[0])), abs(float(kmin[0])))
            n = _outward_normal(gmsh, t, uv, p, vol, eps)
            # nearest faces first (by bounding box); none beyond the wall found
            gap = np.linalg.norm(np.maximum(0.0, np.maximum(boxes[:, :3] - p, p - boxes[:, 3:])), axis=1)
            for i in np.argsort(gap):
                u = faces[i]
                if gap[i] >= wall:
                    break
                if u == t:
                    continue
                q, quv = gmsh.model.getClosestPoint(2, u, list(p))
                d = np.asarray(q, dtype=float) - p
                dist = float(np.linalg.norm(d))
                if dist <= 10 * eps or dist >= wall or float(d @ -n) < ACROSS_COS * dist:
                    continue
                # straight across: the line is normal to the far face too (not a graze of
                # its edge), and the point is on that face (Gmsh projects on the untrimmed surface)
                m = np.asarray(gmsh.model.getNormal(u, list(quv)), dtype=float)[:3]
                if abs(float(m @ d)) < ACROSS_COS * dist * max(float(np.linalg.norm(m)), 1e-300):
                    continue
                if gmsh.model.isInside(2, u, list(quv), parametric=True) <= 0:
                    continue
                if gmsh.model.isInside(3, vol, list(p + 0.5 * d)) > 0:
                    wall = dist
        radius = 1.0 / k if k > 1e-9 / diag else math.inf
        out.append({"tag": t, "kind": kind, "radius": radius, "wall": wall, "area": gmsh.model.occ.getMass(2, t)})
    return out


def _threshold(gmsh: ModuleType, surfaces: list[int], small: float, size: float, dist_min: float) -> int:
    f = gmsh.model.mesh.field
    d = f.add("Distance")
    f.setNumbers(d, "SurfacesList", surfaces)
    f.setNumber(d, "Sampling", 20)
    t = f.add("Threshold")
    f.setNumber(t, "InField", d)
    f.setNumber(t, "SizeMin", small)
    f.setNumber(t, "SizeMax", size)
    f.setNumber(t, "DistMin", dist_min)
    f.setNumber(t, "DistMax", dist_min + GROWTH * size)
    return t


def feature_fields(
    gmsh: ModuleType, size: float, across: int, around: int, selected: list[int] | None = None
) -> tuple[list[int], dict]:
    """Add the size fields of the features (module docstring) to the model;
    returns (field ids, summary: counts and the smallest sizes asked for)."""
    feats = find_features(gmsh)
    floor = FLOOR * size
    fields: list[int] = []
    holes = walls = 0
    smallest = size
    # tetrahedra (about 6 per cube of the local size): the nominal volume, plus
    # each refined layer (a wall's half-thickness or one element) and its grading
    tets = sum(6.0 * gmsh.model.occ.getMass(3, t) / size**3 for _d, t in gmsh.model.getEntities(3))
    thinnest = min((f["wall"] for f in feats), default=math.inf)
    for f in feats:
        if math.isfinite(f["radius"]):
            s = max(floor, 2 * math.pi * f["radius"] / around)
            if s < size:
                fields.append(_threshold(gmsh, [f["tag"]], s, size, s))
                tets += 6.0 * f["area"] * (1.0 / s**2 + 1.0 / s**2)
                holes += 1
                smallest = min(smallest, s)
        if math.isfinite(f["wall"]):
            s = max(floor, f["wall"] / across)
            if s < size:
                fields.append(_threshold(gmsh, [f["tag"]], s, size, f["wall"]))
                tets += 6.0 * f["area"] * (0.5 * f["wall"] / s**3 + 1.0 / s**2)
                walls += 1
                smallest = min(smallest, s)
    if selected:
        s = SELECTED_FACTOR * size
        fields.append(_threshold(gmsh, list(selected), s, size, size))
        smallest = min(smallest, s)
    info = {
        "curved_faces_refined": holes,
        "wall_faces_refined": walls,
        "selected_faces": len(selected or []),
        "thinnest_wall": thinnest if math.isfinite(thinnest) else None,
        "smallest_size": smallest,
        "across": across,
        "around": around,
        "tets_estimate": tets,
    }
    return fields, info


#: nodes per tetrahedron of a Gmsh mesh (C3D4, C3D10; the paper's beam: 1630 /
#: 8557 nodes for about 5.9e3 tets at 5 mm)
NODES_PER_TET = {1: 0.2, 2: 1.45}


def estimate_nodes(info: dict, size: float, order: int) -> float:
    """Nodes of the mesh the fields of :func:`feature_fields` will give (its
    tets estimate; within a factor ~2)."""
    return NODES_PER_TET[order] * info["tets_estimate"]


def plane_surfaces(gmsh: ModuleType, plane: str) -> list[int]:
    """Tags of the faces lying on a bounding-box plane ('x-min' ...)."""
    gmsh.option.setNumber("Geometry.OCCBoundsUseStl", 1)  # tight bounds of curved faces
    box = np.array(gmsh.model.getBoundingBox(-1, -1))
    axis = "xyz".index(plane[0])
    value = box[axis] if plane.endswith("min") else box[axis + 3]
    tol = 1e-6 * float(np.linalg.norm(box[3:] - box[:3]))
    out = []
    for _d, t in gmsh.model.getEntities(2):
        b = np.array(gmsh.model.getBoundingBox(2, t))
        if abs(b[axis] - value) <= 10 * tol + 2e-7 and abs(b[axis + 3] - value) <= 10 * tol + 2e-7:
            out.append(t)
    return out


def set_background(gmsh: ModuleType, fields: list[int], smallest: float) -> None:
    """The minimum of the fields as the background mesh size; sizes from the
    boundary's points and curvature off (the fields say everything)."""
    if not fields:
        return
    m = gmsh.model.mesh.field.add("Min")
    gmsh.model.mesh.field.setNumbers(m, "FieldsList", fields)
    gmsh.model.mesh.field.setAsBackgroundMesh(m)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeMin", smallest)


def prism_mesh(lo: np.ndarray, hi: np.ndarray, size: float, across_factor: float, order: int, scale: float) -> Mesh:
    """Structured tetrahedral mesh of an axis-aligned box (geometry units
    ``lo``..``hi``; the returned Mesh in metres, CalculiX order): ``size``
    along the longest side, ``across_factor * size`` across (as
    :func:`stiffkit.meshing.gmsh_mesh._structured_box` divides), each hex
    cell split into the six tetrahedra around its diagonal from (0, 0, 0) to
    (1, 1, 1) (Kuhn; conforming, and the same under a swap of y and z).
    Measured on the paper's beam at 5 mm, 8 across (C3D10, max error of the
    non-zero elements vs eq. 22): this split 0.036 %; Gmsh's transfinite
    split 0.059 % (k22 -0.059 % vs k33 -0.027 %: one bending plane stiffer);
    the split mirrored in every other cell along x 0.050 %, along x, y and z
    0.073 %."""
    import itertools

    from .mesh import CCX_TET10_EDGES, tet_volumes

    ext = hi - lo
    along = int(np.argmax(ext))
    n = [max(1, int(np.ceil(ext[a] / (size if a == along else across_factor * size) * (1 - 1e-6)))) for a in range(3)]
    axes = [np.linspace(lo[a], hi[a], n[a] + 1) for a in range(3)]
    gx, gy, gz = np.meshgrid(*axes, indexing="ij")
    corners = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)
    ci, cj, ck = (c.ravel() for c in np.meshgrid(*[np.arange(m) for m in n], indexing="ij"))

    def node(v: int) -> np.ndarray:  # local corner v (bits x, y, z) of every cell
        bx, by, bz = v & 1, (v >> 1) & 1, (v >> 2) & 1
        return ((ci + bx) * (n[1] + 1) + (cj + by)) * (n[2] + 1) + (ck + bz)

    tets = [
        np.stack([node(0), node(a), node(a | b), node(7)], axis=1) for a, b, _c in itertools.permutations((1, 2, 4))
    ]
    conn = np.concatenate(tets) + 1
    neg = tet_volumes(corners, conn) < 0
    conn[neg] = conn[neg][:, [0, 2, 1, 3]]
    nodes = corners
    if order == 2:
        edges = np.sort(conn[:, CCX_TET10_EDGES], axis=2).reshape(-1, 2)
        uniq, inv = np.unique(edges, axis=0, return_inverse=True)
        mids = 0.5 * (corners[uniq[:, 0] - 1] + corners[uniq[:, 1] - 1])
        nodes = np.concatenate([corners, mids])
        conn = np.concatenate([conn, corners.shape[0] + 1 + inv.reshape(-1, 6)], axis=1)
    return Mesh(nodes=nodes * scale, elements=conn.astype(np.int64), mesher="gmsh")


def hex_mesh(lo: np.ndarray, hi: np.ndarray, size: float, across_factor: float, order: int, scale: float) -> Mesh:
    """Structured hexahedral mesh of an axis-aligned box, divided as
    :func:`prism_mesh` divides it (``size`` along the longest side,
    ``across_factor * size`` across): C3D8 (order 1) or C3D20R (order 2,
    the mid-side nodes at the edge midpoints), CalculiX order."""
    from .mesh import CCX_HEX20_EDGES

    ext = hi - lo
    along = int(np.argmax(ext))
    n = [max(1, int(np.ceil(ext[a] / (size if a == along else across_factor * size) * (1 - 1e-6)))) for a in range(3)]
    axes = [np.linspace(lo[a], hi[a], n[a] + 1) for a in range(3)]
    gx, gy, gz = np.meshgrid(*axes, indexing="ij")
    corners = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)
    ci, cj, ck = (c.ravel() for c in np.meshgrid(*[np.arange(m) for m in n], indexing="ij"))

    def node(v: int) -> np.ndarray:  # local corner v (bits x, y, z) of every cell
        bx, by, bz = v & 1, (v >> 1) & 1, (v >> 2) & 1
        return ((ci + bx) * (n[1] + 1) + (cj + by)) * (n[2] + 1) + (ck + bz)

    # CalculiX: 1-2-3-4 counter-clockwise below 5-6-7-8 (z = bit 2)
    conn = np.stack([node(v) for v in (0, 1, 3, 2, 4, 5, 7, 6)], axis=1) + 1
    nodes = corners
    if order == 2:
        edges = np.sort(conn[:, CCX_HEX20_EDGES], axis=2).reshape(-1, 2)
        uniq, inv = np.unique(edges, axis=0, return_inverse=True)
        mids = 0.5 * (corners[uniq[:, 0] - 1] + corners[uniq[:, 1] - 1])
        nodes = np.concatenate([corners, mids])
        conn = np.concatenate([conn, corners.shape[0] + 1 + inv.reshape(-1, 12)], axis=1)
    return Mesh(nodes=nodes * scale, elements=conn.astype(np.int64), mesher="gmsh")
