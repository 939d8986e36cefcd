"""The cache of FEA solutions: a key that hashes everything that determines
the six displacement fields, verified loads and atomic stores.

An entry is ``<key>.npz`` in the cache folder; the field fit is recomputed
from it on every run, so a rerun with other [field] or [fit] settings costs
no FEA. An entry that cannot be read, or whose arrays do not fit together,
is ignored (with a warning) and solved again.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..errors import StiffkitWarning
from ..io.files import atomic_open
from ..meshing import Mesh
from ..meshing.refine import PRISM_ARRANGEMENT
from .ccx import exact_k
from .config import LinkJob
from .solve import FeaSolution, resolve_route, solve_fea

__all__ = ["CACHE_VERSION", "cache_key", "store_solution", "load_solution", "fea_cached"]

CACHE_VERSION = "fea-2"  # bump when the FEA results of a key change


def _file_digest(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def cache_key(job: LinkJob, route: str) -> str:
    """Hash of everything that determines the six displacement fields."""
    geom = dict(job.geometry)
    if "step" in geom:
        geom = {"cad_sha256": _file_digest(geom["step"]), "suffix": Path(geom["step"]).suffix.lower()}
    key = {
        "v": CACHE_VERSION,
        "geometry": geom,
        "units": job.units,
        "E": job.E,
        "nu": job.nu,
        "density": job.density if route == "matrix" else None,
        "support": job.support_plane,
        "load": job.load_plane,
        "ref": job.reference_point,
        "coupling": job.coupling,
        "amplitudes": job.amplitudes,
        "mesher": job.mesher,
        "order": job.order,
        "size": job.size,
        "refine": job.refine,
        "refine_radius": job.refine_radius,
        "route": route,
        "tol": job.plane_tolerance,
        "optimize": job.optimize,
    }
    if (
        job.uses_cad_faces
        or job.reference_point is None
        or job.region == "faces"
        or not (job.support_plane and job.load_plane)
    ):  # only then: keys of plane-only runs stay as they were
        key["sets"] = {
            "support": [s.key() for s in job.support_sel],
            "load": [s.key() for s in job.load_sel],
            "field": [s.key() for s in job.field_sel],
            "load_tol": job.load_tolerance,
        }
    if job.features:  # only then: keys of plain meshes stay as they were
        key["features"] = {"across": job.across, "around": job.around, "prism": PRISM_ARRANGEMENT}
    if route == "matrix" and exact_k():  # K read exactly (binary), not ccx's 14-digit text
        key["stiffness"] = "exact"
    if job.element.startswith("hex"):  # only then: keys of tetrahedral meshes stay as they were
        key["element"] = job.element
    if job.support_coupling != "rigid":  # only then: keys of clamped runs stay as they were
        key["support_coupling"] = job.support_coupling
    if job.structured:  # only then: keys of unstructured runs stay as they were
        key["structured"] = True
        key["across_factor"] = job.across_factor
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:20]


def remove_stale_temporaries(cache_dir: Path) -> int:
    """Remove half-written entries left by a run that was killed while it
    wrote (their writer process no longer exists); returns how many."""
    gone = 0
    for tmp in Path(cache_dir).glob(".*.npz.*-*.tmp.npz"):
        m = re.match(r"\..*\.npz\.(\d+)-[0-9a-f]+\.tmp\.npz$", tmp.name)
        if m is None:
            continue
        try:
            os.kill(int(m.group(1)), 0)
            continue  # its writer is still running
        except ProcessLookupError:
            pass
        except OSError:
            continue  # another user's process: leave it
        tmp.unlink(missing_ok=True)
        gone += 1
    return gone


def store_solution(path: Path, sol: FeaSolution, key: str | None = None) -> None:
    """Write one entry atomically (a concurrent reader sees the old entry or the whole new one)."""
    meta = {
        "route": sol.route,
        "timing": sol.timing,
        "stats": sol.stats,
        "mesher": sol.mesh.mesher,
        "size_m": sol.mesh.size_m,
        "mesh_info": sol.mesh.info,
    }
    if key is not None:
        meta["key"] = key
    with atomic_open(path, "wb") as fh:
        np.savez(
            fh,
            nodes=sol.mesh.nodes,
            elements=sol.mesh.elements,
            U=sol.U,
            amplitudes=sol.amplitudes,
            ref=sol.ref_motion,
            load=sol.load_nodes,
            fixed=sol.fixed_nodes,
            **({} if sol.field_nodes is None else {"field": sol.field_nodes}),
            meta=np.array(json.dumps(meta)),
        )


def _check(sol: FeaSolution) -> None:
    """ValueError unless the arrays of an entry fit together."""
    n = sol.mesh.nodes.shape[0]
    if n < 4 or sol.mesh.nodes.shape != (n, 3) or sol.U.shape != (6, n, 3):
        raise ValueError(f"displacements {sol.U.shape} for nodes {sol.mesh.nodes.shape}")
    el = sol.mesh.elements
    if el.ndim != 2 or el.shape[1] not in (4, 10) or el.shape[0] < 1 or el.dtype.kind not in "iu":
        raise ValueError(f"elements of shape {el.shape} ({el.dtype})")
    if el.min() < 1 or el.max() > n:
        raise ValueError(f"element nodes outside 1..{n}")
    if not (np.all(np.isfinite(sol.mesh.nodes)) and np.all(np.isfinite(sol.amplitudes)) and np.all(sol.amplitudes > 0)):
        raise ValueError("node coordinates or amplitudes are not finite and positive")
    for name in ("route", "timing", "stats"):
        if not isinstance(getattr(sol, name), (str if name == "route" else dict)):
            raise ValueError(f"metadata {name!r} of the wrong type")
    if sol.amplitudes.shape != (6,) or sol.ref_motion.shape != (6, 6):
        raise ValueError(f"amplitudes {sol.amplitudes.shape}, reference motion {sol.ref_motion.shape}")
    for name, nodes in (("load", sol.load_nodes), ("fixed", sol.fixed_nodes)):
        if nodes.ndim != 1 or nodes.size == 0 or nodes.min() < 1 or nodes.max() > n:
            raise ValueError(f"{name} nodes outside 1..{n}")
    if not (np.all(np.isfinite(sol.U)) and np.all(np.isfinite(sol.ref_motion))):
        raise ValueError("displacements contain NaN or Inf")


def load_solution(path: Path, key: str | None = None) -> FeaSolution | None:
    """The entry at ``path``, or None (with a warning) when it cannot be
    read, was stored under another key, or its arrays do not fit together."""
    try:
        with np.load(path) as z:
            meta = json.loads(str(z["meta"]))
            if key is not None and meta.get("key", key) != key:
                raise ValueError(f"stored under key {meta['key']}")
            mesh = Mesh(
                nodes=z["nodes"],
                elements=z["elements"],
                mesher=meta["mesher"],
                size_m=meta["size_m"],
                info=meta.get("mesh_info", {}),
            )
            sol = FeaSolution(
                mesh=mesh,
                U=z["U"],
                amplitudes=z["amplitudes"],
                ref_motion=z["ref"],
                load_nodes=z["load"],
                fixed_nodes=z["fixed"],
                route=meta["route"],
                timing=meta["timing"],
                stats=meta["stats"],
                field_nodes=z["field"] if "field" in z.files else None,
            )
        _check(sol)
        return sol
    except Exception as exc:  # noqa: BLE001 - any damage (truncated zip, EOF, bad pickle): a miss
        why = " ".join(str(exc).split())[:120]
        warnings.warn(
            StiffkitWarning(f"ignoring the unreadable cache entry {path} ({type(exc).__name__}: {why}); solving again"),
            stacklevel=2,
        )
        return None


def fea_cached(
    job: LinkJob,
    cache_dir: Path | None,
    route: str | None = None,
    progress: Callable[[str], None] | None = None,
    workdir: Path | None = None,
) -> tuple[FeaSolution, bool, str]:
    """FEA solution from the cache when present, else solved and stored:
    (solution, cached, key)."""
    route = route or resolve_route(job)
    key = cache_key(job, route)
    entry = cache_dir / f"{key}.npz" if cache_dir else None
    if entry is not None and entry.is_file():
        sol = load_solution(entry, key)
        if sol is not None:
            return sol, True, key
    own = workdir is None
    if own:
        base = cache_dir if cache_dir is not None and cache_dir.exists() else None
        workdir = Path(tempfile.mkdtemp(prefix=f"run-{key}-", dir=base))
    try:
        sol = solve_fea(job, workdir, route, progress)
    except BaseException as exc:
        # the folder stays for inspection only when the error names a file in
        # it (a ccx log); Ctrl-C, SIGTERM, a missing solver: nothing left behind
        if own and (isinstance(exc, KeyboardInterrupt) or str(workdir) not in str(exc)):
            shutil.rmtree(workdir, ignore_errors=True)
        raise
    if own:
        shutil.rmtree(workdir, ignore_errors=True)
    if entry is not None:
        store_solution(entry, sol, key)
    return sol, False, key
