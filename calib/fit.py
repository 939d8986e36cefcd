"""Identification of a model's elastostatic parameters from measurements.

The observation basis of every spring comes from the core in one call
(klimchik eqs. 4-5, 12); Python combines it into the columns of the model's
parameters, and the core solves the weighted least squares by a
rank-revealing SVD (eqs. 7-9, 15-20) and partitions the parameters into
identifiable / non-identifiable / semi-identifiable groups (M4a).
Nonlinear effects (gravity compensator, point offset) are identified by the
core's Levenberg-Marquardt in one call (core/sk_deflect_fit.f90 on sk_lm and
sk_deflect: the model, its variables, the step, the damping, the acceptance
of a trial and the stopping are the core's).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._core import calib as core
from ..errors import InputError
from ..io import validate as V
from ..robot.model import JOINT_KINDS, SYM, Model, load_model
from ..robot.urdf_checks import limit_warnings
from .measure import Measurements, read_measurements
from .problem import Problem
from .results import (
    FitResult,
    error_stats,
    format_parameters,
    format_table,
    identified_model,
    model_tables_with_values,
    write_model,
)

if TYPE_CHECKING:
    import numpy.typing as npt

__all__ = [
    "fit",
    "solve_wls",
    "equilibrate",
    "coupling_relations",
    "coupling_groups",
    "as_inputs",
    "Problem",
    "FitResult",
    "error_stats",
    "identified_model",
    "format_table",
    "format_parameters",
    "model_tables_with_values",
    "write_model",
    "GROUP_NAMES",
    "NEGLIGIBLE",
    "negligible_columns",
    "RCOND",
    "GTOL",
]

GROUP_NAMES = {1: "identifiable", 2: "non-identifiable", 3: "semi-identifiable"}
RCOND = 1e-10  # singular values below RCOND * s_max are zero (unit-norm columns)
GTOL = 1e-6  # M4a: a row of V below this norm counts as zero
#: Levenberg-Marquardt of nonlinear models (core/sk_lm.f90): stop when a step
#: decreases the cost, and predicts to decrease it, by less than LM_FTOL of it
#: (a small fraction of one unit of chi2 at the sizes of calibration data;
#: tighter values only crawl along the flat valley of a compensator the data
#: hardly determine), when the scaled step is below LM_XTOL of the point, or
#: when every column is within LM_GTOL of orthogonal to the residual
LM_FTOL = 1e-4
LM_XTOL = 1e-10
LM_GTOL = 1e-10
#: a parameter whose column is this small against the best-excited parameter of
#: its kind (the data's scale) is not excited by the loads: non-identifiable
NEGLIGIBLE = 1e-6


def _block(e: int) -> str:
    a, b = SYM[e]
    return "translation" if b < 3 else ("rotation" if a >= 3 else "coupling")


def negligible_columns(pb: Problem, A: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Parameters that the loads of these data do not excite, judged
    against the data's scale, not against rounding: a joint-type parameter
    (joint, joint_profile, joint_cubic, joint_deadzone, compensator) whose
    joint's RMS torque is below NEGLIGIBLE times the largest RMS joint
    torque; a 6x6 spring element whose column is below NEGLIGIBLE times the
    largest column of the same block (translation, rotation, coupling) of
    any spring. Returns (mask (npar,), reason per parameter)."""
    npar = A.shape[1]
    mask = np.zeros(npar, bool)
    reasons = [""] * npar
    if npar == 0:
        return mask, reasons
    tau = np.sqrt(np.mean(pb.torques**2, axis=0)) if pb.meas.n else np.zeros(0)
    act = pb.model.chain.qidx > 0
    tmax = float(tau[act].max()) if np.any(act) else 0.0
    norms = np.linalg.norm(A, axis=0)
    blocks: dict[str, float] = {}
    cols = []
    for i, t in enumerate(pb.terms):
        if not t.free:
            continue
        sl = pb.layout[i]
        for k, col in enumerate(range(sl.start, sl.stop)):
            cols.append((col, t, k))
            if t.kind == "six":
                blk = _block(t.elements[k])
                blocks[blk] = max(blocks.get(blk, 0.0), norms[col])
    for col, t, k in cols:
        if t.kind in JOINT_KINDS and tmax > 0 and tau[t.joint] < NEGLIGIBLE * tmax:
            mask[col] = True
            reasons[col] = (
                f"the loads do not twist {t.target} (RMS torque {tau[t.joint]:.3g} N m against {tmax:.3g} N m "
                f"about the most loaded joint)"
            )
        elif t.kind == "six":
            blk = _block(t.elements[k])
            ref = blocks.get(blk, 0.0)
            if ref > 0 and 0 < norms[col] < NEGLIGIBLE * ref:
                mask[col] = True
                reasons[col] = (
                    f"its column is {norms[col] / ref:.2g} of the largest {blk} column: the loads do not excite it"
                )
    return mask, reasons


def equilibrate(A: np.ndarray, nonlinear: np.ndarray) -> np.ndarray:
    """Column factors that bring the columns of nonlinear parameters (whose
    units differ from compliances by many decades, e.g. k_s in N/m) to the
    largest column norm, so the core's zero-column test (relative to the
    largest column) only flags structural zeros. Returns f (npar,): solve
    with A * f, then theta = theta_f * f."""
    f = np.ones(A.shape[1])
    if A.shape[1] == 0 or not np.any(nonlinear):
        return f
    d = np.linalg.norm(A, axis=0)
    big = d.max() if d.size else 0.0
    for k in np.nonzero(nonlinear)[0]:
        if d[k] > 0 and big > 0:
            f[k] = big / d[k]
    return f


def solve_wls(
    A: np.ndarray, b: np.ndarray, rcond: float = RCOND, gtol: float = GTOL, scale: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, np.ndarray, np.ndarray]:
    """Core weighted least squares (rows already weighted); ``scale``
    multiplies the columns before the core and the solution after."""
    if A.shape[0] < A.shape[1]:
        raise InputError(
            f"{A.shape[0]} observations for {A.shape[1]} parameters: fewer rows than "
            f"parameters (add measurements or remove effects)"
        )
    f = np.ones(A.shape[1]) if scale is None else scale
    theta, stdu, s, v, rank, group, res = core.wls(A * f, b, rcond, gtol)
    return theta * f, stdu * f, s, v, rank, group, res


def coupling_relations(names: Sequence[str], v: np.ndarray, rank: int, tol: float = 1e-6) -> list[list[str]]:
    """Sparse linear relations between coupled parameters (eq. 21, core
    null_relations): each is a set of parameters of which only a combination
    is identifiable, e.g. a joint compliance and the link spring's rotation
    about the same axis."""
    n = len(names)
    if rank >= n:
        return []
    if np.shape(v) != (n, n):
        raise ValueError(f"V must be ({n}, {n}), got {np.shape(v)}")
    rel = core.null_relations(v, rank, tol)
    out = []
    for row in rel:
        members = [names[i] for i in np.nonzero(row)[0]]
        if len(members) > 1 and members not in out:
            out.append(members)
    return out


def coupling_groups(
    names: Sequence[str], v: np.ndarray, rank: int, group: np.ndarray, tol: float = 1e-6
) -> list[list[str]]:
    """M5a: semi-identifiable parameters coupled through the null space, as
    connected groups (unions of overlapping relations)."""
    rels = coupling_relations(names, v, rank, tol)
    groups: list[set] = []
    for r in rels:
        s = set(r)
        merged = [g for g in groups if g & s]
        for g in merged:
            s |= g
            groups.remove(g)
        groups.append(s)
    order = {n: i for i, n in enumerate(names)}
    return [sorted(g, key=order.get) for g in groups if len(g) > 1]


def as_inputs(model: Model | Path | str, meas: Measurements | Path | str) -> tuple[Model, Measurements]:
    """Accept paths as well as loaded objects (Python calls mirror the CLI)."""

    if isinstance(model, (str, Path)):
        model = load_model(model)
    if isinstance(meas, (str, Path)):
        meas = read_measurements(meas, model.chain.dof)
    for msg in limit_warnings(meas.q, model.chain.actuated, model.chain.limits, meas.lines, meas.path):
        V.warn(msg, key=("limits", msg))
    return model, meas


def _levenberg_marquardt(
    pb: Problem, theta: np.ndarray, neg: np.ndarray, nlmask: np.ndarray, max_iter: int
) -> tuple[np.ndarray, int, bool]:
    """The nonlinear fit from theta: the core's Levenberg-Marquardt around
    the core's rows and Jacobian, one call (core/sk_deflect_fit.f90: its
    variables, 1/c of a compensated joint and the column equilibration,
    and its restarts). Returns (theta, iterations, converged)."""
    comp = {t.joint for t in pb.terms if t.kind == "gravity_compensator"}
    inv = np.array([t.kind == "joint" and t.joint in comp for t in pb.terms if t.free for _ in t.names], dtype=bool)
    q, w, p = pb.core_rows
    theta, used, reason = core.deflection_lm(
        pb.model.chain.core_arrays(),
        pb.encoded(),
        q,
        w,
        p,
        pb.weighted(pb.y),
        pb.wrow,
        neg,
        nlmask,
        inv,
        theta,
        max_iter,
        LM_FTOL,
        LM_XTOL,
        LM_GTOL,
    )
    return theta, used, reason in core.LM_CONVERGED


def fit(
    model: Model | Path | str,
    meas: Measurements | Path | str,
    sigma_position: float | None = None,
    max_iter: int = 50,
    problem: Problem | None = None,
    theta0: npt.ArrayLike | None = None,
) -> FitResult:
    """Identify the free parameters of ``model`` from ``meas`` (docs/calibration.md §4).

    Parameters
    ----------
    model : Model or path of a model TOML
    meas : Measurements or path of a measurement CSV
    sigma_position : overrides the model's [measurements] sigma_position (m)
    max_iter : Levenberg-Marquardt iterations (nonlinear effects only)

    Returns
    -------
    FitResult : values, standard errors (NaN unless identifiable), groups,
        couplings, residuals; ``.table()``, ``.to_json()`` (contract keys).

    Linear models are solved in one weighted least-squares step; models with
    a free gravity compensator or point offset by Levenberg-Marquardt.

    Raises
    ------
    InputError : fewer observations than parameters, inconsistent inputs.
    """
    model, meas = as_inputs(model, meas)
    pb = problem or Problem(model, meas, sigma_position=sigma_position)
    npar = pb.npar
    nobs = pb.rows * meas.n
    if npar > nobs:
        raise InputError(
            f"{meas.path}: {meas.n} rows give {nobs} observations for {npar} free parameters "
            f"({', '.join(pb.names[:8])}{', ...' if npar > 8 else ''}): fewer rows than parameters"
        )
    y = pb.weighted(pb.y)
    theta = np.zeros(npar) if theta0 is None else np.array(theta0, float)
    nonlinear = any(t.free and t.nonlinear for t in pb.terms)
    nlmask = np.array([t.nonlinear for t in pb.terms if t.free for _ in t.names], dtype=bool)
    it, converged = 0, True
    pred, J = pb.evaluate(theta)
    neg, reasons = negligible_columns(pb, pb.weighted(J))

    def weigh(Jx: np.ndarray) -> np.ndarray:
        # parameters the loads do not excite get a zero column: the core
        # reports them non-identifiable (value 0, no standard error)
        Ax = pb.weighted(Jx)
        Ax[:, neg] = 0.0
        return Ax

    if npar:
        if not nonlinear:
            delta, *_ = solve_wls(weigh(J), y - pb.weighted(pred))
            theta = theta + delta
            it = 1
        else:
            theta, it, converged = _levenberg_marquardt(pb, theta, neg, nlmask, max_iter)
        pred, J = pb.evaluate(theta)
        A = weigh(J)
        b = y - pb.weighted(pred)
        eq = equilibrate(A, nlmask)
        _, stdu, s, v, rank, group, _ = solve_wls(A, b, scale=eq)
        A = A * eq  # equilibrated: for the score tests of the diagnosis
    else:
        eq = np.ones(0)
        A = np.zeros((nobs, 0))
        b = y - pb.weighted(pred)
        stdu, s, v, rank, group = np.zeros(0), np.zeros(0), np.zeros((0, 0)), 0, np.zeros(0, int)
    chi2 = float(b @ b)
    dof = nobs - rank
    if pb.sigma_declared:
        scale = 1.0
        sigma = float(pb.sigma_position)
    else:
        scale = np.sqrt(chi2 / dof) if dof > 0 else np.nan
        sigma = float(scale)
    names = pb.names
    groups = [GROUP_NAMES.get(int(g), "non-identifiable") for g in group]
    std = np.where(np.asarray(group) == 1, stdu * scale, np.nan)
    couplings = coupling_relations(names, v, rank) if npar else []
    return FitResult(
        names=names,
        values=theta,
        std=std,
        groups=groups,
        rank=rank,
        nobs=nobs,
        measured=meas.d.copy(),
        predicted=pred[0:3].T.copy(),
        chi2=chi2,
        dof=dof,
        sigma=sigma,
        sigma_declared=pb.sigma_declared,
        iterations=it,
        converged=converged,
        couplings=couplings,
        singular_values=s,
        problem=pb,
        theta=theta,
        A=A,
        r=b,
        pred6=pred,
        col_scale=eq,
        not_excited={names[k]: reasons[k] for k in np.nonzero(neg)[0]},
    )
