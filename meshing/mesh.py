"""Tetrahedral and hexahedral meshes in CalculiX's conventions, and face selection.

A :class:`Mesh` holds node coordinates in metres (rows 0..n-1 are nodes
1..n) and elements as 1-based node numbers in CalculiX order (C3D4 or
C3D10: corners, then mid-sides 1-2, 2-3, 3-1, 1-4, 2-4, 3-4; C3D8 or
C3D20R: corners 1-4 of the bottom face, 5-8 above them, then mid-sides
1-2, 2-3, 3-4, 4-1, 5-6, 6-7, 7-8, 8-5, 1-5, 2-6, 3-7, 4-8). Meshers write
their own mid-side order; the permutation tables below turn it into
CalculiX's, and :func:`check_geometry` proves it (every mid-side node at the
midpoint of its edge, every volume positive).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

#: mesher's 10-node tet -> CalculiX C3D10: ccx_nodes = mesher_nodes[:, PERM]
PERM_GMSH_TET10 = np.array([0, 1, 2, 3, 4, 5, 6, 7, 9, 8])
PERM_TETGEN_TET10 = np.array([0, 1, 2, 3, 6, 7, 9, 5, 8, 4])
#: CalculiX C3D10 mid-side node k (4..9) sits on the edge between these corners
CCX_TET10_EDGES = np.array([[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]])
#: CalculiX tet faces S1..S4 (corners; for C3D10 then mid-sides in face order)
CCX_TET_FACES = {1: (0, 1, 2, 4, 5, 6), 2: (0, 3, 1, 7, 8, 4), 3: (1, 3, 2, 8, 9, 5), 4: (2, 3, 0, 9, 7, 6)}
#: gmsh's 20-node hexahedron (type 17) -> CalculiX C3D20R
PERM_GMSH_HEX20 = np.array([0, 1, 2, 3, 4, 5, 6, 7, 8, 11, 13, 9, 16, 18, 19, 17, 10, 12, 14, 15])
#: CalculiX C3D20(R) mid-side node k (8..19) sits on the edge between these corners
CCX_HEX20_EDGES = np.array(
    [[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4], [0, 4], [1, 5], [2, 6], [3, 7]]
)
#: CalculiX hex faces S1..S6 (corners, outward normal; for C3D20R then mid-sides in face order)
CCX_HEX_FACES = {
    1: (0, 1, 2, 3, 8, 9, 10, 11),
    2: (4, 7, 6, 5, 15, 14, 13, 12),
    3: (0, 4, 5, 1, 16, 12, 17, 8),
    4: (1, 5, 6, 2, 17, 13, 18, 9),
    5: (2, 6, 7, 3, 18, 14, 19, 10),
    6: (3, 7, 4, 0, 19, 15, 16, 11),
}
#: nodes per element -> (CalculiX type, order, hexahedron?)
ELEMENT_KINDS = {4: ("C3D4", 1, False), 10: ("C3D10", 2, False), 8: ("C3D8", 1, True), 20: ("C3D20R", 2, True)}
#: [mesh] element names -> nodes per element
ELEMENT_NODES = {"tet4": 4, "tet10": 10, "hex8": 8, "hex20": 20}
PLANES = ("x-min", "x-max", "y-min", "y-max", "z-min", "z-max")


class MeshError(InputError):
    """The geometry or mesh cannot be used (not a solid, empty selection ...)."""


@dataclass
class Mesh:
    nodes: np.ndarray  # (n, 3) metres
    elements: np.ndarray  # (ne, 4|10) 1-based, CalculiX order
    mesher: str = "gmsh"
    size_m: float = 0.0
    info: dict = field(default_factory=dict)
    #: the mesh's boundary triangles (corner nodes, 1-based) and the CAD face each lies on (gmsh meshes)
    surface_tri: np.ndarray | None = None
    surface_tag: np.ndarray | None = None

    @property
    def order(self) -> int:
        return ELEMENT_KINDS[self.elements.shape[1]][1]

    @property
    def ccx_type(self) -> str:
        return ELEMENT_KINDS[self.elements.shape[1]][0]

    @property
    def is_hex(self) -> bool:
        return ELEMENT_KINDS[self.elements.shape[1]][2]

    @property
    def face_table(self) -> dict:
        """CalculiX's faces S1.. of this element kind: local nodes, corners first."""
        return CCX_HEX_FACES if self.is_hex else CCX_TET_FACES

    @property
    def face_corners(self) -> int:
        return 4 if self.is_hex else 3

    @property
    def face_nodes(self) -> int:
        """Nodes of one element face: 3 | 6 (triangles), 4 | 8 (quadrilaterals)."""
        return self.face_corners * self.order

    @property
    def n_nodes(self) -> int:
        return int(self.nodes.shape[0])

    @property
    def n_elements(self) -> int:
        return int(self.elements.shape[0])

    def bbox(self) -> tuple[np.ndarray, np.ndarray]:
        return self.nodes.min(axis=0), self.nodes.max(axis=0)


def tet_volumes(nodes: np.ndarray, elements: np.ndarray) -> np.ndarray:
    """Signed volumes of the corner tetrahedra (positive = CalculiX orientation);
    of a hexahedron: the sum of its corners' six Kuhn tetrahedra."""
    if elements.shape[1] in (8, 20):
        kuhn = ((0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6))
        return sum(tet_volumes(nodes, elements[:, list(t)]) for t in kuhn)
    p = nodes[elements[:, :4] - 1]
    a, b, c = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]
    return np.einsum("ij,ij->i", np.cross(a, b), c) / 6.0


def midside_errors(nodes: np.ndarray, elements: np.ndarray) -> np.ndarray:
    """Distance of each C3D10 mid-side node from its edge midpoint, relative
    to the edge length: (ne, 6). Zero for straight-sided elements."""
    p = nodes[elements - 1]
    edges, first = (CCX_HEX20_EDGES, 8) if elements.shape[1] == 20 else (CCX_TET10_EDGES, 4)
    ends = p[:, edges]  # (ne, edges, 2, 3)
    mid = ends.mean(axis=2)
    length = np.linalg.norm(ends[:, :, 1] - ends[:, :, 0], axis=2)
    return np.linalg.norm(p[:, first:] - mid, axis=2) / length


def check_geometry(mesh: Mesh, curved_tol: float = 0.25) -> dict:
    """Prove the node order: positive volumes and, for C3D10, every
    mid-side node near its edge midpoint (exactly on it for straight edges;
    on a curved boundary it may move off by a fraction of the edge, bounded
    by ``curved_tol``). Raises MeshError, returns statistics."""
    vol = tet_volumes(mesh.nodes, mesh.elements)
    stats = {"min_volume": float(vol.min()), "total_volume": float(vol.sum())}
    if (vol <= 0).any():
        raise MeshError(
            f"{int((vol <= 0).sum())} of {vol.size} elements have non-positive volume "
            f"(node order wrong for CalculiX {mesh.ccx_type})"
        )
    if mesh.order == 2:
        err = midside_errors(mesh.nodes, mesh.elements)
        stats["max_midside_offset"] = float(err.max())
        stats["straight_fraction"] = float((err < 1e-9).mean())
        if err.max() > curved_tol:
            raise MeshError(
                f"mid-side nodes are not at their edge midpoints (offset up to "
                f"{err.max():.3g} edge lengths): wrong {mesh.ccx_type} node order"
            )
    return stats


def plane_nodes(mesh: Mesh, plane: str, tol: float | None = None, what: str = "plane") -> np.ndarray:
    """1-based numbers of the nodes on a bounding-box face ('x-min' ...),
    within ``tol`` metres (default 1e-6 of the bounding-box diagonal)."""
    if plane not in PLANES:
        raise InputError(f"{what} = {plane!r}: choose one of {', '.join(PLANES)}")
    lo, hi = mesh.bbox()
    if tol is None:
        tol = 1e-6 * float(np.linalg.norm(hi - lo))
    axis = "xyz".index(plane[0])
    value = lo[axis] if plane.endswith("min") else hi[axis]
    sel = np.nonzero(np.abs(mesh.nodes[:, axis] - value) <= tol)[0] + 1
    if sel.size == 0:
        raise MeshError(f"{what} = {plane!r} (at {plane[0]} = {value:.6g} m, tolerance {tol:.3g} m) selects no nodes")
    return sel


def faces_on_nodes(mesh: Mesh, node_set: np.ndarray) -> np.ndarray:
    """Element faces whose nodes all belong to ``node_set``: (nf, 2) rows of
    (1-based element, face number 1..4, or 1..6 for hexahedra)."""
    on = np.zeros(mesh.n_nodes + 1, dtype=bool)
    on[np.asarray(node_set)] = True
    out = []
    for s, loc in mesh.face_table.items():
        ok = np.logical_and.reduce([on[mesh.elements[:, loc[k]]] for k in range(mesh.face_corners)])
        for e in np.nonzero(ok)[0]:
            out.append((e + 1, s))
    return np.array(sorted(out), dtype=int).reshape(-1, 2)


def face_connectivity(mesh: Mesh, faces: np.ndarray) -> np.ndarray:
    """Node numbers (nf, 3|6|4|8) of element faces from :func:`faces_on_nodes`:
    corners, then for quadratic elements the mid-sides 1-2, 2-3, ... of the face."""
    k = mesh.face_nodes
    table = mesh.face_table
    rows = [mesh.elements[e - 1, list(table[s][:k])] for e, s in faces]
    return np.array(rows, dtype=int).reshape(-1, k)
