"""Identification of a model's elastostatic parameters from measurements.

The observation basis of every spring comes from the core in one call
(klimchik eqs. 4-5, 12); Python combines it into the columns of the model's
parameters, and the core solves the weighted least squares by a
rank-revealing SVD (eqs. 7-9, 15-20) and partitions the parameters into
identifiable / non-identifiable / semi-identifiable groups (M4a).
Nonlinear effects (gravity compensator, point offset) are identified by
Levenberg-Marquardt on top of the same linear solver.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._core import calib as core
from ..errors import InputError
from ..robot.model import JOINT_KINDS, SYM, Model, load_model
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
#: a parameter whose column is this small against the best-excited parameter of
#: its kind (the data's scale) is not excited by the loads: non-identifiable
NEGLIGIBLE = 1e-6


def _block(e: int) -> str:
    a, b = SYM[e]
    return "translation" if b < 3 else ("rotation" if a >= 3 else "coupling")


def negligible_columns(pb: Problem, A) -> tuple[np.ndarray, list[str]]:
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


def equilibrate(A, nonlinear):
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


def solve_wls(A, b, rcond=RCOND, gtol=GTOL, scale=None):
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


def coupling_relations(names, v, rank, tol=1e-6) -> list[list[str]]:
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


def coupling_groups(names, v, rank, group, tol=1e-6) -> list[list[str]]:
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


def as_inputs(model, meas):
    """Accept paths as well as loaded objects (Python calls mirror the CLI)."""

    if isinstance(model, (str, Path)):
        model = load_model(model)
    if isinstance(meas, (str, Path)):
        meas = read_measurements(meas, model.chain.dof)
    return model, meas


def fit(
    model: Model,
    meas: Measurements,
    sigma_position=None,
    max_iter: int = 50,
    problem: Problem | None = None,
    theta0=None,
) -> FitResult:
    """Identify the free parameters of ``model`` from ``meas`` (contract s4).

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
    lam, it, converged = 0.0, 0, True
    pred, J = pb.evaluate(theta)
    neg, reasons = negligible_columns(pb, pb.weighted(J))

    def weigh(Jx):
        # parameters the loads do not excite get a zero column: the core
        # reports them non-identifiable (value 0, no standard error)
        Ax = pb.weighted(Jx)
        Ax[:, neg] = 0.0
        return Ax

    if npar:
        A = weigh(J)
        b = y - pb.weighted(pred)
        cost = float(b @ b)
        if not nonlinear:
            delta, *_ = solve_wls(A, b)
            theta = theta + delta
            it = 1
        else:
            # compensated joints: iterate on their stiffness 1/c, in which
            # c_eff = 1 / (1/c + k_s h(q)) has a straight valley, not a curved one
            comp = {t.joint for t in pb.terms if t.kind == "gravity_compensator"}
            inv = np.array(
                [t.kind == "joint" and t.joint in comp for t in pb.terms if t.free for _ in t.names], dtype=bool
            )
            converged = False
            for it in range(1, max_iter + 1):
                use = inv & (theta > 0) if it > 1 else np.zeros(npar, bool)
                Az = A.copy()
                Az[:, use] = A[:, use] * (-(theta[use] ** 2))  # d/d(1/c) = -c^2 d/dc
                if lam > 0:
                    d = np.linalg.norm(Az, axis=0)
                    Aa = np.vstack([Az, np.sqrt(lam) * np.diag(d)])
                    ba = np.concatenate([b, np.zeros(npar)])
                else:
                    Aa, ba = Az, b
                dz, *_ = solve_wls(Aa, ba, scale=equilibrate(Az, nlmask | use))
                trial = theta + dz
                zc = 1.0 / theta[use] + dz[use]
                trial[use] = np.where(zc > 0, 1.0 / np.where(zc > 0, zc, 1.0), theta[use] * 10.0)
                delta = trial - theta
                p2, J2 = pb.evaluate(trial)
                b2 = y - pb.weighted(p2)
                c2 = float(b2 @ b2)
                if c2 <= cost:
                    # a relative decrease below 1e-4 is far below one unit of chi2
                    # at any noise level: stop (the noise-free case converges
                    # quadratically down to round-off first)
                    small = cost - c2 <= 1e-4 * cost + 1e-300 or np.all(
                        np.abs(delta) <= 1e-10 * (np.abs(trial) + 1e-300)
                    )
                    theta, pred, J, b, cost = trial, p2, J2, b2, c2
                    A = weigh(J)
                    lam = lam / 10.0 if lam > 1e-12 else 0.0
                    if small:
                        converged = True
                        break
                else:
                    lam = max(lam * 10.0, 1e-6)
                    if lam > 1e12:
                        converged = True  # no further decrease possible
                        break
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
