"""The result of a fit: identified parameters with their groups and
standard errors, residuals, the klimchik Table 2 statistics, and the
identified model written back as a model file (docs/calibration.md §4, §5)."""

from __future__ import annotations

import copy
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import tomli_w

from ..robot.model import JOINT_KINDS, SYM, Model
from ..robot.model_file import effects_toml
from .problem import Problem

__all__ = [
    "FitResult",
    "error_stats",
    "identified_model",
    "format_table",
    "format_parameters",
    "model_tables_with_values",
    "write_model",
]


@dataclass
class FitResult:
    """Identified parameters, their groups and the residuals."""

    names: list[str]
    values: np.ndarray
    std: np.ndarray  # NaN where the parameter is not identifiable
    groups: list[str]
    rank: int
    nobs: int
    measured: np.ndarray  # (n, 3) measured point deflections
    predicted: np.ndarray  # (n, 3)
    chi2: float  # weighted residual sum of squares
    dof: int
    sigma: float  # sigma used for the standard errors
    sigma_declared: bool
    iterations: int
    converged: bool
    couplings: list[list[str]]
    singular_values: np.ndarray
    problem: Problem = field(repr=False)
    theta: np.ndarray = field(repr=False)
    A: np.ndarray = field(repr=False)  # weighted Jacobian at the solution
    r: np.ndarray = field(repr=False)  # weighted residual
    pred6: np.ndarray = field(repr=False)
    col_scale: np.ndarray | None = field(default=None, repr=False)  # A = weighted Jacobian * col_scale
    not_excited: dict = field(default_factory=dict)  # parameter -> why the data do not inform it

    @property
    def residuals(self) -> np.ndarray:
        return self.measured - self.predicted

    @property
    def model(self) -> Model:
        return self.problem.model

    def table(self) -> dict:
        """Residual statistics as in klimchik Table 2 (before / after)."""
        return {"before": error_stats(self.measured), "after": error_stats(self.residuals)}

    @property
    def rms_position(self) -> float:
        return error_stats(self.residuals)["rms_position_m"]

    @property
    def compensated_fraction(self) -> float:
        before = error_stats(self.measured)["rms_position_m"]
        return 1.0 - self.rms_position / before if before > 0 else 0.0

    def parameter(self, name: str) -> float:
        return float(self.values[self.names.index(name)])

    def to_json(self) -> dict:
        after = error_stats(self.residuals)
        out = {
            "rms_position_m": after["rms_position_m"],
            "max_position_m": after["max_position_m"],
            "axes": after["axes"],
            "compensated_fraction": self.compensated_fraction,
            "parameters": [
                {"name": n, "value": float(v), "std": None if not np.isfinite(s) else float(s), "group": g}
                | ({"reason": self.not_excited[n]} if n in self.not_excited else {})
                for n, v, s, g in zip(self.names, self.values, self.std, self.groups)
            ],
            # extensions
            "before": error_stats(self.measured),
            "rank": self.rank,
            "n_parameters": len(self.names),
            "n_rows": int(self.measured.shape[0]),
            "n_observations": self.nobs,
            "chi2": self.chi2,
            "dof": self.dof,
            "sigma_m": self.sigma if np.isfinite(self.sigma) else None,
            "sigma_declared": self.sigma_declared,
            "iterations": self.iterations,
            "converged": self.converged,
            "couplings": self.couplings,
            "model": str(self.model.path) if self.model.path else None,
            "measurements": self.problem.meas.path,
        }
        return out


def error_stats(e: np.ndarray) -> dict:
    """MAX and RMS per axis and positional of (n, 3) errors (Table 2)."""
    e = np.asarray(e, float)
    norm = np.linalg.norm(e, axis=1)
    axes = {
        ax: {"rms_m": float(np.sqrt(np.mean(e[:, i] ** 2))), "max_m": float(np.abs(e[:, i]).max())}
        for i, ax in enumerate("xyz")
    }
    return {"rms_position_m": float(np.sqrt(np.mean(norm**2))), "max_position_m": float(norm.max()), "axes": axes}


def identified_model(res: FitResult) -> Model:
    """The model with every free parameter set to its identified value."""
    m = copy.copy(res.model)
    terms = []
    for i, t in enumerate(res.problem.terms):
        t2 = copy.copy(t)
        if t.free:
            t2.value = res.theta[res.problem.layout[i]].copy()
        terms.append(t2)
    m.terms = terms
    return m


def format_table(res: FitResult, unit: float = 1e-3, label: str = "") -> str:
    """Residual table like klimchik Table 2, in mm."""
    before, after = res.table()["before"], res.table()["after"]
    if unit < 1.0 and max(before["max_position_m"], after["max_position_m"]) / unit >= 999.0:
        unit = 1.0  # metres of deflection (a unit slip): keep the columns readable
    u = "mm" if unit == 1e-3 else "um" if unit == 1e-6 else "m"
    head = f"{'':34s}{'x':>15s}{'y':>15s}{'z':>15s}{'positional':>15s}\n{'errors, ' + u:34s}" + "".join(
        f"{'MAX':>7s}{'RMS':>8s}" for _ in range(4)
    )

    def row(name: str, st: dict) -> str:
        cells = [(st["axes"][a]["max_m"], st["axes"][a]["rms_m"]) for a in "xyz"]
        cells.append((st["max_position_m"], st["rms_position_m"]))
        return f"{name:34s}" + "".join(f"{m / unit:7.3f}{r / unit:8.3f}" for m, r in cells)

    lines = [
        head,
        row("deflections without compensation", before),
        row(f"after compensation{(' (' + label + ')') if label else ''}"[:33], after),
        f"compensated fraction {100 * res.compensated_fraction:.1f} %   "
        f"({res.problem.meas.n} rows, {len(res.names)} parameters, rank {res.rank})",
    ]
    return "\n".join(lines)


def format_parameters(res: FitResult) -> str:
    lines = [f"{'parameter':24s}{'value':>14s}{'std':>12s}  group"]
    for n, v, s, g in zip(res.names, res.values, res.std, res.groups):
        sd = f"{s:12.3e}" if np.isfinite(s) else f"{'-':>12s}"
        lines.append(f"{n:24s}{v:14.5e}{sd}  {g}")
    counts = {g: res.groups.count(g) for g in ("identifiable", "semi-identifiable", "non-identifiable")}
    lines.append(
        f"groups: {counts['identifiable']} identifiable (G1), {counts['semi-identifiable']} "
        f"semi-identifiable (G3), {counts['non-identifiable']} non-identifiable (G2); rank {res.rank}"
    )
    for c in res.couplings:
        lines.append(f"coupled (only their combination is identifiable): {', '.join(c)}")
    for n, why in res.not_excited.items():
        lines.append(f"not identified (value 0 is a placeholder): {n}: {why}")
    return "\n".join(lines)


def model_tables_with_values(res: FitResult) -> list[dict]:
    """The model's [[effect]] tables with every identified value (docs/calibration.md §5)."""
    model = identified_model(res)
    out = []
    for i, table in enumerate(model.effects):
        terms = [t for t in model.terms if t.effect == i]
        for t in terms:
            tab = {k: v for k, v in table.items() if k not in ("value", "k_s", "r")}
            if t.kind in JOINT_KINDS:
                tab["target"] = t.target
            unknown = [n for n in t.names if n in res.not_excited]
            if unknown:
                tab["note"] = "not identified by the data (the loads do not excite it): " + ", ".join(unknown)
            if t.kind in ("joint", "joint_cubic", "joint_deadzone"):
                tab["value"] = float(t.value[0])
                if t.kind == "joint_deadzone":
                    tab["tau0"] = res.problem.tau0(t)
            elif t.kind == "joint_profile":
                tab["value"] = [float(v) for v in t.value]
            elif t.kind == "gravity_compensator":
                tab["k_s"] = float(t.value[0])
            elif t.kind == "point_offset":
                tab["r"] = [float(v) for v in t.value]
            else:
                C = np.zeros((6, 6))
                for e, v in zip(t.elements, t.value):
                    a, b = SYM[e]
                    C[a, b] = C[b, a] = float(v)
                tab["value"] = C.tolist()
                tab.pop("rpy", None)
            out.append(tab)
    return out


def write_model(res: FitResult, path: Path | str) -> None:
    """Write the identified model (URDF reference, sigma, effects with values)."""
    path = Path(path)
    model = res.model
    robot = (
        dict(model.robot_table)
        if model.robot_table
        else {"base_link": model.chain.base_link, "tool_frame": model.chain.tool_frame}
    )
    urdf = Path(model.chain.urdf).resolve()
    try:
        robot["urdf"] = os.path.relpath(urdf, path.resolve().parent)
    except ValueError:
        robot["urdf"] = str(urdf)
    doc = {"robot": robot}
    meas = {}
    if model.sigma_position is not None:
        meas["sigma_position"] = model.sigma_position
    if model.sigma_rotation is not None:
        meas["sigma_rotation"] = model.sigma_rotation
    if meas:
        doc["measurements"] = meas
    head = (
        f"# identified by stiffkit fit from {res.problem.meas.path}: positional RMS "
        f"{res.rms_position:.4g} m, rank {res.rank} of {len(res.names)} parameters\n"
        f"# non-identifiable and semi-identifiable parameters hold the minimum-norm solution\n"
    )
    path.write_text(head + tomli_w.dumps(doc) + effects_toml(model_tables_with_values(res)))
