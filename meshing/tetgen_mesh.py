"""TetGen meshes of a part's surface (the STL Gmsh writes): the tetgen run
and its .node/.ele files read into a :class:`~stiffkit.meshing.mesh.Mesh`
(metres, CalculiX node order)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np

from ..errors import InputError
from .mesh import PERM_TETGEN_TET10, Mesh, MeshError

__all__ = ["read_tetgen", "tetgen_mesh"]


def read_tetgen(node_file: Path, ele_file: Path, order: int, scale: float) -> Mesh:
    def table(path: Path) -> tuple[list[str], np.ndarray]:
        lines = [ln.split("#")[0].split() for ln in path.read_text().splitlines()]
        lines = [ln for ln in lines if ln]
        head, body = lines[0], lines[1:]
        return head, np.array(body, dtype=float)

    _h, nd = table(node_file)
    eh, el = table(ele_file)
    npe = int(eh[1])
    if npe != (10 if order == 2 else 4):
        raise MeshError(f"TetGen wrote {npe}-node tetrahedra, expected {10 if order == 2 else 4}")
    idx = nd[:, 0].astype(np.int64)
    lookup = np.zeros(int(idx.max()) + 1, dtype=np.int64)
    lookup[idx] = np.arange(1, idx.size + 1)
    conn = lookup[el[:, 1 : 1 + npe].astype(np.int64)]
    if order == 2:
        conn = conn[:, PERM_TETGEN_TET10]
    return Mesh(nodes=nd[:, 1:4] * scale, elements=conn, mesher="tetgen")


def tetgen_mesh(stl: Path, order: int, size: float, scale: float, timeout: float) -> Mesh:
    exe = shutil.which("tetgen")
    if exe is None:
        raise InputError(
            "mesh.mesher = 'tetgen' but the tetgen program is not on PATH "
            "(Debian package tetgen; `make install` installs it)"
        )
    vmax = size**3 / (6.0 * np.sqrt(2.0))  # regular tetrahedron of edge `size`
    flags = f"-pq1.414a{vmax:.6g}YQ" + ("o2" if order == 2 else "")
    try:
        proc = subprocess.run([exe, flags, stl.name], cwd=stl.parent, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise MeshError(f"tetgen did not finish within {timeout:.0f} s") from None
    node_file = stl.parent / (stl.stem + ".1.node")
    ele_file = stl.parent / (stl.stem + ".1.ele")
    if proc.returncode != 0 or not ele_file.is_file():
        text = (proc.stdout + proc.stderr).strip().splitlines()[-5:]
        raise MeshError(f"tetgen {flags} failed (exit {proc.returncode}): " + " | ".join(text))
    return read_tetgen(node_file, ele_file, order, scale)
