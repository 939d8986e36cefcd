"""One FEA-to-compliance job: mesh, six load cases, field fits, compliance.

Pipeline (Pashkevich et al. 2009, s2-s4):

1. mesh the part (Gmsh or TetGen, C3D4/C3D10), clamp the support face, couple
   a reference node to the load face (distributing or rigid);
2. solve the six unit-direction load cases, either as six ccx *STEPs
   (``route = "ccx"``) or by letting ccx assemble K once
   (*FREQUENCY, SOLVER=MATRIXSTORAGE) and solving all six with one CHOLMOD
   factorisation in the core (``route = "matrix"``, the same nodal loads as
   ccx's *DISTRIBUTING);
3. fit the rigid motion (t, phi) of the field nodes near the reference point
   in each case (core field fit), build the compliance with confidence
   intervals and zero-element tests (core), and report beside it the
   reference node's own compliance (work-conjugate face motion, or the
   *RIGID BODY nodes) as an independent check.

FEA results (displacement fields) are cached under a hash of everything
that determines them; fits are recomputed from the cache.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..field import DOF_NAMES, LOAD_NAMES, compliance_from_experiments, fit_fields
from ..io.files import atomic_write_text
from ..meshing import Mesh
from .amplitudes import PHI_RANGE_RAD, T_RANGE_M, auto_amplitudes, beam_estimate, closed_form
from .cache import cache_key, fea_cached
from .config import LinkJob
from .facesets import set_label
from .outputs import LinkResult
from .solve import FeaSolution, resolve_route, solve_fea


def select_field(
    job: LinkJob,
    mesh: Mesh,
    load_nodes: np.ndarray,
    fixed_nodes: np.ndarray | None = None,
    face_nodes: np.ndarray | None = None,
) -> np.ndarray:
    """1-based node numbers of the field around the reference point (s4.4):
    ``face`` the load face; ``cube`` nodes inside a cube of edge
    ``field.size`` centred on the reference point; ``layer`` nodes within
    ``field.size`` of the load plane; ``faces`` the nodes of the [field]
    face selectors (``face_nodes``, found when the part was meshed). A region that reaches the clamped
    nodes (``fixed_nodes``) is an error: they do not follow the load face,
    so the rigid-motion fit would mix two bodies."""
    p0 = np.asarray(job.reference_point)
    if job.region == "face":
        sel = np.asarray(load_nodes)
    elif job.region == "faces":
        if face_nodes is None:
            raise InputError(f'{job.source}: [field] region = "faces": the solution carries no field faces')
        sel = np.asarray(face_nodes)
    elif job.region == "cube":
        inside = np.all(np.abs(mesh.nodes - p0) <= job.region_size / 2 * (1 + 1e-9), axis=1)
        sel = np.nonzero(inside)[0] + 1
    else:
        axis = "xyz".index(job.load_plane[0])
        lo, hi = mesh.bbox()
        value = lo[axis] if job.load_plane.endswith("min") else hi[axis]
        sel = np.nonzero(np.abs(mesh.nodes[:, axis] - value) <= job.region_size * (1 + 1e-9))[0] + 1
    if fixed_nodes is not None and job.region != "face":
        clamped = np.intersect1d(sel, fixed_nodes)
        if clamped.size:
            raise InputError(
                f"{job.source}: [field] region = {job.region!r}, size = {job.region_size / job.scale:g} {job.units} "
                f"takes in {clamped.size} clamped node(s) of the {set_label(job, 'support')}: the field "
                "must stay near the load face (give a smaller size or other faces)"
            )
    if sel.size < 3:
        raise InputError(
            f"{job.source}: [field] region = {job.region!r}"
            f"{'' if job.region in ('face', 'faces') else f', size = {job.region_size / job.scale:g} {job.units}'}"
            f" selects {sel.size} node(s); the fit needs at least 3 "
            "(enlarge the region or refine the mesh)"
        )
    return sel


def fit_solution(job: LinkJob, sol: FeaSolution) -> tuple:
    """Fit the field of every load case and build the compliance (core):
    (field nodes, fits, compliance, reference-node compliance, seconds)."""
    t0 = time.perf_counter()
    field_nodes = select_field(job, sol.mesh, sol.load_nodes, sol.fixed_nodes, sol.field_nodes)
    pts = sol.mesh.nodes[field_nodes - 1]
    fits = fit_fields(
        pts, sol.U[:, field_nodes - 1], job.reference_point, method=job.method, trim=job.trim, pooled=job.pooled
    )
    comp = compliance_from_experiments(
        np.diag(sol.amplitudes), fits, confidence=job.confidence, symmetrize=job.symmetrize
    )
    ref_c = sol.ref_motion / sol.amplitudes[None, :]
    return field_nodes, fits, comp, ref_c, time.perf_counter() - t0


def run_link(
    job: LinkJob,
    cache_dir: Path | str | None = None,
    route: str | None = None,
    progress: Callable[[str], None] | None = None,
    workdir: Path | str | None = None,
) -> LinkResult:
    """Run (or resume from the cache) one LINK job and fit its compliance;
    with ``[mesh] accuracy``, the refinement loop of :mod:`.accuracy`."""
    if job.accuracy is not None:
        from .accuracy import run_to_accuracy

        return run_to_accuracy(job, run_link, cache_dir, route, progress, workdir)
    cache_dir = Path(cache_dir) if cache_dir else None
    if cache_dir:
        cache_dir.mkdir(parents=True, exist_ok=True)
    sol, cached, key = fea_cached(job, cache_dir, route, progress, Path(workdir) if workdir else None)
    if job.reference_point is None:  # the default: the load set's centre, found when solved
        job = dataclasses.replace(job, reference_point=list(sol.stats["reference_point_m"]))
    field_nodes, fits, comp, ref_c, t_fit = fit_solution(job, sol)
    timing = {"mesh": sol.timing["mesh"], "fea": sol.timing["fea"], "fit": t_fit}
    return LinkResult(
        job=job,
        solution=sol,
        compliance=comp,
        fits=fits,
        field_nodes=field_nodes,
        reference_compliance=ref_c,
        closed_form=closed_form(job),
        timing=timing,
        cached=cached,
        key=key,
    )


__all__ = [
    "run_link",
    "LinkResult",
    "FeaSolution",
    "solve_fea",
    "fea_cached",
    "fit_solution",
    "auto_amplitudes",
    "beam_estimate",
    "select_field",
    "cache_key",
    "atomic_write_text",
    "resolve_route",
    "closed_form",
    "DOF_NAMES",
    "LOAD_NAMES",
    "T_RANGE_M",
    "PHI_RANGE_RAD",
]
