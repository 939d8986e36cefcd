"""Checking the data of a fit before blaming the model, and the robust fit.

``check_data(res)`` runs the generic checks of ``checks`` on a fit of a
model to relative measurements (docs/calibration.md §3): a robust fit (IRLS with
Huber or Cauchy row weights around the core's weighted least squares, on
the Jacobian at the plain fit), the rows whose standardised residual is a
gross error, the configurations recorded in the wrong unit (deflections
in mm, rotations in degrees, loads in kN, joint values in degrees) with
the fix, and the configurations that are off as a whole. The rows it
lists are set aside unless there are too many of them (more than
``MAX_SET_ASIDE`` of the rows: then the misfit is the model's, not a few
bad rows). ``robust_fit`` refits the model without them.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import checks as C
from .fit import FitResult, as_inputs, fit

if TYPE_CHECKING:
    from ..robot.model import Model
    from .measure import Measurements

__all__ = ["DataChecks", "check_data", "robust_fit", "MAX_SET_ASIDE", "format_checks"]

#: at most this fraction of the rows is set aside as gross errors / unit slips
MAX_SET_ASIDE = 0.10


@dataclass
class DataChecks:
    n_rows: int
    sigma_m: float  # the position sigma the standardised residuals use
    robust_scale: float  # robust scale of the residuals, in sigma
    robust_rms_position_m: float  # RMS of the robust fit over the rows not set aside
    outliers: list[C.RowFlag] = field(default_factory=list)
    unit_slips: list[C.UnitSlip] = field(default_factory=list)
    angle_units: list[dict] = field(default_factory=list)
    configs: list[C.ConfigFlag] = field(default_factory=list)
    set_aside: list[int] = field(default_factory=list)
    too_many: bool = False
    weights: np.ndarray | None = field(default=None, repr=False)
    lines: list[int] = field(default_factory=list, repr=False)
    method: str = "huber"

    @property
    def flagged_rows(self) -> list[int]:
        rows = {f.row for f in self.outliers}
        for s in self.unit_slips:
            rows |= set(s.rows)
        for a in self.angle_units:
            rows |= set(a["rows"])
        return sorted(rows)

    @property
    def clean(self) -> bool:
        return not (self.outliers or self.unit_slips or self.angle_units)

    def line(self, row: int) -> int | None:
        return self.lines[row] if self.lines and row < len(self.lines) else None

    def to_json(self) -> dict:
        def rows_lines(rows: Iterable[int]) -> dict:
            return {"rows": list(rows), "lines": [self.line(i) for i in rows]}

        return {
            "outliers": [f.to_json(self.line(f.row)) for f in self.outliers],
            "unit_slips": [{**s.to_json(), "lines": [self.line(i) for i in s.rows]} for s in self.unit_slips],
            "angle_units": [{**a, "lines": [self.line(i) for i in a["rows"]]} for a in self.angle_units],
            "outlying_configurations": [c.to_json() for c in self.configs],
            "set_aside": rows_lines(self.set_aside),
            "too_many_to_set_aside": self.too_many,
            "robust_method": self.method,
            "robust_scale_sigma": self.robust_scale,
            "robust_rms_position_m": self.robust_rms_position_m,
            "sigma_m": self.sigma_m,
        }


def check_data(
    res: FitResult, alpha: float = 0.01, kind: str = "huber", max_fraction: float = MAX_SET_ASIDE
) -> DataChecks:
    """Data checks of a fit (see the module text)."""
    pb = res.problem
    meas = pb.meas
    n, k = meas.n, pb.rows
    A, b = res.A, res.r
    wp = float(pb.wrow[0])
    # standardise: with a declared sigma the weighted rows already are; else
    # by a robust estimate (the plain fit's sigma is inflated by gross errors)
    s_est = 1.0 if pb.sigma_declared else max(C.robust_sigma(b), 1e-300)
    sigma_m = float(pb.sigma_position) if pb.sigma_declared else s_est
    obs_rows = np.tile(np.arange(n), k)
    _, w, e, scale = C.irls(A / s_est, b / s_est, obs_rows, n, kind=kind)
    e_rows = e.reshape(k, n).T  # (n, k) in sigma
    y_rows = pb.weighted(pb.y).reshape(k, n).T / s_est
    pred_rows = y_rows - e_rows
    out = DataChecks(n_rows=n, sigma_m=sigma_m, robust_scale=scale, robust_rms_position_m=0.0, method=kind)
    out.weights = w
    out.lines = list(meas.lines)
    loads = [f"{c}|{w.tobytes().hex()}" for c, w in zip(meas.config, meas.w)]
    out.outliers = C.outlier_rows(e_rows, labels=meas.config, alpha=alpha, scale=scale, groups=loads)
    load = np.linalg.norm(meas.w[:, :3], axis=1)
    out.unit_slips = C.unit_slips(y_rows[:, :3], pred_rows[:, :3], meas.config, load=load, factors=C.LENGTH_FACTORS)
    if k == 6:
        rot = C.unit_slips(y_rows[:, 3:], pred_rows[:, 3:], meas.config, factors=C.ANGLE_FACTORS)
        for s in rot:
            s.extra["columns"] = ["rx", "ry", "rz"]
        out.unit_slips += rot
    for s in out.unit_slips:
        s.extra.setdefault(
            "columns", ["dx", "dy", "dz"] if s.quantity == "measured" else ["fx", "fy", "fz", "mx", "my", "mz"]
        )
    # rows of a slipped configuration are explained by the slip, not listed as gross errors
    slipped = {i for s in out.unit_slips for i in s.rows}
    out.outliers = [f for f in out.outliers if f.row not in slipped]
    out.angle_units = C.angle_units(meas.q, meas.config)
    flagged = out.flagged_rows
    out.configs = C.outlying_configs(e_rows, meas.config, alpha=alpha, scale=scale, skip=flagged)
    if flagged and len(flagged) <= max_fraction * n:
        out.set_aside = flagged
    elif flagged:
        out.too_many = True
    keep = np.setdiff1d(np.arange(n), out.set_aside)
    out.robust_rms_position_m = float(np.sqrt(np.mean(np.sum(e_rows[keep, :3] ** 2, axis=1)))) * s_est / wp
    return out


def robust_fit(
    model: Model | Path | str,
    meas: Measurements | Path | str,
    sigma_position: float | None = None,
    alpha: float = 0.01,
    kind: str = "huber",
) -> tuple[FitResult, DataChecks, FitResult]:
    """Fit, check the data, and refit without the rows set aside.

    Returns (FitResult on the kept rows, DataChecks, plain FitResult on
    all rows). With nothing set aside the first and the last are the same."""
    model, meas = as_inputs(model, meas)
    plain = fit(model, meas, sigma_position=sigma_position)
    dc = check_data(plain, alpha=alpha, kind=kind)
    if not dc.set_aside:
        return plain, dc, plain
    keep = np.setdiff1d(np.arange(meas.n), dc.set_aside)
    return fit(model, meas.subset(keep), sigma_position=sigma_position), dc, plain


def format_checks(dc: DataChecks, unit: float = 1e-3, limit: int = 12) -> str:
    """Sentences a user can act on; empty when the data look clean."""
    lines = []
    u = "mm" if unit == 1e-3 else "m"
    for s in dc.unit_slips:
        ln = [dc.line(i) for i in s.rows]
        where = f"lines {min(ln)}-{max(ln)}" if all(x is not None for x in ln) else f"rows {s.rows[0]}-{s.rows[-1]}"
        lines.append(
            f"unit slip: configuration {s.config} ({where}) is {s.ratio:.4g} x the model's prediction: "
            f"{', '.join(s.extra.get('columns', []))} {s.meaning}; fix: {s.fix} "
            f"(removes {100 * s.misfit_removed:.1f} % of its misfit)"
        )
    for a in dc.angle_units:
        lines.append(
            f"joint units: configuration {a['config']}: {', '.join(a['columns'])}: {a['meaning']}; fix: {a['fix']}"
        )
    if dc.outliers:
        lines.append(
            f"gross errors: {len(dc.outliers)} row(s) lie beyond the noise (Bonferroni over {dc.n_rows} rows, "
            f"robust {dc.method} fit):"
        )
        for f in dc.outliers[:limit]:
            ln = dc.line(f.row)
            lines.append(
                f"  {'line ' + str(ln) if ln is not None else 'row ' + str(f.row)}, configuration {f.config}: "
                f"{f.norm_sigma:.3g} sigma ({f.norm_sigma * dc.sigma_m / unit:.3g} {u}), log10 p = {f.log10_p:.3g}"
            )
        if len(dc.outliers) > limit:
            lines.append(f"  ... and {len(dc.outliers) - limit} more (see the JSON)")
    if dc.too_many:
        lines.append(
            f"{len(dc.flagged_rows)} rows ({100 * len(dc.flagged_rows) / dc.n_rows:.0f} %) are far from the model: "
            f"too many to be gross errors; the misfit is the model's (or sigma is too small), nothing is set aside"
        )
    elif dc.set_aside:
        lines.append(f"set aside for the rest of the analysis: {len(dc.set_aside)} row(s)")
    for c in dc.configs[:5]:
        lines.append(
            f"configuration {c.config} is off as a whole (chi2 {c.statistic:.4g} on {c.dof} dof, "
            f"log10 p = {c.log10_p:.3g}): check its posture and loads"
        )
    return "\n".join(lines)
