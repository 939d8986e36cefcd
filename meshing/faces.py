"""The faces of a CAD part as Gmsh numbers them, and the mesh on each.

:func:`read_faces` opens a part (built-in shape, STEP/BREP/IGES, or a Gmsh
``.geo`` script) and returns one :class:`CadFace` per surface: its id (the
Gmsh tag), type, area, centre of area, and for a cylinder its axis and
radius (from the principal curvatures), for a plane its normal; plus the
named groups (physical groups of a .geo, entity names of a STEP).
``distances`` gives the distance of points to every face (trimmed faces:
OpenCASCADE's exact distance). :func:`surface_triangles` collects, after
meshing, the corner triangles of each surface in the mesh's numbering.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from types import ModuleType

import numpy as np

#: a principal curvature below this fraction of the other counts as zero (cylinder)
_FLAT = 1e-9


@dataclass
class CadFace:
    """One CAD surface; lengths in the geometry's unit."""

    id: int
    type: str  # Plane | Cylinder | Cone | Sphere | Torus | BSpline surface ... (OpenCASCADE's name)
    area: float
    centre: list
    bbox: list  # xmin, ymin, zmin, xmax, ymax, zmax
    axis: list | None = None  # cylinder axis (unit) or plane normal
    radius: float | None = None  # cylinder radius
    point: list | None = None  # a point of the cylinder's axis (the centre projected on it)

    def to_dict(self) -> dict:
        return asdict(self)

    def describe(self, units: str) -> str:
        c = ", ".join(f"{v:.6g}" for v in self.centre)
        s = f"face {self.id} ({self.type}, area {self.area:.6g} {units}^2, centre [{c}]"
        if self.radius is not None:
            a = ", ".join(f"{v:.4g}" for v in self.axis)
            s += f", axis [{a}], radius {self.radius:.6g}"
        elif self.axis is not None:
            a = ", ".join(f"{v:.4g}" for v in self.axis)
            s += f", normal [{a}]"
        return s + ")"


def _face(gmsh: ModuleType, tag: int) -> CadFace:
    occ = gmsh.model.occ
    typ = gmsh.model.getType(2, tag)
    area = float(occ.getMass(2, tag))
    centre = [float(v) for v in occ.getCenterOfMass(2, tag)]
    bbox = [float(v) for v in gmsh.model.getBoundingBox(2, tag)]
    face = CadFace(id=int(tag), type=typ, area=area, centre=centre, bbox=bbox)
    lo, hi = gmsh.model.getParametrizationBounds(2, tag)
    uv = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2]
    if typ == "Plane":
        n = np.asarray(gmsh.model.getNormal(tag, uv), dtype=float)
        face.axis = [float(v) for v in n / np.linalg.norm(n)]
    else:  # a cylinder, or a surface of another type that is one (a fused or spline face)
        cyl = _cylinder_of(gmsh, tag, lo, hi, np.asarray(centre), rel=1e-9 if typ == "Cylinder" else 1e-6)
        if cyl is not None:
            face.axis, face.radius, face.point = cyl
    return face


def _cylinder_of(
    gmsh: ModuleType, tag: int, lo: list, hi: list, centre: np.ndarray, rel: float
) -> tuple[list, float, list] | None:
    """(axis, radius, point on the axis) when the surface is a circular
    cylinder: at 3 x 3 parametric points one principal curvature vanishes,
    the other is the same, and the axes found agree (within ``rel``)."""
    uv = [(lo[0] + (hi[0] - lo[0]) * a, lo[1] + (hi[1] - lo[1]) * b) for a in (0.2, 0.5, 0.8) for b in (0.2, 0.5, 0.8)]
    flat = np.array(uv, dtype=float).ravel()
    kmax, kmin, dmax, dmin = (np.asarray(v, dtype=float) for v in gmsh.model.getPrincipalCurvatures(tag, flat))
    pts = np.asarray(gmsh.model.getValue(2, tag, flat), dtype=float).reshape(-1, 3)
    nrm = np.asarray(gmsh.model.getNormal(tag, flat), dtype=float).reshape(-1, 3)
    k = np.column_stack([kmax, kmin])
    dirs = np.stack([dmax.reshape(-1, 3), dmin.reshape(-1, 3)], axis=1)
    i_flat = np.argmin(np.abs(k), axis=1)
    rows = np.arange(k.shape[0])
    curv = np.abs(k[rows, 1 - i_flat])
    if not (curv > 0).all() or (np.abs(k[rows, i_flat]) > rel * curv).any():
        return None
    if np.ptp(curv) > rel * curv.mean():
        return None
    r = 1.0 / curv.mean()
    axes = dirs[rows, i_flat]
    axes = axes / np.linalg.norm(axes, axis=1)[:, None]
    axis = _canonical(axes[0])
    if (np.linalg.norm(np.cross(axes, axis), axis=1) > np.sqrt(rel)).any():
        return None
    nrm = nrm / np.linalg.norm(nrm, axis=1)[:, None]
    best = None
    for sign in (-1.0, 1.0):  # the axis lies at r along the normal, on one side
        q = pts + sign * r * nrm
        off = q - q[0]
        spread = np.linalg.norm(off - np.outer(off @ axis, axis), axis=1).max()
        if best is None or spread < best[0]:
            best = (spread, q[0])
    if best[0] > np.sqrt(rel) * r:
        return None
    q0 = best[1]
    point = q0 + np.dot(centre - q0, axis) * axis
    return [float(v) for v in axis], float(r), [float(v) for v in point]


def _canonical(v: np.ndarray) -> np.ndarray:
    """The direction with its largest component positive (axes have no sign)."""
    i = int(np.argmax(np.abs(v)))
    return -v if v[i] < 0 else v


def groups(gmsh: ModuleType) -> dict[str, list[int]]:
    """Named surface groups: physical groups (a .geo, .msh) and entity names
    (STEP labels: the full name and its last path segment)."""
    out: dict[str, list[int]] = {}
    for dim, ptag in gmsh.model.getPhysicalGroups(2):
        name = gmsh.model.getPhysicalName(dim, ptag)
        tags = [int(t) for t in gmsh.model.getEntitiesForPhysicalGroup(dim, ptag)]
        for key in [name or str(ptag)]:
            out.setdefault(key, [])
            out[key] = sorted(set(out[key]) | set(tags))
    for _dim, tag in gmsh.model.getEntities(2):
        name = gmsh.model.getEntityName(2, tag)
        if name:
            for key in {name, name.rsplit("/", 1)[-1]}:
                out.setdefault(key, [])
                out[key] = sorted(set(out[key]) | {int(tag)})
    return out


def _discrete_face(gmsh: ModuleType, tag: int) -> CadFace | None:
    """A surface of a .msh (no CAD behind it) from its mesh: area, centre
    and bounding box of its elements' corner triangles (a quadrilateral:
    two), a plane's normal when its nodes lie on one (1e-9 of its size);
    None when the file holds no element on it."""
    tris = []
    ntags, coords, _p = gmsh.model.mesh.getNodes(2, tag, includeBoundary=True)
    if len(ntags) == 0:
        return None
    xyz = dict(zip((int(t) for t in ntags), np.asarray(coords, dtype=float).reshape(-1, 3)))
    for etype, _et, enodes in zip(*gmsh.model.mesh.getElements(2, tag)):
        props = gmsh.model.mesh.getElementProperties(etype)
        nn, corners = props[3], props[5]
        conn = np.asarray(enodes, dtype=np.int64).reshape(-1, nn)[:, :corners]
        tris += [conn[:, :3]] + ([conn[:, [0, 2, 3]]] if corners == 4 else [])
    if not tris:
        return None
    t = np.concatenate(tris)
    p = np.array([[xyz[int(v)] for v in row] for row in t])
    cr = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    a = 0.5 * np.linalg.norm(cr, axis=1)
    area = float(a.sum())
    centre = (a[:, None] * p.mean(axis=1)).sum(axis=0) / area
    pts = p.reshape(-1, 3)
    bbox = [float(v) for v in np.concatenate([pts.min(axis=0), pts.max(axis=0)])]
    face = CadFace(id=int(tag), type="Discrete", area=area, centre=[float(v) for v in centre], bbox=bbox)
    _u, sv, vt = np.linalg.svd(pts - centre, full_matrices=False)
    if sv[-1] <= 1e-9 * max(sv[0], 1e-300) * np.sqrt(len(pts)):
        face.type = "Plane"
        face.axis = [float(v) for v in _canonical(vt[-1])]
    return face


def faces_of_model(gmsh: ModuleType) -> list[CadFace]:
    """Every surface of the current (synchronised) model; of a .msh (discrete
    surfaces), every surface that carries elements, measured on its mesh."""
    out = []
    for _dim, tag in gmsh.model.getEntities(2):
        if gmsh.model.getType(2, tag) == "Discrete surface":
            f = _discrete_face(gmsh, tag)
            if f is not None:
                out.append(f)
        else:
            out.append(_face(gmsh, tag))
    return out


def distances(gmsh: ModuleType, points: list, faces: list[CadFace]) -> np.ndarray:
    """(len(points), len(faces)) exact distances from each point to each
    (trimmed) face, in the geometry's unit (OpenCASCADE)."""
    occ = gmsh.model.occ
    out = np.zeros((len(points), len(faces)))
    if faces and all(f.type in ("Discrete", "Plane") for f in faces) and not gmsh.model.occ.getEntities(2):
        # a .msh: the distance to the nearest node of each surface's mesh
        for j, f in enumerate(faces):
            _t, c, _p = gmsh.model.mesh.getNodes(2, f.id, includeBoundary=True)
            xyz = np.asarray(c, dtype=float).reshape(-1, 3)
            for i, p in enumerate(points):
                out[i, j] = float(np.min(np.linalg.norm(xyz - np.asarray(p, dtype=float), axis=1)))
        return out
    for i, p in enumerate(points):
        pt = occ.addPoint(float(p[0]), float(p[1]), float(p[2]))
        occ.synchronize()
        for j, f in enumerate(faces):
            out[i, j] = occ.getDistance(0, pt, 2, f.id)[0]
        occ.remove([(0, pt)])
        occ.synchronize()
    return out


def surface_triangles(gmsh: ModuleType, corners: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """(tri (m, 3) corner node numbers in the mesh's 1-based numbering,
    tag (m,) the surface each triangle lies on) of the current gmsh mesh;
    ``corners = 4``: its quadrilaterals (a hexahedral mesh), (m, 4).
    The numbering is the one :func:`~stiffkit.meshing.gmsh_mesh.mesh_part`
    gives: the nodes of the 3-D elements, in increasing gmsh tag order."""
    used = []
    for _etype, _tags, enodes in zip(*gmsh.model.mesh.getElements(3)):
        used.append(np.asarray(enodes, dtype=np.int64))
    if not used:
        return np.zeros((0, corners), dtype=np.int64), np.zeros(0, dtype=np.int64)
    used_all = np.unique(np.concatenate(used))
    lookup = np.zeros(int(used_all.max()) + 1, dtype=np.int64)
    lookup[used_all] = np.arange(1, used_all.size + 1)
    tris, tags = [], []
    for _dim, tag in gmsh.model.getEntities(2):
        for etype, _et, enodes in zip(*gmsh.model.mesh.getElements(2, tag)):
            nn = gmsh.model.mesh.getElementProperties(etype)[3]
            conn = np.asarray(enodes, dtype=np.int64).reshape(-1, nn)[:, :corners]
            if conn.size == 0:
                continue
            if conn.max() >= lookup.size or (lookup[conn] == 0).any():
                continue  # a surface not bounding the volume mesh
            tris.append(lookup[conn])
            tags.append(np.full(conn.shape[0], tag, dtype=np.int64))
    if not tris:
        return np.zeros((0, corners), dtype=np.int64), np.zeros(0, dtype=np.int64)
    return np.concatenate(tris), np.concatenate(tags)


def format_faces(faces: list[CadFace], named: dict[str, list[int]], units: str) -> str:
    """The table `stiffkit link --list-faces` prints."""
    lines = [
        f"{len(faces)} face(s), lengths in {units}:",
        f"{'id':>4}  {'type':<16} {'area':>12}  {'centre x, y, z':<36} {'axis / normal':<26} {'radius':>10}",
    ]
    span = max([abs(v) for f in faces for v in f.bbox] + [1e-300])
    for f in faces:
        # OpenCASCADE's integrals leave ~1e-16 (1e-9 of the part on trimmed faces) where 0 is meant
        c = ", ".join(f"{(v if abs(v) > 1e-8 * span else 0.0):.5g}" for v in f.centre)
        a = "" if f.axis is None else ", ".join(f"{v + 0.0:.4g}" for v in f.axis)
        r = "" if f.radius is None else f"{f.radius:.6g}"
        lines.append(f"{f.id:>4}  {f.type:<16} {f.area:>12.6g}  {c:<36} {a:<26} {r:>10}")
    if named:
        lines.append("named groups: " + "; ".join(f"{k} = {v}" for k, v in sorted(named.items())))
    return "\n".join(lines)
