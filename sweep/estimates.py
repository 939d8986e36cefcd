"""Estimates of a run before it runs (sweep/runner.py places runs by them):
the node count of its mesh from the part's volume, surface and edge length,
and its peak memory from the node count."""

from __future__ import annotations

import contextlib
import math
import os
import sys
from collections.abc import Iterator
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..fea.config import LinkJob

__all__ = ["estimate_nodes", "estimate_memory_mb", "CACHED_MB", "NODE_MODEL"]

#: peak memory model of a run, MB: BASE + SAFETY * PEAK_40K * (nodes / 40084) ** POWER,
#: fitted to matrix-route runs of the paper's beam (C3D10: 8557 nodes 139 MB, 40084 nodes
#: 535 MB, 109531 nodes 1.74 GB, 237423 nodes 4.6 GB; the six-step ccx route needs less)
BASE_MB, PEAK_40K_MB, POWER, SAFETY = 100.0, 465.0, 1.28, 1.25
#: a run whose FEA is in the cache only loads it and fits
CACHED_MB = 150.0
#: node count of an unstructured gmsh mesh of size h:
#: a V/h^3 + b S/h^2 + c P/h (V volume, S surface, P edge length), by order
NODE_MODEL = {1: (0.680, 0.732, 0.556), 2: (5.495, 3.478, 2.437)}

_CAD_MEASURES: dict[tuple, tuple] = {}


@contextlib.contextmanager
def _silent_stdout() -> Iterator[None]:
    """OpenCASCADE prints its STEP statistics on file descriptor 1."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def _cad_measures(path: str) -> tuple[float, float, float]:
    """(volume, surface, edge length) of a CAD file in its own units."""
    st = os.stat(path)
    key = (path, st.st_mtime_ns, st.st_size)
    if key not in _CAD_MEASURES:
        import gmsh

        with _silent_stdout():
            gmsh.initialize(readConfigFiles=False)
            try:
                gmsh.option.setNumber("General.Terminal", 0)
                gmsh.model.occ.importShapes(path)
                gmsh.model.occ.synchronize()
                occ = gmsh.model.occ
                V = sum(occ.getMass(3, t) for _, t in gmsh.model.getEntities(3))
                S = sum(occ.getMass(2, t) for _, t in gmsh.model.getEntities(2))
                P = sum(occ.getMass(1, t) for _, t in gmsh.model.getEntities(1))
            except Exception:  # unreadable: the run itself will say why
                V = S = P = 0.0
            finally:
                gmsh.finalize()
        _CAD_MEASURES[key] = (V, S, P)
    return _CAD_MEASURES[key]


def estimate_nodes(job: LinkJob) -> int:
    """Nodes of the run's mesh, estimated from the geometry and the mesh size
    before meshing (unstructured gmsh meshes: within ~10 % above a few
    thousand nodes, ~35 % for a section only one or two elements across)."""
    g = job.geometry
    h = job.size
    if g.get("shape") == "box":
        L, b, c = g["size"]
        prism = job.features and job.mesher == "gmsh" and not job.refine and job.optimize == "none"
        if job.structured or prism:
            ext = [L, b, c]
            along = max(range(3), key=lambda i: ext[i])
            af = job.across_factor if job.structured else min(1.0, min(ext) / (job.across * h))
            n = [max(1, math.ceil(e / (h if i == along else af * h) * (1 - 1e-6))) for i, e in enumerate(ext)]
            k = 2 if job.order == 2 else 1
            return int(math.prod(k * m + 1 for m in n))
        V, S, P = L * b * c, 2 * (L * b + b * c + L * c), 4 * (L + b + c)
        lmax = max(L, b, c)
    elif g.get("shape") in ("tube", "rod"):
        L = g["length"]
        ro = g["outer_diameter"] / 2
        ri = g.get("inner_diameter", 0.0) / 2 if g["shape"] == "tube" else 0.0
        V = math.pi * (ro * ro - ri * ri) * L
        S = 2 * math.pi * (ro + ri) * L + 2 * math.pi * (ro * ro - ri * ri)
        P = 4 * math.pi * (ro + ri)
        lmax = max(L, 2 * ro)
        if job.features and ri > 0:  # the wall's size field: across elements through it
            h = min(h, (ro - ri) / job.across)
    else:
        V, S, P = _cad_measures(g["step"])
        lmax = max(V ** (1 / 3), 1e-12) if V > 0 else h
    a, b_, c_ = NODE_MODEL[job.order]
    n = a * V / h**3 + b_ * S / h**2 + c_ * P / h
    if job.refine:
        R = job.refine_radius or 4 * h
        n *= 1 + (1 / job.refine**3 - 1) * min(1.0, 2 * R / lmax)
    return max(int(n), 10)


def estimate_memory_mb(nodes: int) -> float:
    """Peak resident memory of a run (ccx; Python with CHOLMOD), MB."""
    return BASE_MB + SAFETY * PEAK_40K_MB * (nodes / 40084.0) ** POWER
