"""The proposal of the absolute diagnosis (``calib.absolute_diagnose``): a
candidate significant after the multiplicity of the candidates (the
max-score test, ``diagnosis.corrected_p``) that lowers
the held-out error by more than CV_GAIN, checked by a fit with it (a
compliance that would have to be negative is held at 0 there, and then
nothing changes); the simpler of two nested candidates first; rivals within
the margin reported as tied; else why nothing is proposed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from .._core import calib as core_calib
from ..errors import StiffkitError
from ..robot.tree_model import TreeModel, tree_model_from_tables
from .absolute_data import AbsoluteData
from .absolute_fit import _nonnegative, _solve, predict
from .absolute_structure import structure_verdict
from .diagnose_candidates import Candidate
from .diagnosis import CV_GAIN, NO_HELD_OUT, ZTOL, lowers_held_out, tie_rivals
from .diagnosis_report import not_significant, nothing_fits_reason, undecidable

if TYPE_CHECKING:
    from .absolute_diagnose_report import AbsoluteDiagnosis

__all__ = ["propose", "CV_GAIN"]

#: a smaller candidate contained in the best one is proposed first when it achieves this share of
#: the best one's held-out improvement (joint offsets before the frame errors that contain them)
NESTED_SHARE = 0.5
#: a proposal is checked by fitting the model with it (at most this many candidates): the fit
#: must realise this share of the in-sample improvement the linear prediction promised
VERIFY_TOP = 3
VERIFY_SHARE = 0.5
VERIFY_MAXIT = 5


def propose(
    dg: AbsoluteDiagnosis,
    ranked: list[tuple[Candidate, np.ndarray]],
    top: list[tuple[Candidate, np.ndarray]],
    m: TreeModel,
    theta: np.ndarray,
    kept_names: list[str],
    data: AbsoluteData,
    w: np.ndarray,
    A: np.ndarray,
    r: np.ndarray,
    J: np.ndarray,
    col: dict,
    cv_base: float | None,
    ext_names: list[str],
    sig_decl: float | None,
    log_p: float,
    alpha: float,
    significant: Callable[[Candidate], bool],
) -> None:
    """The proposal: significant after multiplicity, lowers the held-out
    error, and a fit with it realises the improvement; ties; or why none."""
    fit = dg.fit
    if dg.nothing_fits:  # diagnosis.catalogue_fails, with a declared sigma
        dg.verdict = "inadequate"
        dg.reasons.append(nothing_fits_reason(ranked[0][0].excess_fraction if ranked else None))
        structure_verdict(dg, data, fit, w, checked=True, decide=False)
        return
    useful = [c for c, _ in top if significant(c) and lowers_held_out(c.cv_rms_position_m, cv_base)]
    best = None
    tried: set[str] = set()
    notes: list[str] = []
    cols_of = {id(c): cols for c, cols in top}
    kept_set = set(kept_names)
    for lead in sorted(useful, key=lambda c: c.cv_rms_position_m)[:VERIFY_TOP]:
        # the linear prediction is checked by a fit with the candidate added: a compliance
        # that would have to be negative is held at 0 there, and then nothing changes
        cand = _smaller_first(lead, useful, cols_of, A, r, J, col, cv_base)
        for c in [cand] + ([lead] if lead is not cand else []):
            if c.label in tried:
                continue
            tried.add(c.label)
            scored = {ext_names[x] for x in cols_of[id(c)]}
            rms_new = _refit_rms(m, theta, kept_set, c, data, w, scored)
            want = fit.rms_position - c.rms_after_m
            if rms_new is not None and fit.rms_position - rms_new >= VERIFY_SHARE * want:
                best = c
                break
            notes.append(
                f"{c.label} would lower the held-out RMS to {c.cv_rms_position_m * 1e3:.4g} mm as a linear "
                f"change, but a fit with it does not ("
                + (f"RMS {fit.rms_position * 1e3:.4g} -> {rms_new * 1e3:.4g} mm" if rms_new is not None else "no fit")
                + ": a compliance held at 0, or the linear step does not hold)"
            )
        if best is not None:
            break
    if best is None:
        dg.reasons += notes
    else:
        dg.warnings += [f"not proposed: {n}" for n in notes]
    if best is not None:
        # the one tie rule (diagnosis.tie_rivals; was: useful rivals within CV_GAIN of its held-out
        # error, and the proposal made): rivals that failed the check by a fit are no rivals
        failed = tried - {best.label}
        rivals = [c for c in tie_rivals(best, [c for c, _ in ranked], A, alpha) if c.label not in failed]
        dg.verdict = "inadequate"
        if not rivals:
            dg.proposal = best
            return
        dg.ties.append(
            {
                "candidates": [best.label] + [c.label for c in rivals],
                "log10_p_values": [best.log_p / math.log(10)] + [c.log_p / math.log(10) for c in rivals],
                "cv_rms_position_m": [best.cv_rms_position_m] + [c.cv_rms_position_m for c in rivals],
            }
        )
        dg.reasons.append(undecidable([best.label] + [c.label for c in rivals]))
        return
    if ranked and not significant(ranked[0][0]) and sig_decl and log_p < math.log(alpha):
        # the chi-square rejects, the best candidate does not pass its corrected test
        dg.reasons.append(not_significant(ranked[0][0].log_p, dg.multiplicity_p, dg.n_tests))
    elif cv_base is None and ranked:
        dg.reasons.append(NO_HELD_OUT)
    elif ranked and significant(ranked[0][0]) and not tried:
        dg.reasons.append(
            "the leading candidates are significant but none lowers the held-out error by more than "
            f"{CV_GAIN:.0%}: they would fit noise or the fit's own flexibility"
        )
    checked = cv_base is not None or not ranked  # candidates held out (or none to check)
    if sig_decl and log_p < math.log(alpha):
        # inadequate; whether nothing fits was the catalogue_fails rule's (unified: was every time
        # nothing was proposed)
        dg.verdict = "inadequate"
    if not sig_decl or dg.verdict == "inadequate":
        # the residual's structure: the verdict without a declared sigma, else what it suggests
        structure_verdict(dg, data, fit, w, checked, decide=not sig_decl)


def _refit_rms(
    m: TreeModel,
    theta: np.ndarray,
    kept: set[str],
    cand: Candidate,
    data: AbsoluteData,
    w: np.ndarray,
    scored: set[str] | None = None,
) -> float | None:
    """RMS point error (m) of the fitted model ``m`` plus the candidate's
    effect, fitted: LM from the fitted values (the candidate at 0) on the
    identified parameters and the candidate's that were scored (``scored``,
    names; default all: the members of an ``all`` candidate that cannot act
    stay at 0, their columns would only let the fit wander), compliances that come out
    negative held at 0 and the rest fitted again, as the fit does. None
    when that fails."""
    try:
        mc = tree_model_from_tables(
            m.tree, list(m.effects) + [dict(cand.effect)], m.gravity, m.iterations, "diagnosis", m.sigma_position
        )
        mc.arrays["rref"] = np.asfortranarray(m.arrays["rref"])
        th = mc.theta0.copy()
        for k, name in enumerate(mc.names):
            if name in m.names:
                th[k] = theta[m.index(name)]
        new = [name not in m.names and (scored is None or name in scored) for name in mc.names]
        free = np.array([k for k, name in enumerate(mc.names) if name in kept or new[k]], int)
        free = np.array([k for k in free if mc.params[k].free], int)
        mc, sol = _solve(mc, data, th, free, w, VERIFY_MAXIT)
        th = sol["theta"]
        neg = [k for k in free if _nonnegative(mc.params[k]) and th[k] < 0]
        if neg:
            th = th.copy()
            th[neg] = 0.0
            mc, sol = _solve(mc, data, th, np.array([k for k in free if k not in neg], int), w, VERIFY_MAXIT)
            th = sol["theta"]
        d = np.linalg.norm(data.xyz - predict(mc, data, th)["pred"], axis=1)[w > 0]
    except StiffkitError:
        return None
    return float(np.sqrt(np.mean(d**2))) if d.size else None


def _smaller_first(
    best: Candidate,
    useful: list[Candidate],
    cols: dict,
    A: np.ndarray,
    r: np.ndarray,
    J: np.ndarray,
    col: dict,
    cv_base: float,
) -> Candidate:
    """A useful candidate with fewer parameters whose columns lie in the span
    of the model and the best candidate (the best one contains it, e.g. joint
    offsets inside frame errors) and that gets NESTED_SHARE of the best one's
    held-out improvement: the simpler effect first; the rest of the best one
    remains a candidate of the next step."""
    gain = cv_base - best.cv_rms_position_m
    Zb = J[:, [col[x] for x in cols[id(best)]]]
    inner = []
    for c in useful:
        if c is best or c.kind == best.kind or c.dof >= best.dof or cv_base - c.cv_rms_position_m < NESTED_SHARE * gain:
            continue
        Zc = J[:, [col[x] for x in cols[id(c)]]]
        _st, dof, _pr = core_calib.score(np.hstack([A, Zb]), r, Zc, np.array([1, Zc.shape[1] + 1]), 1e-10, ZTOL)
        if int(dof[0]) == 0:
            inner.append(c)
    if not inner:
        return best
    pick = min(inner, key=lambda c: c.cv_rms_position_m)
    pick.hint = (
        f"{pick.label} is contained in {best.label} (which would bring the held-out RMS to "
        f"{best.cv_rms_position_m * 1e3:.4g} mm): the simpler effect first"
    )
    return pick
