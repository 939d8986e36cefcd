"""A picture of a link's mesh with its selected faces: the boundary
triangles of the mesh in grey, the clamped set in blue, the loaded set in
red, the reference point as a black cross (PNG, matplotlib 3-D)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.files import pyplot, save_figure
from ..meshing import Mesh


def boundary_triangles(mesh: Mesh) -> np.ndarray:
    """(m, 3) corner nodes (1-based) of the element faces on the boundary
    (those that belong to one element only)."""
    k = mesh.face_corners
    face = np.concatenate([mesh.elements[:, list(loc[:k])] for loc in mesh.face_table.values()])
    key = np.sort(face, axis=1)
    _u, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    face = face[count[inv.ravel()] == 1]
    if k == 4:  # quadrilaterals: two triangles each
        face = np.concatenate([face[:, [0, 1, 2]], face[:, [0, 2, 3]]])
    return face


def write_faces_png(
    path: Path | str,
    mesh: Mesh,
    fixed: np.ndarray,
    load: np.ndarray,
    reference_point: list | np.ndarray,
    title: str = "",
    scale: float = 1e3,
    units: str = "mm",
) -> Path:
    """The mesh's boundary with the clamped (blue) and loaded (red) faces."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    plt = pyplot()
    tri = boundary_triangles(mesh)
    on_fix = np.zeros(mesh.n_nodes + 1, dtype=bool)
    on_fix[np.asarray(fixed)] = True
    on_load = np.zeros(mesh.n_nodes + 1, dtype=bool)
    on_load[np.asarray(load)] = True
    colour = np.full((tri.shape[0], 4), (0.82, 0.82, 0.82, 0.35))
    colour[on_fix[tri].all(axis=1)] = (0.1, 0.3, 0.9, 0.95)
    colour[on_load[tri].all(axis=1)] = (0.9, 0.15, 0.1, 0.95)
    xyz = mesh.nodes * scale
    fig = plt.figure(figsize=(9, 5))
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(Poly3DCollection(xyz[tri - 1], facecolors=colour, edgecolors=(0.3, 0.3, 0.3, 0.25), lw=0.2))
    p = np.asarray(reference_point) * scale
    ax.scatter([p[0]], [p[1]], [p[2]], marker="x", s=60, c="k")
    lo, hi = xyz.min(axis=0), xyz.max(axis=0)
    ext = np.maximum(hi - lo, 0.05 * (hi - lo).max())  # equal scales; a flat part keeps some depth
    for setter, a, b in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), (lo + hi - ext) / 2, (lo + hi + ext) / 2):
        setter(a, b)
    ax.set_box_aspect(tuple(ext / ext.max()), zoom=1.2)
    ax.set_xlabel(f"x, {units}")
    ax.set_ylabel(f"y, {units}")
    ax.set_zlabel(f"z, {units}")
    ax.tick_params(labelsize=7)
    ax.view_init(elev=28, azim=-60)
    default = f"{mesh.n_nodes} nodes: clamped faces blue, loaded faces red, x = reference point"
    ax.set_title(title or default, fontsize=9)
    try:
        save_figure(fig, path, dpi=110, format="png")
    finally:
        plt.close(fig)
    return Path(path)
