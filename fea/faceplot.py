"""A picture of a link's mesh with its selected faces: the boundary
triangles of the mesh in grey, the clamped set in blue, the loaded set in
red, the reference point as a black cross (PNG, matplotlib 3-D)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.files import pyplot, save_figure
from ..meshing import Mesh
from ..meshing.mesh import CCX_TET_FACES


def boundary_triangles(mesh: Mesh) -> np.ndarray:
    """(m, 3) corner nodes (1-based) of the element faces on the boundary
    (those that belong to one element only)."""
    corner = mesh.elements[:, :4]
    tri = np.concatenate([corner[:, list(loc[:3])] for loc in CCX_TET_FACES.values()])
    key = np.sort(tri, axis=1)
    _u, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return tri[count[inv.ravel()] == 1]


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
    mid, half = (lo + hi) / 2, (hi - lo).max() / 2
    for setter, m in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), mid):
        setter(m - half, m + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel(f"x, {units}")
    ax.set_ylabel(f"y, {units}")
    ax.set_zlabel(f"z, {units}")
    ax.view_init(elev=28, azim=-60)
    ax.set_title(title or f"{mesh.n_nodes} nodes: clamped faces blue, loaded faces red, x = reference point")
    try:
        save_figure(fig, path, dpi=110, format="png")
    finally:
        plt.close(fig)
    return Path(path)
