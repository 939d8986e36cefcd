"""``[mesh] accuracy``: refine until the compliance is as accurate as asked.

Level k meshes the part with every element size scaled by h_k (the nominal
size, the walls' ``t / across`` and the holes' ``2 pi r / around``): h_k =
n_0 / n_k with n_k = round(n_0 r^k) elements across the thinnest wall (so a
structured prism's section divides exactly), r = :data:`RATIO`. After each
level from the second on, the compliance of the meshes is extrapolated to
h -> 0 (:func:`stiffkit.fea.convergence.richardson`: k(h) = k0 + C h^p, p
observed on the three finest meshes, else 2); the estimate of the finest
mesh's error is the largest relative difference from k0 over its
significant elements that are not near zero (:data:`NONZERO`). The loop stops when the estimate is at most the
target, and with a clear message before a mesh would exceed ``max_nodes``
(the memory limit) or after :data:`MAX_LEVELS` meshes.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..errors import InputError
from .config import LinkJob
from .convergence import richardson
from .meshkeys import node_memory_gb

#: element sizes shrink by this factor from one level to the next
RATIO = 4.0 / 3.0
#: meshes the loop makes at most
MAX_LEVELS = 8
#: the elements the estimate is taken over: significant and at least this
#: fraction of the geometric mean of their two diagonal elements (a coupling
#: the fit resolves at 2e-4 of it, e.g. ty under Fx on the paper's beam, is
#: mesh noise around zero: its relative change says nothing of the accuracy)
NONZERO = 1e-2


class AccuracyError(InputError):
    """The accuracy asked for cannot be reached within the limits."""


def level_job(job: LinkJob, k: int) -> tuple[LinkJob, float]:
    """(the job of level k, its size scale h_k) (module docstring)."""
    n0 = job.across
    nk = max(n0, round(n0 * RATIO**k))
    h = n0 / nk
    lj = copy.deepcopy(job)
    lj.accuracy = None
    lj.size = job.size * h
    lj.across = nk
    lj.around = job.around / h
    return lj, h


def estimate_error(hs: list[float], comps: list[np.ndarray], significant: np.ndarray) -> tuple[float, float, bool, str]:
    """(estimated relative error of the finest compliance, p, p observed?,
    the element it is largest on) from the Richardson extrapolation."""
    k0, p, observed = richardson(np.array(hs), np.array(comps))
    fine = comps[int(np.argmin(hs))]
    scale = np.sqrt(np.outer(np.abs(np.diag(k0)), np.abs(np.diag(k0))))
    keep = significant & (np.abs(k0) >= NONZERO * scale)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(keep, np.abs(fine / k0 - 1.0), 0.0)
    i = int(np.argmax(rel))
    return float(rel.flat[i]), float(p), bool(observed), f"k{i // 6 + 1}{i % 6 + 1}"


def run_to_accuracy(
    job: LinkJob,
    run: Callable[..., object],
    cache_dir: Path | str | None = None,
    route: str | None = None,
    progress: Callable[[str], None] | None = None,
    workdir: Path | str | None = None,
) -> object:
    """Run the levels of ``job`` (``job.accuracy`` set) with ``run`` (the
    single-mesh :func:`stiffkit.fea.job.run_link`) until the estimate is at
    most ``job.accuracy``; the finest run's result, its ``accuracy`` the
    levels and the estimate."""
    say = progress or (lambda msg: None)
    target = float(job.accuracy)
    levels: list[dict] = []
    hs: list[float] = []
    comps: list[np.ndarray] = []
    est = None
    for k in range(MAX_LEVELS):
        lj, h = level_job(job, k)
        if levels:
            need = levels[-1]["nodes"] * (hs[-1] / h) ** 3
            if need > job.max_nodes:
                raise AccuracyError(_stop_text(job, levels, est, f"the next mesh would need about {need:.3g} nodes"))
        say(f"accuracy level {k + 1}: size {lj.size:.4g} {job.units}, {lj.across} across the thinnest wall")
        res = run(lj, cache_dir=cache_dir, route=route, progress=progress, workdir=workdir)
        hs.append(h)
        comps.append(np.array(res.compliance.matrix))
        levels.append(
            {
                "level": k + 1,
                "scale": h,
                "size": lj.size,
                "across": lj.across,
                "nodes": res.mesh.n_nodes,
                "elements": res.mesh.n_elements,
                "seconds": float(sum(res.timing.values())),
            }
        )
        if len(levels) >= 2:
            err, p, observed, worst = estimate_error(hs, comps, res.compliance.significant)
            est = {"estimate": err, "p": p, "p_observed": observed, "worst": worst}
            levels[-1]["estimate"] = err
            say(f"accuracy: estimated error {100 * err:.3g} % ({worst}, p = {p:.2f}), target {100 * target:g} %")
            if err <= target:
                res.accuracy = {"target": target, **est, "levels": levels, "basis": "Richardson extrapolation"}
                return res
    raise AccuracyError(_stop_text(job, levels, est, f"{MAX_LEVELS} meshes were made"))


def _stop_text(job: LinkJob, levels: list[dict], est: dict | None, why: str) -> str:
    where = f"{job.source}: [mesh] accuracy = {job.accuracy:g}"
    reached = (
        f"the estimated error is {100 * est['estimate']:.3g} % ({est['worst']}) after {len(levels)} meshes"
        if est
        else f"no estimate after {len(levels)} mesh(es)"
    )
    return (
        f"{where} not reached: {reached} (finest {levels[-1]['nodes']} nodes, size {levels[-1]['size']:.4g} "
        f"{job.units}); {why}, above the memory limit [mesh] max_nodes = {job.max_nodes} "
        f"(about {node_memory_gb(job.max_nodes):.1f} GB): raise max_nodes, start from a finer size, or ask for "
        "a looser accuracy"
        if "nodes" in why
        else f"{where} not reached: {reached}; {why}: start from a finer size or ask for a looser accuracy"
    )
