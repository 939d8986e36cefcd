"""Mesh-convergence studies (the paper's Table 5).

The runs themselves are tasks of the sweep machinery
(:func:`stiffkit.sweep.convergence.run_study`); this module assesses
finished runs and reports them. The error of a run is
the largest relative error of the non-zero compliance elements against the
closed form when the shape has one (eq. 22), else against a Richardson
extrapolation of the finest meshes of the same order.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io.files import atomic_write_text
from .amplitudes import closed_form
from .config import LinkJob


@dataclass
class RunRecord:
    order: int
    size: float
    nodes: int
    elements: int
    seconds: float
    memory_mb: float  # peak resident memory of the run's processes (ccx, CHOLMOD)
    compliance: np.ndarray
    significant: np.ndarray
    cached: bool
    error: float = float("nan")
    worst: str = ""
    route: str = ""


def richardson(sizes: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, float, bool]:
    """Extrapolate element-wise values (k, 6, 6) over sizes h (k,) to h -> 0
    with k(h) = k0 + C h^p. p is estimated from the three finest meshes
    (median over the diagonal elements of the ratio of successive
    differences, solved by bisection in [0.5, 8]); with two meshes, or when
    the differences do not shrink monotonically, p = 2 is assumed.
    Returns k0, p and whether p was estimated."""
    o = np.argsort(sizes)[::-1]
    h, v = np.asarray(sizes, float)[o], np.asarray(values, float)[o]
    if len(h) == 1:
        return v[0], float("nan"), False
    p, estimated = 2.0, False
    if len(h) >= 3:
        h1, h2, h3 = h[-3:]
        d12 = np.diagonal(v[-3] - v[-2])
        d23 = np.diagonal(v[-2] - v[-1])
        big = np.abs(d23) > 1e-12 * np.abs(np.diagonal(v[-1])).max()
        if big.any():
            ratio = float(np.median(d12[big] / d23[big]))
            f = lambda q: (h1**q - h2**q) / (h2**q - h3**q) - ratio  # noqa: E731
            lo, hi = 0.5, 8.0
            if ratio > 0 and f(lo) * f(hi) < 0:
                for _ in range(60):
                    mid = 0.5 * (lo + hi)
                    lo, hi = (mid, hi) if f(lo) * f(mid) > 0 else (lo, mid)
                p, estimated = 0.5 * (lo + hi), True
    ha, hb = h[-2], h[-1]
    k0 = v[-1] + (v[-1] - v[-2]) * hb**p / (ha**p - hb**p)
    return k0, p, estimated


ELEMENT_NAMES = [f"k{i + 1}{j + 1}" for i in range(6) for j in range(6)]


def _errors(records: list[RunRecord], reference: np.ndarray, nonzero: np.ndarray) -> None:
    for r in records:
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.abs(r.compliance / reference - 1.0)
        rel = np.where(nonzero, rel, 0.0)
        idx = int(np.argmax(rel))
        r.error = float(rel.flat[idx])
        r.worst = ELEMENT_NAMES[idx]


def assess(job: LinkJob, records: list[RunRecord], failed: list[dict] | None = None) -> dict:
    """The study of finished runs: each run's error against the closed form
    when the shape has one, else against a Richardson extrapolation of the
    finest meshes of its order (see the module docstring)."""
    records = sorted(records, key=lambda r: (r.order, -r.size))
    # a single-beam [approximation] is no reference: only a true closed form is
    cform = closed_form(job) if job.approximation is None else None
    refs = {}
    if cform is not None:
        _errors(records, cform, cform != 0)
        basis = "closed form (eq. 22, Euler-Bernoulli)"
    else:
        for o in sorted({r.order for r in records}):
            rs = [r for r in records if r.order == o]
            k0, p, est = richardson(np.array([r.size for r in rs]), np.array([r.compliance for r in rs]))
            finest = min(rs, key=lambda r: r.size)
            refs[o] = (k0, p, est)
            _errors(rs, k0, finest.significant)
        basis = "Richardson extrapolation of the finest meshes of each order"
    return {
        "records": records,
        "basis": basis,
        "richardson": refs,
        "units": job.units,
        "scale": job.scale,
        "failed": failed or [],
    }


def table(study: dict) -> str:
    lines = [
        f"mesh convergence: max relative error of the significant compliance elements vs {study['basis']}",
        f"{'order':>5s} {'element':>7s} {'size':>7s} {'nodes':>8s} {'error %':>9s} {'worst':>6s} "
        f"{'time s':>8s} {'mem MB':>8s} {'route':>7s}",
    ]
    for o, (_k0, p, est) in sorted(study.get("richardson", {}).items()):
        how = (
            "observed on the three finest meshes"
            if est
            else "assumed (fewer than three meshes, or differences not shrinking)"
        )
        lines.append(f"  order {o}: k(h) = k0 + C h^p with p = {p:.2f}, {how}")
    for r in study["records"]:
        lines.append(
            f"{r.order:5d} {('C3D10' if r.order == 2 else 'C3D4'):>7s} "
            f"{r.size:5g}{study['units']:>2s} {r.nodes:8d} {100 * r.error:9.4f} {r.worst:>6s} "
            f"{r.seconds:8.1f} {r.memory_mb:8.0f} {r.route:>7s}"
        )
    for f in study.get("failed", []):
        lines.append(
            f"{f['order']:5d} {('C3D10' if f['order'] == 2 else 'C3D4'):>7s} "
            f"{f['size']:5g}{study['units']:>2s}   FAILED: {f['reason']}"
        )
    return "\n".join(lines)


def to_json(study: dict) -> dict:
    return {
        "basis": study["basis"],
        "units": study["units"],
        "richardson": {
            str(o): {"p": p, "observed": est, "extrapolated_compliance": k0.tolist()}
            for o, (k0, p, est) in study.get("richardson", {}).items()
        },
        "runs": [
            {
                "order": r.order,
                "size": r.size,
                "nodes": r.nodes,
                "elements": r.elements,
                "max_relative_error": r.error,
                "worst_element": r.worst,
                "wall_time_s": r.seconds,
                "memory_mb": r.memory_mb,
                "route": r.route,
                "cached": r.cached,
                "compliance": r.compliance.tolist(),
            }
            for r in study["records"]
        ],
        "failed_runs": study.get("failed", []),
    }


def plot(study: dict, path: Path | str) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    for o in sorted({r.order for r in study["records"]}):
        rs = [r for r in study["records"] if r.order == o]
        lab = "C3D10 (order 2)" if o == 2 else "C3D4 (order 1)"
        a1.loglog([r.size for r in rs], [100 * max(r.error, 1e-12) for r in rs], "o-", label=lab)
        a2.loglog([r.size for r in rs], [r.seconds for r in rs], "o-", label=lab)
    a1.set_xlabel(f"element size, {study['units']}")
    a1.set_ylabel("max error, %")
    a1.set_title("error of the compliance")
    a2.set_xlabel(f"element size, {study['units']}")
    a2.set_ylabel("wall time, s")
    a2.set_title("time per run")
    for a in (a1, a2):
        a.invert_xaxis()
        a.grid(True, which="both", alpha=0.3)
        a.legend()
    fig.tight_layout()
    tmp = path.with_name(path.name + ".tmp.png")
    fig.savefig(tmp, dpi=90, format="png")
    plt.close(fig)
    tmp.replace(path)
    return path


__all__ = ["RunRecord", "assess", "table", "to_json", "plot", "richardson", "atomic_write_text"]
