"""Postures that tell tied candidates apart (``stiffkit plan --discriminate``,
issue 19): a T-optimal design on absolute (tracker) data.

Each tied candidate effect h (as the diagnosis reports it: its [[effect]]
table or its label ``kind:target``) is a hypothesis: the model extended
with that effect (``absolute_candidates.extended_model``) fitted to the
data so far: the model's fit (``fit_absolute``) plus the effect, one
Gauss-Newton step with the model's identified parameters, as the diagnosis
ranks them. At the existing rows and at every marker point of every
candidate posture, each hypothesis's prediction and the Jacobian of its
parameters are evaluated, whitened by the noise sigma (declared, else the
model's residual estimate).
The core (``design.discriminate``) then picks the k candidates that
maximise the smallest noncentrality over ordered pairs (a, b): how far a's
predictions lie from anything b can fit, relative to the noise.
"""

from __future__ import annotations

import math

import numpy as np

from .._core import calib as core_calib
from ..errors import InputError
from ..robot.tree_model import TreeModel
from .absolute_candidates import absolute_candidates, extended_model, params_of
from .absolute_data import AbsoluteData
from .absolute_fit import AbsoluteFit, fit_absolute, predict
from .diagnose_candidates import effect_label

__all__ = ["plan_discriminate", "hypothesis_effects"]

#: singular values of a hypothesis's Jacobian below this fraction of the largest: directions no row informs
RANK_TOL = 1e-9


def hypothesis_effects(model: TreeModel, tied: object) -> list[dict]:
    """The [[effect]] tables of the tied candidates on tracker data
    (:func:`tied_effects` among the model's absolute candidates)."""
    return tied_effects(tied, absolute_candidates(model))


def tied_effects(tied: object, lacking: list[dict]) -> list[dict]:
    """The [[effect]] tables of the tied candidates, for both data kinds:
    ``tied`` is a tie as the diagnosis reports it (a dict with
    ``candidates``), or a list of labels ``kind:target[:template]`` and/or
    effect tables; a label is looked up among ``lacking`` (the candidate
    tables of the model's data kind)."""
    items = tied.get("candidates") if isinstance(tied, dict) else tied
    if not isinstance(items, (list, tuple)) or len(items) < 2:
        raise InputError(f"tied: needs at least 2 candidate effects to tell apart, got {items!r}")
    catalogue = {}
    for c in lacking:  # the label with and without a spring's template
        catalogue.setdefault(f"{c['kind']}:{c.get('target', c['kind'])}", c)
        catalogue[effect_label(c)] = c
    out = []
    for i, it in enumerate(items):
        if isinstance(it, dict) and "kind" in it:
            out.append(dict(it))
        elif isinstance(it, str) and it in catalogue:
            out.append(dict(catalogue[it]))
        else:
            raise InputError(
                f"tied[{i}]: {it!r} is neither an [[effect]] table nor a candidate the model lacks "
                f"(labels kind:target[:template], e.g. {next(iter(catalogue), 'link:LINK')})"
            )
    names = [effect_label(e) for e in out]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"tied: {', '.join(dup)} given twice")
    return out


def _postures(data: AbsoluteData, Q: object) -> np.ndarray:
    """Candidate postures (m, nq) in the data's joint order: an array in
    that order, or an object with ``q`` and ``joint_names`` (plan_candidates.Candidates)."""
    if hasattr(Q, "q") and hasattr(Q, "joint_names"):
        names = list(Q.joint_names)
        missing = [j for j in data.joints if j not in names]
        if missing:
            raise InputError(f"candidates: joint(s) {', '.join(missing)} of the data missing")
        q = np.asarray(Q.q, dtype=float)[:, [names.index(j) for j in data.joints]]
    else:
        q = np.asarray(Q, dtype=float)
    if q.ndim != 2 or q.shape[1] != len(data.joints):
        raise InputError(f"candidates: expected an (m, {len(data.joints)}) array of postures, got shape {q.shape}")
    if q.shape[0] == 0:
        raise InputError("candidates: no candidate posture")
    bad = np.argwhere(~np.isfinite(q))
    if bad.size:
        raise InputError(f"candidates: posture {bad[0, 0]}, joint {data.joints[bad[0, 1]]}: not finite")
    return q


def _all_rows(data: AbsoluteData, q: np.ndarray) -> AbsoluteData:
    """The data's rows (measured points set to 0: predictions only), then
    every frame of the data at every candidate posture (weight 1)."""
    m, nf, npo = q.shape[0], len(data.frames), data.n_postures
    return AbsoluteData(
        path="candidates",
        joints=data.joints,
        configs=list(data.configs) + [f"candidate {c}" for c in range(m)],
        Q=np.vstack([data.Q, q]),
        posture=np.concatenate([data.posture, npo + np.repeat(np.arange(m), nf)]),
        frame=np.concatenate([data.frame, np.tile(np.arange(nf), m)]),
        frames=data.frames,
        xyz=np.zeros((data.n + m * nf, 3)),
        weight=np.concatenate([data.weight, np.ones(m * nf)]),
        lines=np.concatenate([data.lines, np.zeros(m * nf, int)]),
        payloads=list(data.payloads),
    )


def _hypotheses(
    fit: AbsoluteFit, data: AbsoluteData, q: np.ndarray, effects: list[dict], sig: float
) -> tuple[np.ndarray, list[np.ndarray]]:
    """Whitened predictions (nrow, nh) of each hypothesis and an orthonormal
    basis (nrow, rank) of its whitened Jacobian, at the data's rows then
    every candidate's: the model's fit plus the effect, one Gauss-Newton
    step from the fit with the effect at zero (the linearisation the
    diagnosis ranks by; a nonlinear fit of a tied effect can wander along the
    direction the data leave free). The basis spans the same columns as the
    Jacobian (the same projector), without its near-dependent directions."""
    m = fit.model
    ext = extended_model(m, effects)
    th = ext.theta0.copy()
    for i, name in enumerate(ext.names):
        if name in m.names:
            th[i] = fit.theta[m.index(name)]
    base = [ext.index(m.names[i]) for i in fit.reduction.kept]
    own = [[i for i in params_of(ext, e) if ext.names[i] not in m.names] for e in effects]
    cols = np.unique(np.concatenate([base] + own)).astype(int)
    rows = _all_rows(data, q)
    ev = predict(ext, rows, th, cols, rows.weight)
    where = {c: j for j, c in enumerate(cols)}
    J = np.asarray(ev["jac"], dtype=float) / sig
    pred = np.asarray(ev["res"], dtype=float) / sig  # weighted predictions (the points are 0)
    n0 = 3 * data.n
    r = np.asarray(predict(m, data, fit.theta, None, fit.weight)["res"], dtype=float) / sig  # predicted - measured
    f, jh = [], []
    for h, e in enumerate(effects):
        if not own[h]:
            raise InputError(f"tied: {effect_label(e)} adds no parameter to the model")
        Jh = J[:, [where[c] for c in base + own[h]]]
        coef = core_calib.wls(np.asfortranarray(Jh[:n0]), -r, 1e-10, 1e-6)[0]  # the fit's rank-revealing solve
        f.append(pred + Jh @ coef)
        U, sv, _ = np.linalg.svd(Jh, full_matrices=False)
        jh.append(np.ascontiguousarray(U[:, sv > RANK_TOL * sv[0]]))
    return np.ascontiguousarray(np.column_stack(f)), jh


def plan_discriminate(
    model: TreeModel, data: AbsoluteData, tied: object, Q: object, k: int, settings: object = None
) -> dict:
    """The ``k`` candidate postures (rows of ``Q``) that best separate the
    tied candidate effects ``tied`` after each is fitted to ``data``
    (module docstring). ``settings``: the model's [plan] settings (the
    candidates are already feasible; not used here). Returns {selected (k,)
    int 0-based, value (the smallest noncentrality, in sigma^2), pairs (nh,
    nh) noncentrality of a against b's fit, hypotheses [labels], effects
    [their tables], sigma_position_m, rows (f, jh, n0, nobs): the design
    problem, for design.discrimination}."""
    from .._core import design

    if not isinstance(model, TreeModel):
        raise InputError("--discriminate: implemented for absolute (tracker) data with a tree model")
    effects = hypothesis_effects(model, tied)
    q = _postures(data, Q)
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise InputError(f"k must be a positive integer, got {k!r}")
    if k > q.shape[0]:
        raise InputError(f"k = {k} exceeds the {q.shape[0]} candidate postures")
    fit = fit_absolute(model, data)
    sig = model.sigma_position if model.sigma_position is not None else fit.sigma
    if not (sig is not None and math.isfinite(sig) and sig > 0):
        raise InputError(f"{data.path}: no noise sigma (declare sigma_position, or measure more rows than parameters)")
    f, jh = _hypotheses(fit, data, q, effects, sig)
    n0, nobs = 3 * data.n, 3 * len(data.frames)
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
