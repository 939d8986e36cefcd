"""Postures and loads that tell tied candidates apart on deflection data
(``stiffkit plan --discriminate``, issue 19): the T-optimal design of
calib/plan_discriminate.py with (posture, load) candidates.

Each tied candidate effect h (its [[effect]] table or the diagnosis's label
``kind:target[:template]``) is a hypothesis: the model plus that effect,
fitted to the rows measured so far: the model's fit (``calib.fit``) plus
one Gauss-Newton step in the model's free parameters and the effect's, as
the diagnosis ranks and separates them (``diagnose_rank.separating_measurements``).
Its predictions and Jacobian are evaluated (core deflection rows) at the
measured rows and at every point of every (posture, load) candidate,
whitened by the noise sigma (declared, else the fit's estimate); the core
(``design.discriminate``) picks the k candidates that maximise the smallest
noncentrality over ordered pairs of hypotheses.
"""

from __future__ import annotations

import math

import numpy as np

from .._core import calib as core_calib
from ..errors import InputError
from ..robot.model import Model, default_tau0, expand_effect
from .diagnose_candidates import candidate_tables, effect_label
from .fit import fit
from .measure import Measurements
from .plan_discriminate import tied_effects
from .problem import Problem

__all__ = ["plan_discriminate_deflection", "deflection_effects", "hypothesis_rows"]

#: singular values of a hypothesis's Jacobian below this fraction of the largest: directions no row informs
RANK_TOL = 1e-9


def _tau0(model: Model, meas: Measurements) -> dict:
    tau = model.chain.joint_torques(meas.q, meas.w)
    return {j: default_tau0(tau[:, k]) for k, j in enumerate(model.chain.joint_names) if model.chain.qidx[k] > 0}


def deflection_effects(model: Model, meas: Measurements, tied: object) -> list[dict]:
    """The [[effect]] tables of the tied candidates on deflection data
    (calib.plan_discriminate.tied_effects among the model's candidates)."""
    return tied_effects(tied, [table for table, _hint in candidate_tables(model, _tau0(model, meas))])


def candidate_rows(q: np.ndarray, loads: np.ndarray, points: np.ndarray) -> Measurements:
    """Every (posture q[c], load loads[c]) candidate at every point (candidates major)."""
    npt, m = points.shape[0], q.shape[0]
    n = m * npt
    return Measurements(
        q=np.repeat(q, npt, axis=0),
        w=np.repeat(loads, npt, axis=0),
        p=np.tile(points, (m, 1)),
        d=np.zeros((n, 3)),
        r=None,
        config=[f"candidate {k // npt}" for k in range(n)],
        lines=list(range(2, n + 2)),
        path="candidates",
    )


def _blocks(rows6: np.ndarray, m: int, npt: int) -> np.ndarray:
    """Position rows (3, m*npt[, k]) -> (m*npt*3[, k]): each candidate's rows together."""
    r = rows6[:3]
    tail = r.shape[2:]
    return r.reshape((3, m, npt) + tail).transpose((1, 2, 0) + tuple(range(3, r.ndim + 1))).reshape((-1,) + tail)


def _hypotheses(
    model: Model, meas: Measurements, cand: Measurements, m: int, npt: int, effects: list[dict], sig: float
) -> tuple[np.ndarray, list[np.ndarray]]:
    """Whitened predictions (nrow, nh) and an orthonormal basis of each
    hypothesis's whitened Jacobian, at the measured rows then every candidate's."""
    res = fit(model, meas, sigma_position=sig)
    n0 = len(model.effects)
    f, jh = [], []
    for h, e in enumerate(effects):
        ts = expand_effect(model.chain, e, n0 + h, "candidate")
        if not any(t.free for t in ts):
            raise InputError(f"tied: {effect_label(e)} adds no parameter to the model")
        terms = list(model.terms) + ts
        layout = Problem._layout(terms)
        theta = np.concatenate([res.theta, np.zeros(sum(len(t.names) for t in ts if t.free))])
        pm = Problem(model, meas, extra_terms=ts, sigma_position=sig)
        pc = Problem(model, cand, extra_terms=ts, sigma_position=sig)
        out = [pb.evaluate(theta, terms=terms, layout=layout) for pb in (pm, pc)]
        (p0, J0), (p1, J1) = out
        r = pm.weighted(p0[: pm.rows] - pm.y)  # predicted - measured, whitened
        A = np.vstack([pm.weighted(J0), _blocks(J1, m, npt) / sig])
        pred = np.concatenate([pm.weighted(p0), _blocks(p1, m, npt) / sig])
        coef = core_calib.wls(np.asfortranarray(A[: r.size]), -r, 1e-10, 1e-6)[0]  # the fit's rank-revealing solve
        f.append(pred + A @ coef)
        U, sv, _ = np.linalg.svd(A, full_matrices=False)
        jh.append(np.ascontiguousarray(U[:, sv > RANK_TOL * sv[0]]))
    return np.ascontiguousarray(np.column_stack(f)), jh


def hypothesis_rows(
    model: Model, meas: Measurements, tied: object, q: np.ndarray, loads: np.ndarray, points: np.ndarray
) -> tuple[np.ndarray, list[np.ndarray], int, int, list[dict], float]:
    """The design problem of ``plan_discriminate_deflection``: (f (nrow, nh)
    whitened predictions, jh [orthonormal bases of the whitened Jacobians],
    n0 measured rows, nobs rows per candidate, the effects, sigma)."""
    effects = deflection_effects(model, meas, tied)
    q, loads, points = (np.asarray(a, dtype=float) for a in (q, loads, points))
    if q.ndim != 2 or q.shape[1] != model.chain.dof or loads.shape != (q.shape[0], 6) or q.shape[0] == 0:
        raise InputError(
            f"candidates: expected (m, {model.chain.dof}) postures and (m, 6) loads, got {q.shape}, {loads.shape}"
        )
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] == 0:
        raise InputError(f"points: expected an (n, 3) array of tool-frame points, got shape {points.shape}")
    sig = model.sigma_position
    if sig is None:
        sig = fit(model, meas).sigma
    if not (sig is not None and math.isfinite(sig) and sig > 0):
        raise InputError(f"{meas.path}: no noise sigma (declare sigma_position, or measure more rows than parameters)")
    npt = points.shape[0]
    f, jh = _hypotheses(model, meas, candidate_rows(q, loads, points), q.shape[0], npt, effects, float(sig))
    return f, jh, f.shape[0] - 3 * npt * q.shape[0], 3 * npt, effects, float(sig)


def plan_discriminate_deflection(
    model: Model, meas: Measurements, tied: object, q: np.ndarray, loads: np.ndarray, points: np.ndarray, k: int
) -> dict:
    """The ``k`` (posture ``q[c]``, load ``loads[c]``) candidates, each
    measured at ``points`` (tool frame, m), that best separate the tied
    effects ``tied`` after each is fitted to ``meas`` (module docstring).
    Returns {selected (k,) 0-based, value (smallest noncentrality, sigma^2
    units), pairs (nh, nh), hypotheses [labels], effects, sigma_position_m,
    rows (f, jh, n0, nobs): the design problem, for design.discrimination}."""
    from .._core import design

    f, jh, n0, nobs, effects, sig = hypothesis_rows(model, meas, tied, q, loads, points)
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise InputError(f"k must be a positive integer, got {k!r}")
    if k > (f.shape[0] - n0) // nobs:
        raise InputError(f"k = {k} exceeds the {(f.shape[0] - n0) // nobs} (posture, load) candidates")
    res = design.discriminate(f, jh, n0, nobs, int(k))
    return {
        "selected": np.asarray(res.selected, dtype=int),
        "value": float(res.value),
        "pairs": np.asarray(res.pairs, dtype=float),
        "hypotheses": [effect_label(e) for e in effects],
        "effects": effects,
        "sigma_position_m": float(sig),
        "rows": (f, jh, n0, nobs),
    }
