"""The node and element-face sets of [support], [load] and [field] on a mesh.

Before meshing, :func:`resolve_job_sets` reads the part's CAD faces and
turns every CAD selector (face, cylinder, point, box, group) into face ids
(errors name the nearest candidates). After meshing, :func:`mesh_set`
gives each set's nodes and element faces: the bounding-box planes by node
coordinates (as before), the CAD faces by the mesh triangles Gmsh laid on
them. :func:`default_reference_point` is the load set's centre of area,
on its axis when the set is coaxial cylinders (a pin, a bearing bore).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..meshing import Mesh, MeshError, faces_on_nodes, plane_nodes
from ..meshing.faces import CadFace
from ..meshing.gmsh_mesh import cad_faces
from .config import ConfigError, LinkJob
from .selectors import SelectorError, cad_selectors, coaxial_axis, describe, planes_of, resolve

SECTIONS = ("support", "load", "field")


@dataclass
class CadSets:
    """The CAD faces of the part and the ids each section selects."""

    faces: list[CadFace]
    named: dict[str, list[int]]
    diag: float  # bounding-box diagonal, geometry units
    ids: dict[str, list[int]] = field(default_factory=dict)

    def by_id(self, ids: list[int]) -> list[CadFace]:
        table = {f.id: f for f in self.faces}
        return [table[i] for i in ids]


def _sels(job: LinkJob, section: str) -> list:
    return {"support": job.support_sel, "load": job.load_sel, "field": job.field_sel}[section]


def resolve_job_sets(job: LinkJob) -> CadSets | None:
    """The CAD face ids of each section (None when every set is made of
    bounding-box planes only: then no CAD faces are needed)."""
    if not job.uses_cad_faces:
        return None
    if job.mesher != "gmsh":
        raise ConfigError(
            f'{job.source}: face selectors other than plane need mesher = "gmsh" (it lays the mesh on each '
            f"CAD face), not {job.mesher!r}"
        )
    points = [s.value for sec in SECTIONS for s in _sels(job, sec) if s.kind == "point"]
    faces, named, dist, box = cad_faces(job.geometry, job.units, points)
    diag = float(np.linalg.norm(np.subtract(box[3:], box[:3])))
    sets = CadSets(faces=faces, named=named, diag=diag)
    k = 0
    for sec in SECTIONS:
        ids: set[int] = set()
        for s in cad_selectors(_sels(job, sec)):
            d = None
            if s.kind == "point":
                d = dist[k]
                k += 1
            try:
                ids |= set(resolve(s, faces, named, d, diag, job.units))
            except SelectorError as exc:
                raise ConfigError(str(exc)) from None
        sets.ids[sec] = sorted(ids)
    both = sorted(set(sets.ids["support"]) & set(sets.ids["load"]))
    if both:
        raise ConfigError(
            f"{job.source}: [load] and [support] both select CAD face(s) {both}: the load face must differ "
            "from the clamped face"
        )
    return sets


def triangles_to_faces(mesh: Mesh, tri: np.ndarray) -> np.ndarray:
    """(elem, face number) of the element faces whose corners are the
    triangles ``tri`` (corner nodes, 1-based; quadrilaterals (m, 4) on a
    hexahedral mesh): (nf, 2). A face is known by its three lowest corners."""
    if tri.size == 0:
        return np.zeros((0, 2), dtype=int)
    n = np.int64(mesh.n_nodes + 1)

    def code(c: np.ndarray) -> np.ndarray:
        c = np.sort(c.astype(np.int64), axis=1)[:, :3]
        return (c[:, 0] * n + c[:, 1]) * n + c[:, 2]

    k = mesh.face_corners
    codes, owner = [], []
    for s, loc in mesh.face_table.items():
        codes.append(code(mesh.elements[:, list(loc[:k])]))
        owner.append(np.column_stack([np.arange(1, mesh.n_elements + 1), np.full(mesh.n_elements, s)]))
    codes_a = np.concatenate(codes)
    owner_a = np.concatenate(owner)
    order = np.argsort(codes_a, kind="stable")
    codes_a, owner_a = codes_a[order], owner_a[order]
    want = code(tri)
    pos = np.searchsorted(codes_a, want)
    ok = (pos < codes_a.size) & (codes_a[np.minimum(pos, codes_a.size - 1)] == want)
    if not ok.all():
        raise MeshError(f"{int((~ok).sum())} surface triangle(s) of the CAD faces match no element face")
    out = owner_a[pos]
    return out[np.lexsort((out[:, 1], out[:, 0]))]


def mesh_set(
    job: LinkJob, mesh: Mesh, section: str, cad: CadSets | None, tol: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """(nodes, element faces) of one section's set on the mesh."""
    sels = _sels(job, section)
    nodes = [np.zeros(0, dtype=np.int64)]
    faces = [np.zeros((0, 2), dtype=int)]
    for plane in planes_of(sels):
        pn = plane_nodes(mesh, plane, tol, f"{job.source}: [{section}] plane")
        nodes.append(pn)
        faces.append(faces_on_nodes(mesh, pn))
    ids = cad.ids.get(section, []) if cad is not None else []
    if ids:
        if mesh.surface_tri is None:
            raise MeshError(f"{job.source}: [{section}]: the mesh carries no CAD faces (mesher {mesh.mesher!r})")
        on = np.isin(mesh.surface_tag, ids)
        f = triangles_to_faces(mesh, mesh.surface_tri[on])
        if f.size == 0:
            raise MeshError(f"{job.source}: [{section}] CAD face(s) {ids} carry no element face of the mesh")
        faces.append(f)
        k = mesh.face_nodes
        conn = np.array([mesh.elements[e - 1, list(mesh.face_table[s][:k])] for e, s in f])
        nodes.append(conn.ravel())
    fa = np.concatenate(faces)
    fa = np.unique(fa, axis=0) if fa.size else fa
    return np.unique(np.concatenate(nodes)), fa


def set_label(job: LinkJob, section: str) -> str:
    return f"[{section}] {describe(_sels(job, section))}"


def default_reference_point(job: LinkJob, mesh: Mesh, cad: CadSets | None, weights: np.ndarray) -> np.ndarray:
    """The load set's centre of area (m): ``weights`` are the nodal weights
    of a uniform traction on its faces (their first moment is exact for the
    isoparametric faces), projected on the common axis when the set is
    coaxial cylinders (a pin through two lugs, a bearing bore)."""
    c = (weights[:, None] * mesh.nodes).sum(axis=0) / weights.sum()
    if cad is not None and not planes_of(job.load_sel):  # CAD faces only: OpenCASCADE's exact centre
        faces = cad.by_id(cad.ids.get("load", []))
        area = sum(f.area for f in faces)
        c = sum(np.asarray(f.centre) * f.area for f in faces) / area * job.scale
        ax = coaxial_axis(faces, cad.diag)
        if ax is not None:
            p, a = np.asarray(ax[0]) * job.scale, np.asarray(ax[1])
            c = p + np.dot(c - p, a) * a
    return c
