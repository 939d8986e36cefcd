"""The result of a fit: identified parameters with their groups and
standard errors, residuals, the klimchik Table 2 statistics, and the
identified model written back as a model file (docs/calibration.md §4, §5)."""

from __future__ import annotations

import copy
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..io.files import atomic_write_text
from ..robot import catalogue
from ..robot.model import JOINT_KINDS, SYM, Model, model_from_tables
from ..robot.model_file import model_text
from .problem import Problem

__all__ = [
    "FitResult",
    "error_stats",
    "identified_model",
    "format_table",
    "format_parameters",
    "model_tables_with_values",
    "written_tables",
    "written_model",
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


def format_table(res: FitResult, unit: float = 1e-3, label: str = "", footer: str | None = None) -> str:
    """Residual table like klimchik Table 2, in mm; ``footer`` replaces the
    last line (compensated fraction, rows, parameters, rank)."""
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
        footer
        if footer is not None
        else f"compensated fraction {100 * res.compensated_fraction:.1f} %   "
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


def _psd(C: np.ndarray) -> np.ndarray | None:
    """The nearest positive semi-definite matrix (eigenvalues below 0 set to
    0) when C fails the model reader's test, else None."""
    from .._core.springs import psd_defect

    dmin, tol = psd_defect(C)
    if not dmin[0] < -tol:
        return None
    w, V = np.linalg.eigh(C)
    P = (V * np.maximum(w, 0.0)) @ V.T
    return 0.5 * (P + P.T)


def written_tables(res: FitResult) -> tuple[list[dict], list[str]]:
    """The model's [[effect]] tables with the values ``write_model`` writes
    (docs/calibration.md §5), and notes on the values that differ from the fit's.

    The values are the fitted ones, made to satisfy the model reader's own
    rules (docs/calibration.md section 5): a non-identifiable parameter
    (the data do not depend on it; the fit's value is a placeholder, the
    minimum-norm solution or round-off such as -7.7e-13) is written as 0; a
    compliance or compensator stiffness fitted below 0 is written as 0 (a
    spring cannot be negative); a 6x6 spring that is not positive
    semi-definite is written as the nearest one that is. Each such table
    carries a ``note`` naming its parameters and what was done, so the file
    says which of its numbers the data did not determine."""
    model = identified_model(res)
    group = dict(zip(res.names, res.groups))
    sd = dict(zip(res.names, res.std))
    out: list[dict] = []
    notes: list[str] = []

    def below_zero(name: str, v: float) -> str:
        e = float(sd.get(name, np.nan))
        pm = f" +- {e:.2g}" if np.isfinite(e) else ""
        near = " (within 2 standard errors of 0)" if np.isfinite(e) and -v <= 2 * e else ""
        return f"{name} fitted {v:.4g}{pm} ({group.get(name, 'known')}) < 0, written as 0{near}"

    for i, table in enumerate(model.effects):
        terms = [t for t in model.terms if t.effect == i]
        for t in terms:
            tab = {k: v for k, v in table.items() if k not in ("value", "k_s", "r", "note")}
            if t.kind in JOINT_KINDS:
                tab["target"] = t.target
            val = np.array(t.value, float)
            said: list[str] = []
            unknown = [n for n in t.names if n in res.not_excited or group.get(n) == "non-identifiable"]
            for k, n in enumerate(t.names):
                if n in unknown:
                    val[k] = 0.0
            if unknown:
                said.append(
                    "not identified by the data (nothing in them depends on it; written as 0): " + ", ".join(unknown)
                )
            semi = [n for n in t.names if group.get(n) == "semi-identifiable"]
            if semi:
                said.append(
                    "semi-identifiable (only a combination with the coupled parameters is determined; the value is "
                    "the minimum-norm one): " + ", ".join(semi)
                )
            if t.kind in ("joint", "gravity_compensator") and val[0] < 0:
                said.append(below_zero(t.names[0], float(val[0])) + ": a spring is >= 0")
                notes.append(said[-1])
                val[0] = 0.0
            if t.kind in catalogue.KIND:  # the key(s) the reader takes the values from (robot/catalogue.py)
                tab.update(catalogue.value_table(t.kind, val))
                if catalogue.KIND[t.kind].w0_key:
                    tab[catalogue.KIND[t.kind].w0_key] = res.problem.tau0(t)
            else:  # a 6x6 spring (link, base, tool)
                C = np.zeros((6, 6))
                for e, v in zip(t.elements, val):
                    a, b = SYM[e]
                    C[a, b] = C[b, a] = float(v)
                P = _psd(C)
                if P is not None:
                    low = float(np.linalg.eigvalsh(C)[0])
                    said.append(
                        f"{t.target} spring fitted with a negative eigenvalue ({low:.3g}): written as the nearest "
                        "positive semi-definite matrix (a spring cannot return energy)"
                    )
                    notes.append(said[-1])
                    C = P
                tab["value"] = C.tolist()
                tab.pop("rpy", None)
            if said:
                tab["note"] = "; ".join(said)
            out.append(tab)
    return out, notes


def model_tables_with_values(res: FitResult) -> list[dict]:
    """The model's [[effect]] tables with every identified value (docs/calibration.md §5;
    the values of ``written_tables``)."""
    return written_tables(res)[0]


def written_model(res: FitResult) -> Model:
    """The model ``write_model`` writes, as a Model (what ``stiffkit
    evaluate`` reads back from the file): the chain with the written tables."""
    m = res.model
    model = model_from_tables(
        m.chain, written_tables(res)[0], sigma_position=m.sigma_position, sigma_rotation=m.sigma_rotation
    )
    model.path = m.path
    return model


def write_model(res: FitResult, path: Path | str) -> list[str]:
    """Write the identified model (URDF reference, sigma, effects with
    values; ``written_tables``); returns the notes on values written
    otherwise than fitted."""
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
    tables, notes = written_tables(res)
    head = (
        f"# identified by stiffkit fit from {res.problem.meas.path}: positional RMS "
        f"{res.rms_position:.4g} m, rank {res.rank} of {len(res.names)} parameters\n"
        f"# semi-identifiable parameters hold the minimum-norm solution; non-identifiable ones 0 (see the notes)\n"
    )
    # the [plan] table as read (stiffkit plan)
    text = model_text(tables, robot, None, model.sigma_position, model.sigma_rotation, plan=model.plan, header=head)
    atomic_write_text(path, text)
    return notes
