"""The report and the files of ``stiffkit plan`` (docs/plan.md): the chosen
postures as a CSV the robot program, ``stiffkit fit`` and ``stiffkit
compensate`` read, the report as text and as JSON."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..io.files import atomic_write_text
from .measure import DEFL, POINT, WRENCH
from .plan_weak import WEAK_EXCITATION, WEAK_VIF, excitation, task_excitation, weak_parameters  # noqa: F401 - weak_parameters: re-exported

if TYPE_CHECKING:  # calib.plan's PlanResult calls this module (its table, report, file)
    from .plan import PlanResult

__all__ = [
    "absolute_postures_rows",
    "absolute_postures_text",
    "postures_rows",
    "postures_table",
    "weak_parameters",
    "correlated_pairs",
    "postures_text",
    "write_postures",
    "plan_json",
    "plan_text",
]

#: at most this many weak parameters and correlated pairs are reported
SHOWN = 10
#: |correlation| above which two parameters are reported as a correlated pair
CORRELATED = 0.9


def correlated_pairs(res: PlanResult, limit: float = CORRELATED) -> list[tuple[str, str, float]]:
    """(a, b, correlation) of the parameter pairs whose expected estimates
    correlate beyond ``limit``, strongest first."""
    c = res.corr
    names = res.setup.names
    if not np.all(np.isfinite(c)):
        return []
    i, j = np.triu_indices(len(names), 1)
    r = c[i, j]
    order = np.argsort(-np.abs(r))
    return [(names[i[k]], names[j[k]], float(r[k])) for k in order if abs(r[k]) > limit][:SHOWN]


def _labels(res: PlanResult | int) -> list[str]:
    k = res if isinstance(res, int) else res.k
    width = max(2, len(str(k)))
    return [f"plan{i + 1:0{width}d}" for i in range(k)]


def absolute_postures_rows(Q: np.ndarray, joint_names: list[str], frames: list[str]) -> tuple[list[str], list[list]]:
    """(header, rows) of POSTURES.csv of tracker data: a row per posture and
    marker, x y z NaN (to be measured)."""
    header = ["config", *joint_names, "frame", "x", "y", "z"]
    rows = [
        [label, *map(float, q), f, math.nan, math.nan, math.nan] for label, q in zip(_labels(len(Q)), Q) for f in frames
    ]
    return header, rows


def postures_rows(res: PlanResult) -> tuple[list[str], list[list]]:
    """(header, rows) of POSTURES.csv (:func:`postures_text`): the chosen
    postures as numbers (float joint values, loads and points; the columns
    still to be measured NaN), one row per chosen posture and marker
    (tracker data) or per chosen (posture, load) and point (deflection data)."""
    s = res.setup
    if s.kind == "absolute":
        return absolute_postures_rows(s.candidates.q[s.posture[res.selected]], s.joint_names, s.model.frames)
    dof = len(s.joint_names)
    header = ["config", *[f"q{i + 1}" for i in range(dof)], *WRENCH, *POINT, *DEFL]
    rows = []
    for label, c in zip(_labels(res), res.selected):
        q = s.candidates.q[s.posture[c]]
        for p in s.points:
            rows.append([label, *map(float, q), *map(float, s.loads[c]), *map(float, p), math.nan, math.nan, math.nan])
    return header, rows


def deflection_postures_text(Q: np.ndarray, loads: np.ndarray, points: np.ndarray) -> str:
    """POSTURES.csv of deflection data for chosen (posture ``Q[i]``, load
    ``loads[i]``) pairs: a row per pair and point, dx dy dz empty."""
    header = ["config", *[f"q{i + 1}" for i in range(Q.shape[1])], *WRENCH, *POINT, *DEFL]
    rows = [
        [label, *map(float, q), *map(float, w), *map(float, p), math.nan, math.nan, math.nan]
        for label, q, w in zip(_labels(len(Q)), Q, loads)
        for p in points
    ]
    return _csv(header, rows)


def _csv(header: list[str], rows: list[list]) -> str:
    def cell(v: object) -> str:
        if isinstance(v, str):
            return v
        return "" if math.isnan(v) else _num(v)

    return "\n".join([",".join(header)] + [",".join(map(cell, r)) for r in rows]) + "\n"


def absolute_postures_text(Q: np.ndarray, joint_names: list[str], frames: list[str]) -> str:
    """POSTURES.csv of tracker data: a row per posture and marker, x y z empty."""
    return _csv(*absolute_postures_rows(Q, joint_names, frames))


def _num(v: float) -> str:
    return f"{v:.17g}"


def postures_text(res: PlanResult) -> str:
    """POSTURES.csv: one row per chosen posture and marker (tracker data:
    config, the joint names, frame, x y z left empty to be measured) or per
    chosen (posture, load) and point (deflection data: the columns of a
    measurement file, docs/calibration.md section 3, dx dy dz left empty)."""
    return _csv(*postures_rows(res))


def postures_table(res: PlanResult) -> object:
    """The table of POSTURES.csv (:func:`postures_rows`): a pandas DataFrame
    when pandas is installed, else a list of dicts (column -> value)."""
    header, rows = postures_rows(res)
    try:
        import pandas as pd
    except ImportError:
        return [dict(zip(header, r)) for r in rows]
    return pd.DataFrame(rows, columns=header)


def write_postures(path: str | Path, res: PlanResult) -> Path:
    return atomic_write_text(path, postures_text(res))


def _finite(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def plan_json(res: PlanResult) -> dict:
    """The report as a JSON document (docs/plan.md, report fields)."""
    s = res.setup
    c = s.candidates
    rv = res.random_values
    selected = []
    for label, k in zip(_labels(res), res.selected):
        row = {"config": label, "candidate": int(k), "q": dict(zip(s.joint_names, map(float, c.q[s.posture[k]])))}
        if s.loads is not None:
            row["load"] = [float(v) for v in s.loads[k]]
        selected.append(row)
    scaled = res.criterion in ("D", "A")
    return {
        "command": "plan",
        "kind": s.kind,
        "model": str(getattr(s.model, "path", "") or ""),
        "select": res.k,
        "criterion": res.criterion,
        "value": _finite(res.value),
        "value_units": "scaled parameters (columns scaled to unit information over all candidates)"
        if scaled
        else "m^2",
        "greedy_value": _finite(res.greedy_value),
        "exchange": {"passes": res.passes, "swaps": res.swaps, "start": res.start},
        "random": {
            "designs": int(rv.size),
            "seed": res.seed + 1,
            "median_value": _finite(float(np.median(rv))),
            "singular": int(np.sum(~np.isfinite(rv))),
        },
        "task": {
            "source": s.task_source,
            "postures": int(s.task_q.shape[0]),
            "points": int(s.jt.shape[0] // 3),
            "rms_position_m": _finite(res.task_rms),
            "rms_position_mm": _finite(res.task_rms * 1e3),
            "random_median_rms_position_m": _finite(res.random_task_rms),
            "random_median_rms_position_mm": _finite(res.random_task_rms * 1e3),
            "ratio": _finite(res.ratio),
            **(
                {"measured_alone_rms_position_m": _finite(res.measured_task_rms)}
                if res.measured_task_rms is not None
                else {}
            ),
            "per_posture_m": [_finite(v) for v in res.task_posture_rms],
            "random_per_posture_m": [_finite(v) for v in res.random_posture_rms],
        },
        "sigma_position_m": s.sigma,
        "sigma_source": s.sigma_source,
        "candidates": {
            "count": int(s.jc.shape[0]),
            "postures": len(c),
            "tried": int(c.tried),
            "rejected": dict(c.rejected),
            "observations_each": s.nobs,
        },
        "measured_rows": s.measured_rows,
        **({"points": s.points.tolist(), "points_source": s.points_source} if s.points is not None else {}),
        "identifiable": s.npar,
        "parameters": [
            {
                "name": n,
                "expected_std": _finite(sd),
                "variance_inflation": _finite(v),
                "excitation": _finite(e),
                "task_excitation": _finite(et),
            }
            for n, sd, v, e, et in zip(s.names, res.std, res.vif, excitation(res), task_excitation(res))
        ],
        "weak": res.weak,
        "correlated_pairs": [{"a": a, "b": b, "r": r} for a, b, r in correlated_pairs(res)],
        "not_planned": [{"name": n, "why": w} for n, w in s.not_planned],
        "selected": selected,
        "notes": list(res.notes),
        **({"discrimination": res.discrimination} if res.discrimination else {}),
    }


def _mm(v: float) -> str:
    return f"{v * 1e3:.4g} mm" if math.isfinite(v) else "inf (singular)"


def plan_text(res: PlanResult) -> str:
    """The report in words and numbers."""
    s = res.setup
    c = s.candidates
    med = float(np.median(res.random_values))
    unit = " (scaled units)" if res.criterion in ("D", "A") else " m^2"
    lines = [
        f"stiffkit plan: {res.k} of {s.jc.shape[0]} candidates ({c.summary()}), {s.kind} data, "
        f"{s.npar} identifiable parameters, {s.nobs} observations per candidate",
        f"  sigma_position {s.sigma:.3g} m ({s.sigma_source})",
    ]
    if s.points is not None:
        lines.append(f"  {len(s.points)} point(s) measured on the tool in each ({s.points_source})")
    if s.measured_rows:
        lines.append(f"  augmenting {s.measured_rows} rows already measured")
    nsing = int(np.sum(~np.isfinite(res.random_values)))
    lines += [
        f"criterion {res.criterion}: plan {res.value:.6g}{unit} (greedy {res.greedy_value:.6g}; "
        + ("" if res.start == "greedy" else f"exchange from {res.start}: ")
        + f"{res.swaps} swaps in {res.passes} passes); median of {res.random_values.size} random feasible designs "
        f"{med:.6g}" + (f" ({nsing} singular)" if nsing else ""),
        f"expected task error (RMS position over {s.jt.shape[0] // 3} points of {s.task_source}): plan "
        f"{_mm(res.task_rms)} ({res.task_rms:.4g} m), random median {_mm(res.random_task_rms)} "
        f"({res.random_task_rms:.4g} m): ratio {res.ratio:.3f}",
    ]
    if res.measured_task_rms is not None:
        lines.append(
            f"  the {s.measured_rows} rows already measured alone: {_mm(res.measured_task_rms)}"
            + (
                " (they do not identify every parameter planned for)"
                if not math.isfinite(res.measured_task_rms)
                else ""
            )
        )
    lines += [
        "expected standard deviation of each parameter:",
    ]
    width = max(len(n) for n in s.names)
    for n, sd, v, e, et in zip(s.names, res.std, res.vif, excitation(res), task_excitation(res)):
        ex = "".join(f", {what} {x:.3g}" for what, x in (("excitation", e), ("for the task", et)) if math.isfinite(x))
        lines.append(f"  {n:{width}s}  {sd:.4g}  (variance inflation {v:.3g}{ex})")
    weak = res.weak
    planned = [w for w in weak if w["source"] == "plan"]
    if planned:
        lines.append(
            "weak parameters (not identifiable, correlated: variance inflation > "
            f"{WEAK_VIF:g}, or weakly excited: excitation < {WEAK_EXCITATION:g} of the median):"
        )
        lines += [f"  {w['name']}: {w['why']}" for w in planned[:SHOWN]]
        if len(planned) > SHOWN:
            lines.append(f"  ... and {len(planned) - SHOWN} more (--json lists them all)")
    pairs = correlated_pairs(res)
    if pairs:
        lines.append(f"correlated pairs (|r| > {CORRELATED}):")
        lines += [f"  {a} ~ {b}: r = {r:+.3f}" for a, b, r in pairs]
    if s.not_planned:
        lines.append(
            f"not planned for ({len(s.not_planned)}: not identifiable at all, the fit's reduction sets them aside):"
        )
        lines += [f"  {n}: {w}" for n, w in s.not_planned[:SHOWN]]
        if len(s.not_planned) > SHOWN:
            lines.append(f"  ... and {len(s.not_planned) - SHOWN} more (--json lists them all)")
    lines += [f"note: {n}" for n in res.notes]
    return "\n".join(lines)
