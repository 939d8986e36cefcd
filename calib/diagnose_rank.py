"""Honest ranking of the deflection diagnosis (``calib.diagnose``):
candidates that the data cannot tell apart, ties with the measurement that
would separate them, "nothing in the catalogue fits", the proposal and the
gravity-compensator hint.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .._core import calib as core
from ..robot.model import Model, compensator_h
from .diagnose_candidates import Candidate
from .diagnose_stats import ZTOL
from .diagnosis import (  # noqa: F401 (re-exported)
    CV_GAIN,
    NO_HELD_OUT,
    NOTHING_FITS,
    TOGETHER_FITS,
    Noise,
    catalogue_fails,
    lowers_held_out,
    tie_rivals,
)
from .diagnosis_report import not_significant, nothing_fits_reason, undecidable
from .fit import FitResult, Problem, identified_model
from .measure import Measurements

if TYPE_CHECKING:
    from ..robot.model import Term
    from ..robot.urdf import Chain
    from .diagnose_report import Diagnosis

__all__ = ["separating_measurements", "compensator_shape_match"]

CV_TOP = 5  # held-out error for this many leading candidates (and every tied one)
EQUIVALENT = 1e-6  # tied fits predicting the same to this relative level everywhere are one effect
COMPENSATOR_MATCH = 0.9  # a compensator shape explaining this share of a joint_profile's part: hint

HINT_COMPENSATOR = (
    "posture-dependent compliance of {j} that a gravity compensator could produce (a spring between "
    "the bodies of {j} explains {r2:.0%} of what the profile explains): if {j} carries one, model it "
    'as kind = "gravity_compensator" with its geometry a, b, beta, s0 (needs a joint effect on {j}); '
    "joint_profile is its generic form"
)


def _rank_honestly(
    dg: Diagnosis,
    pb: Problem,
    res: FitResult,
    A: np.ndarray,
    model: Model,
    cterms: list[list[Term]],
    cands: list[tuple[dict, str]],
    sig: float,
) -> None:
    """Ties, nothing-fits, the proposal and the compensator hint."""
    ranked = dg.candidates
    if not ranked:
        if dg.verdict == "inadequate":
            dg.nothing_fits = True
            dg.reasons.append("no candidate left to score")
        return
    L = ranked[0]
    cv0 = dg.cv_rms_position_m
    tied = tie_rivals(L, ranked, A, dg.alpha) if L.log_p < sig else []
    if tied:
        sep = separating_measurements(pb, res, model, cterms, [L] + tied)
        # the same deflections in every probed posture and load: the same effect
        # under two names (e.g. a full spring moved along a lever), not a tie
        same = {s["candidates"][1] for s in sep if s["difference_m"] <= EQUIVALENT * max(s["predicted_m"])}
        for c in tied:
            if c.label in same:
                L.indistinguishable_from = list(dict.fromkeys(L.indistinguishable_from + [c.label]))
                c.indistinguishable_from = list(dict.fromkeys(c.indistinguishable_from + [L.label]))
        tied = [c for c in tied if c.label not in same]
        sep = [s for s in sep if s["candidates"][1] not in same]
    if tied:
        L.tied_with = [c.label for c in tied]
        for c in tied:
            c.tied_with = [L.label] + [t.label for t in tied if t is not c]
        dg.ties.append(
            {
                "candidates": [L.label] + [c.label for c in tied],
                "log10_p_values": [L.log_p / math.log(10)] + [c.log_p / math.log(10) for c in tied],
                "cv_rms_position_m": [L.cv_rms_position_m] + [c.cv_rms_position_m for c in tied],
                "separate_by": sep,
            }
        )
    # nothing fits: the leader (and the leading few together) explain little of the excess
    if dg.verdict == "inadequate":
        noise = Noise(dg.scale2, "declared" if dg.sigma_source == "declared" else "pure error", res.dof)
        dg.nothing_fits, dg.together_fraction = catalogue_fails(ranked, A, res.r, noise, dg.alpha)
    # the proposal
    if dg.verdict != "inadequate":
        if dg.data_checks is not None and dg.data_checks.set_aside:
            dg.reasons.append("the model fits the data once the rows listed by the data checks are set aside")
        return
    if dg.nothing_fits:
        dg.reasons.append(nothing_fits_reason(L.excess_fraction))
    if tied:
        dg.reasons.append(undecidable([L.label] + [c.label for c in tied]))
    if cv0 is None:
        dg.reasons.append(NO_HELD_OUT)
    elif not lowers_held_out(L.cv_rms_position_m, cv0):
        # unified rule (issue 15): by CV_GAIN, as on tracker data (was: any decrease)
        after = f"{L.cv_rms_position_m * 1e3:.4g}" if L.cv_rms_position_m is not None else "?"
        dg.reasons.append(
            f"{L.label} does not lower the held-out error by {CV_GAIN:.0%} ({cv0 * 1e3:.4g} -> {after} mm)"
        )
    if not (dg.multiplicity_p is not None and dg.multiplicity_p < dg.alpha):
        # unified rule (issue 15): significant after the multiplicity of the candidates (was: on its own)
        dg.reasons.append(not_significant(L.log_p, dg.multiplicity_p, dg.n_tests))
    if not dg.reasons:
        dg.proposal = L
        if L.kind == "joint_profile":
            r2 = compensator_shape_match(pb, res, L, dg.scale2)
            if r2 >= COMPENSATOR_MATCH:
                L.hint = HINT_COMPENSATOR.format(j=L.target, r2=r2)


def separating_measurements(
    pb: Problem,
    res: FitResult,
    model: Model,
    cterms: list[list[Term]],
    group: list[Candidate],
    n_random: int = 60,
    seed: int = 7,
) -> list[dict]:
    """For each candidate of a tie after the first: the posture and load
    where its fit and the leader's fit to these data predict most
    differently (probes: the data's configurations and random postures in
    the data's joint ranges, each under a force along x, y, z and a moment
    about x, y, z of the data's median sizes, at the first measured point)."""
    meas = pb.meas
    rng = np.random.default_rng(seed)
    cfgs = list(dict.fromkeys(meas.config))
    first = {c: meas.config.index(c) for c in cfgs}
    Qd = np.array([meas.q[first[c]] for c in cfgs])
    lo, hi = meas.q.min(axis=0), meas.q.max(axis=0)
    Qr = lo + (hi - lo) * rng.random((n_random, meas.q.shape[1]))
    Q = np.vstack([Qd, Qr])
    src = [f"configuration {c} of the data" for c in cfgs] + ["a new posture"] * n_random
    F = float(np.median(np.linalg.norm(meas.w[:, :3], axis=1))) or 1.0
    M = float(np.median(np.linalg.norm(meas.w[:, 3:], axis=1))) or 1.0
    W6 = np.diag([F, F, F, M, M, M])
    names = ["force +x", "force +y", "force +z", "moment +x", "moment +y", "moment +z"]
    nq = Q.shape[0]
    probe = Measurements(
        q=np.repeat(Q, 6, axis=0),
        w=np.tile(W6, (nq, 1)),
        p=np.tile(meas.p[0], (6 * nq, 1)),
        d=np.zeros((6 * nq, 3)),
        r=None,
        config=[f"p{i // 6}" for i in range(6 * nq)],
        lines=list(range(6 * nq)),
        path="probes",
    )
    preds = []
    eq = res.col_scale if res.col_scale is not None else np.ones(res.A.shape[1])
    fitted = identified_model(res)
    for c in group:
        ts = cterms[c._index]
        ppb = Problem(model, probe, extra_terms=ts)
        _, Jm = ppb.evaluate(res.theta)
        terms = fitted.terms + ts
        layout, k = {}, 0
        for i, t in enumerate(ts):
            layout[len(fitted.terms) + i] = slice(k, k + len(t.names))
            k += len(t.names)
        _, Jc = ppb.evaluate(np.zeros(k), terms=terms, layout=layout)
        coef = core.wls(np.hstack([res.A, c._cols]), res.r, 1e-10, 1e-6)[0]
        na = res.A.shape[1]
        dtheta = coef[:na] * eq
        pred = (Jm[0:3] @ dtheta if na else 0.0) + Jc[0:3] @ coef[na:]
        preds.append(pred)  # (3, probes), metres
    out = []
    for c, p in zip(group[1:], preds[1:]):
        diff = np.linalg.norm(preds[0] - p, axis=0)
        i = int(np.argmax(diff))
        out.append(
            {
                "candidates": [group[0].label, c.label],
                "posture": [round(float(v), 4) for v in probe.q[i]],
                "posture_source": src[i // 6],
                "load": names[i % 6],
                "wrench": [float(v) for v in probe.w[i]],
                "predicted_m": [float(np.linalg.norm(preds[0][:, i])), float(np.linalg.norm(p[:, i]))],
                "difference_m": float(diff[i]),
                "difference_sigma": float(diff[i] / pb.sigma_position) if pb.sigma_declared else None,
            }
        )
    return out


def compensator_shape_match(pb: Problem, res: FitResult, cand: Candidate, scale2: float = 1.0) -> float:
    """How much of what a joint_profile candidate explains a gravity
    compensator on that joint would explain: the best ratio, over
    compensator shapes, of the residual explained by the joint's spring
    column times 1 / (1 + kappa h(q)) (one free size, as c_eff = c / (1 + c
    k_s h)) to the residual the free profile explains (both beyond their
    expected noise share). Shapes: geometry on a grid (angle beta, b / a,
    s0 / a with the spring always in tension, s0 < a - b; the size of a is
    absorbed by k_s) and kappa max|h| in 0 (first order), 1, 10."""
    ch = pb.model.chain
    k = ch.joint_index(cand.target)
    q = pb.meas.q[:, int(ch.qidx[k]) - 1]
    g = pb.evaluate(np.zeros(0), terms=[_unit_joint(ch, k)], layout={}, jac=False)[0]  # (6, n)
    shapes = []
    for beta in np.linspace(0, 2 * np.pi, 24, endpoint=False):
        for b in (0.1, 0.25, 0.4):
            for s0 in np.array([0.3, 0.6, 0.9]) * (1.0 - b):
                h = compensator_h(q, {"a": 1.0, "b": b, "beta": beta, "s0": s0})
                hm = float(np.abs(h).max())
                if not hm > 0:
                    continue
                shapes.append(-h)
                for kap in (1.0, 10.0):
                    den = 1.0 + (kap / hm) * h
                    if np.all(den > 0.05):
                        shapes.append(1.0 / den)
    Zs = np.column_stack([pb.weighted(g * s[None, :]) for s in shapes])
    cs = np.arange(1, len(shapes) + 2, dtype=np.int32)
    A = res.A if res.A.shape[1] else np.zeros((res.nobs, 1))
    st, dof, _ = core.score(A, res.r, Zs, cs, 1e-10, ZTOL)
    st_p, dof_p, _ = core.score(A, res.r, cand._cols, np.array([1, cand._cols.shape[1] + 1], np.int32), 1e-10, ZTOL)
    denom = float(st_p[0] / scale2 - dof_p[0])
    if not denom > 0:
        return 0.0
    return float(max(st.max() / scale2 - 1.0, 0.0) / denom)


def _unit_joint(chain: Chain, k: int) -> Term:
    """A known joint term of unit compliance on chain joint k (its spring column)."""
    from ..robot.model import SPRING_JOINT, Term

    return Term(
        kind="joint",
        target=chain.joint_names[k],
        effect=-1,
        names=[],
        spring=(SPRING_JOINT, k + 1),
        value=np.array([1.0]),
        joint=k,
        qcol=int(chain.qidx[k]) - 1,
    )
