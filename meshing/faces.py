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
    elif typ == "Cylinder":
        kmax, kmin, dmax, dmin = gmsh.model.getPrincipalCurvatures(tag, uv)
        k = np.array([kmax[0], kmin[0]])
        dirs = [np.asarray(dmax, dtype=float), np.asarray(dmin, dtype=float)]
        i_flat = int(np.argmin(np.abs(k)))
        curv = abs(k[1 - i_flat])
        if curv > 0 and abs(k[i_flat]) <= _FLAT * curv:
            axis = dirs[i_flat] / np.linalg.norm(dirs[i_flat])
            axis = _canonical(axis)
            r = 1.0 / curv
            p = np.asarray(gmsh.model.getValue(2, tag, uv), dtype=float)
            n = np.asarray(gmsh.model.getNormal(tag, uv), dtype=float)
            n = n / np.linalg.norm(n)
            # the axis lies at distance r along the normal, on one side or the other
            cands = [p - r * n, p + r * n]
            c = np.asarray(centre)
            on_axis = [q + np.dot(c - q, axis) * axis for q in cands]
            best = min(range(2), key=lambda i: np.linalg.norm(np.cross(c - cands[i], axis)))
            face.axis = [float(v) for v in axis]
            face.radius = float(r)
            face.point = [float(v) for v in on_axis[best]]
    return face


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


def faces_of_model(gmsh: ModuleType) -> list[CadFace]:
    """Every surface of the current (synchronised) model."""
    return [_face(gmsh, tag) for _dim, tag in gmsh.model.getEntities(2)]


def distances(gmsh: ModuleType, points: list, faces: list[CadFace]) -> np.ndarray:
    """(len(points), len(faces)) exact distances from each point to each
    (trimmed) face, in the geometry's unit (OpenCASCADE)."""
    occ = gmsh.model.occ
    out = np.zeros((len(points), len(faces)))
    for i, p in enumerate(points):
        pt = occ.addPoint(float(p[0]), float(p[1]), float(p[2]))
        occ.synchronize()
        for j, f in enumerate(faces):
            out[i, j] = occ.getDistance(0, pt, 2, f.id)[0]
        occ.remove([(0, pt)])
        occ.synchronize()
    return out


def surface_triangles(gmsh: ModuleType) -> tuple[np.ndarray, np.ndarray]:
    """(tri (m, 3) corner node numbers in the mesh's 1-based numbering,
    tag (m,) the surface each triangle lies on) of the current gmsh mesh.
    The numbering is the one :func:`~stiffkit.meshing.gmsh_mesh.mesh_part`
    gives: the nodes of the 3-D elements, in increasing gmsh tag order."""
    used = []
    for _etype, _tags, enodes in zip(*gmsh.model.mesh.getElements(3)):
        used.append(np.asarray(enodes, dtype=np.int64))
    if not used:
        return np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=np.int64)
    used_all = np.unique(np.concatenate(used))
    lookup = np.zeros(int(used_all.max()) + 1, dtype=np.int64)
    lookup[used_all] = np.arange(1, used_all.size + 1)
    tris, tags = [], []
    for _dim, tag in gmsh.model.getEntities(2):
        for etype, _et, enodes in zip(*gmsh.model.mesh.getElements(2, tag)):
            nn = gmsh.model.mesh.getElementProperties(etype)[3]
            conn = np.asarray(enodes, dtype=np.int64).reshape(-1, nn)[:, :3]
            if conn.size == 0:
                continue
            if conn.max() >= lookup.size or (lookup[conn] == 0).any():
                continue  # a surface not bounding the volume mesh
            tris.append(lookup[conn])
            tags.append(np.full(conn.shape[0], tag, dtype=np.int64))
    if not tris:
        return np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=np.int64)
    return np.concatenate(tris), np.concatenate(tags)


def format_faces(faces: list[CadFace], named: dict[str, list[int]], units: str) -> str:
    """The table `stiffkit link --list-faces` prints."""
    lines = [
        f"{len(faces)} face(s), lengths in {units}:",
        f"{'id':>4}  {'type':<16} {'area':>12}  {'centre x, y, z':<36} {'axis / normal':<26} {'radius':>10}",
    ]
    for f in faces:
        c = ", ".join(f"{v:.5g}" for v in f.centre)
        a = "" if f.axis is None else ", ".join(f"{v:.4g}" for v in f.axis)
        r = "" if f.radius is None else f"{f.radius:.6g}"
        lines.append(f"{f.id:>4}  {f.type:<16} {f.area:>12.6g}  {c:<36} {a:<26} {r:>10}")
    if named:
        lines.append("named groups: " + "; ".join(f"{k} = {v}" for k, v in sorted(named.items())))
    return "\n".join(lines)
