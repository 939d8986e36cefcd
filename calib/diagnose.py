"""Model diagnosis: is what is left noise, and which effect is missing?

0. Data checks (``robust``): a robust fit, rows that are gross errors,
   configurations recorded in the wrong unit (with the fix), configurations
   off as a whole. Gross errors and unit slips are set aside for the rest
   (unless they are too many to be data errors); when the model then fits
   the rest to the noise, no effect is proposed.
1. Adequacy: chi-square test of the weighted residual against the declared
   sigma (chi2 = |r/sigma|^2 with n_obs - rank degrees of freedom); without
   a declared sigma, the lack-of-fit F test against the pure error of
   replicated rows. Beside it, the multiplicity-corrected test of the best
   candidate (core max-score test: the p-value of the best candidate's
   score test, corrected for having looked at every candidate, with their
   correlations): a weak effect that the omnibus test dilutes over all the
   degrees of freedom still raises the alarm. Inadequate when either
   rejects at alpha.
2. Candidates: every contract kind (and the extensions joint_cubic,
   joint_deadzone) on every target the model lacks. Each is scored by a
   score (Lagrange-multiplier) test in the core: its columns (linearised at
   the current fit for nonlinear kinds) are projected off the model's
   column space; the rank left is the degrees of freedom, the part of the
   residual in that space the statistic. Candidates with nothing left are
   reported as non-identifiable, not ranked. Ranking by log p-value
   (statistic against its degrees of freedom), never the raw p. The
   leading candidates also get their held-out error: cross-validation by
   configuration (K folds, the points of a configuration never split).
3. Honest ranking: candidates whose explained parts coincide (cosine above
   0.99, and their difference no larger than noise would make it) are
   indistinguishable; candidates of other targets within
   TIE_LOG10 of the leader in log10 p, or whose held-out error is
   significantly lower than the leader's (paired over configurations: the
   two criteria disagree), are undecidable together (a tie), reported with the
   measurement that would separate them (the posture and load where their
   fits predict most differently). When the best candidate explains well
   under half of the excess residual, the best few together do not explain
   most of it, and the model with the best one is still inadequate, nothing
   in the catalogue fits: the residual's shape is shown instead
   (``residual_map``).
4. A proposal (a ready ``[[effect]]`` table) is made only when the model is
   inadequate, the leader is not tied, something in the catalogue fits, and
   the leader lowers the held-out error.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from ..robot.model import Model, default_tau0, expand_effect
from . import crossval as CV
from . import residual_map as RM
from .backward import backward_steps, held_for_addition
from .diagnose_candidates import Candidate, candidate_tables, inert_reasons
from .diagnose_rank import (
    COMPENSATOR_MATCH,
    CV_TOP,
    EQUIVALENT,
    HINT_COMPENSATOR,
    NOTHING_FITS,
    TOGETHER_FITS,
    _rank_honestly,
    compensator_shape_match,
    separating_measurements,
)
from .diagnose_report import Diagnosis, effect_toml, format_diagnosis, residual_shape
from .diagnose_stats import (
    ALPHA,
    CV_FOLDS,
    LOW_DOF,
    NSIM,
    OVERFIT,
    TIE_LOG10,
    ZTOL,
    _adequacy,
    _cos,
    _cv,
    logsf_chi2,
    logsf_f,
    pure_error,
)
from .diagnosis import (
    DUPLICATE_COS,
    OUTLIER_ALPHA,
    Noise,
    bonferroni,
    corrected_p,
    distinct_rows,
    few_dof_warning,
    fill_scores,
    folds_of,
    judged_fit,
    score_blocks,
)
from .fit import FitResult, Problem, as_inputs, fit, identified_model
from .measure import Measurements
from .plan_hint import plan_command
from .robust import check_data

__all__ = [
    "ALPHA",
    "COMPENSATOR_MATCH",
    "CV_FOLDS",
    "CV_TOP",
    "DUPLICATE_COS",
    "EQUIVALENT",
    "HINT_COMPENSATOR",
    "LOW_DOF",
    "NOTHING_FITS",
    "NSIM",
    "OVERFIT",
    "TIE_LOG10",
    "TOGETHER_FITS",
    "ZTOL",
    "Candidate",
    "Diagnosis",
    "candidate_tables",
    "compensator_shape_match",
    "diagnose",
    "effect_toml",
    "format_diagnosis",
    "logsf_chi2",
    "logsf_f",
    "pure_error",
    "residual_shape",
    "separating_measurements",
]


def diagnose(
    model: Model,
    meas: Measurements,
    sigma_position: float | None = None,
    alpha: float = ALPHA,
    kinds: Iterable[str] | None = None,
    checks: bool = True,
    cv_folds: int = CV_FOLDS,
    nsim: int = NSIM,
    seed: int = 20240601,
    prune: bool = False,
) -> Diagnosis:
    """Check the data, fit ``model``, test its adequacy and rank the missing
    effects (docs/calibration.md §4 and its extensions).

    Parameters
    ----------
    model, meas : as for :func:`~stiffkit.calib.fit.fit` (objects or paths)
    sigma_position : overrides the declared noise (m); without any, the pure
        error of replicated rows is used (lack-of-fit F test)
    alpha : level of the adequacy tests (omnibus and best candidate)
    kinds : restrict the candidates to these kinds
    checks : run the data checks (robust fit, gross errors, unit slips) and
        set aside the rows they list
    cv_folds : folds of the cross-validation by configuration (0: none, and
        then nothing is proposed: ``diagnosis.folds_of``)
    nsim, seed : Monte Carlo draws of the max-score test
    prune : propose removals only (the backward steps are made in every
        case; an addition is then not proposed)

    Returns
    -------
    Diagnosis : verdict, tests, the fit on the kept rows, candidates ranked
        best first (log p of the score test) with their held-out error,
        ties, whether nothing fits, the proposal (or why none), warnings,
        the residual map; ``.to_json()`` has the contract keys.
    """

    model, meas = as_inputs(model, meas)
    rows = np.hstack([meas.q, meas.w, meas.p, meas.d] + ([meas.r] if meas.r is not None else []))
    meas, copies = distinct_rows(meas, rows)  # copies are not replicates
    tau_all = model.chain.joint_torques(meas.q, meas.w)
    tau0 = {j: default_tau0(tau_all[:, k]) for k, j in enumerate(model.chain.joint_names) if model.chain.qidx[k] > 0}
    cands = candidate_tables(model, tau0)
    if kinds:
        kinds = set(kinds) | ({"joint_profile"} if "gravity_compensator" in kinds else set())
        cands = [c for c in cands if c[0]["kind"] in kinds]
    n0 = len(model.effects)
    cterms = [expand_effect(model.chain, table, n0 + i, "candidate") for i, (table, _) in enumerate(cands)]
    flat = [t for ts in cterms for t in ts]
    pb = Problem(model, meas, extra_terms=flat, sigma_position=sigma_position)
    res_all = judged_fit(lambda: fit(model, meas, problem=pb), meas.path, meas.n, copies, pb.npar, pb.rows)
    test, stat, dof, log_p, sigma, source, scale2, d_pe = _adequacy(res_all, pb, meas, copies)
    # one level of the data checks, both kinds (was alpha on deflections)
    dc = check_data(res_all, alpha=OUTLIER_ALPHA) if checks else None
    res, log_p_all, verdict_all = res_all, None, None
    if dc is not None and dc.set_aside:
        log_p_all = log_p
        verdict_all = "adequate" if log_p >= math.log(alpha) else "inadequate"
        keep = np.setdiff1d(np.arange(meas.n), dc.set_aside)
        meas = meas.subset(keep)
        pb = Problem(model, meas, extra_terms=flat, sigma_position=sigma_position)
        res = fit(model, meas, problem=pb)
        test, stat, dof, log_p, sigma, source, scale2, d_pe = _adequacy(res, pb, meas, copies)
    nobs = res.nobs
    omnibus = log_p < math.log(alpha)

    # candidate columns, linearised at the fit
    fitted = identified_model(res)
    base_terms = fitted.terms
    Z = []
    for ts in cterms:
        terms = base_terms + ts
        layout, k = {}, 0
        for i, t in enumerate(ts):
            layout[len(base_terms) + i] = slice(k, k + len(t.names))
            k += len(t.names)
        _, J = pb.evaluate(np.zeros(k), terms=terms, layout=layout)
        if ts[0].kind == "joint_cubic":
            # per unit of c3 tau_rms^2 (a compliance), not of c3: the core's
            # round-off test compares columns across candidates
            J = J / max(float(np.mean(pb.torques[:, ts[0].joint] ** 2)), 1e-300)
        Z.append(pb.weighted(J))
    A = res.A if res.A.shape[1] else np.zeros((nobs, 1))
    # candidates that cannot act (zero columns) are listed, never scored
    inert = inert_reasons(cands, Z)
    act = [c for c in range(len(cands)) if not inert[c]]
    stat_c, dof_c = np.zeros(len(cands)), np.zeros(len(cands), int)
    pr = np.zeros((nobs, len(cands)))
    if act:
        stat_c[act], dof_c[act], pr[:, act] = score_blocks(A, res.r, [Z[c] for c in act])
    rr = float(res.r @ res.r)
    noise = Noise(scale2, "declared" if d_pe is None else "pure error", res.dof, d_pe)
    excess = noise.excess(rr)  # residual above the noise, in chi-square units
    wp = float(pb.wrow[0])
    npts = meas.n
    rpos = res.r[: 3 * npts].reshape(3, npts)
    ranked, spanned = [], []
    for c, (table, hint) in enumerate(cands):
        cand = Candidate(kind=table["kind"], target=table.get("target", table["kind"]), effect=dict(table), hint=hint)
        if inert[c] or dof_c[c] == 0:
            cand.reason = inert[c] or "spanned by the model: its columns are combinations of the model's"
            spanned.append(cand)
            continue
        fill_scores(cand, float(stat_c[c]), int(dof_c[c]), noise, rr)
        after = (rpos - pr[: 3 * npts, c].reshape(3, npts)) / wp
        cand.rms_after_m = float(np.sqrt(np.mean((after**2).sum(axis=0))))
        cand._pr = pr[:, c]
        cand._cols = Z[c]
        cand._index = c
        ranked.append(cand)
    ranked.sort(key=lambda c: (c.log_p, c.dof, -c.statistic))

    # the best candidate, corrected for having looked at all of them
    mult_p = bonf_p = None
    nsim_used = 0
    if ranked:
        bonf_p = bonferroni(ranked[0].p_value, len(ranked))
        mult_p, nsim_used = corrected_p(A, [Z[c] for c in act], ranked[0].log_p, alpha, d_pe or 0, nsim, seed)
    best_alarm = mult_p is not None and mult_p < alpha
    verdict = "inadequate" if (omnibus or best_alarm) else "adequate"

    # near-duplicates among the significant leaders
    sig = math.log(alpha)
    lead = [c for c in ranked[:15] if c.log_p < sig]
    for i, a in enumerate(lead):
        for b in lead[i + 1 :]:
            if a.family == b.family:
                continue
            # the same part of the residual, up to what noise could make of the difference
            d2 = float(np.sum((a._pr - b._pr) ** 2)) / scale2
            k = a.dof + b.dof
            if _cos(a._pr, b._pr) > DUPLICATE_COS and d2 < k + 3.0 * math.sqrt(2.0 * k):
                a.indistinguishable_from.append(b.label)
                b.indistinguishable_from.append(a.label)

    # held-out error, by configuration
    folds = folds_of(meas.config, cv_folds)
    obs_rows = np.tile(np.arange(npts), pb.rows)
    cv0 = None
    for c in ranked:
        c._cv = None
    if len(folds) >= 2:
        cv0, _ = _cv(res.A, res.r, obs_rows, folds, npts, wp, meas.config)
    if cv0 is not None and verdict == "inadequate":
        near = [c for c in ranked if c.log_p < sig and (c.log_p - ranked[0].log_p) / math.log(10) <= TIE_LOG10]
        for c in {id(c): c for c in ranked[:CV_TOP] + near}.values():
            c.cv_rms_position_m, c._cv = _cv(np.hstack([res.A, c._cols]), res.r, obs_rows, folds, npts, wp, meas.config)

    dg = Diagnosis(
        verdict=verdict,
        test=test,
        statistic=float(stat),
        dof=float(dof),
        log_p=float(log_p),
        sigma_position=sigma,
        sigma_source=source,
        fit=res,
        candidates=ranked,
        non_identifiable=spanned,
        alpha=alpha,
        fit_all=res_all,
        data_checks=dc,
        verdict_all_rows=verdict_all,
        log_p_all_rows=log_p_all,
        multiplicity_p=mult_p,
        bonferroni_p=bonf_p,
        n_tests=len(ranked),
        nsim=nsim_used,
        omnibus_inadequate=omnibus,
        best_inadequate=best_alarm,
        cv_rms_position_m=cv0,
        cv_folds=len(folds),
        excess=excess,
        scale2=scale2,
        n_copied=copies,
    )
    _rank_honestly(dg, pb, res, A, model, cterms, cands, sig)
    pairs = len(np.unique(np.hstack([meas.q, meas.w]), axis=0))
    for t in dg.ties:  # name the command that plans the (posture, load) pairs to tell them apart
        t["plan_command"], t["plan_select"] = plan_command(model.path, meas.path, pairs, t["candidates"])
    _backward(dg, pb, res, folds, obs_rows, npts, wp, meas, d_pe, alpha)
    if dg.proposal is not None and prune:
        dg.reasons.append(f"{dg.proposal.label} is not proposed: --prune proposes removals only")
        dg.proposal = None
    held_for_addition(dg)
    dg.pruned = prune
    _warnings(dg, nobs)
    if verdict == "inadequate" and (dg.nothing_fits or dg.proposal is None):
        feats = RM.features(pb)
        dg.residual_map = RM.score_features(pb, A, res.r, feats, scale2, excess)
        dg.shapes = [residual_shape(pb, res, f) for f in dg.residual_map[:3]]
    for c in ranked:
        del c._pr, c._cols, c._index, c._cv
    return dg


def _backward(
    dg: Diagnosis,
    pb: Problem,
    res: FitResult,
    folds: list[np.ndarray],
    obs_rows: np.ndarray,
    npts: int,
    wp: float,
    meas: Measurements,
    d_pe: int | None,
    alpha: float,
) -> None:
    """The backward steps (calib/backward.py) of the model's effects,
    linearised at the fit: A's columns are the free parameters times their
    equilibration scale."""
    free = [t for t in pb.terms if t.free]
    owner = np.array([t.effect for t in free for _ in t.names], int)
    eq = res.col_scale if res.col_scale is not None and res.col_scale.size else np.ones(owner.size)
    coef = res.theta / eq if owner.size else np.zeros(0)

    def cv(Ab: np.ndarray, rb: np.ndarray) -> float | None:
        return _cv(Ab, rb, obs_rows, folds, npts, wp, meas.config)[0] if len(folds) >= 2 else None

    dg.backward, dg.removal = backward_steps(
        list(pb.model.effects),
        owner,
        coef,
        res.A,
        res.r,
        dg.scale2,
        d_pe is None,
        d_pe or res.dof,
        cv,
        dg.cv_rms_position_m,
        lambda e: CV.rms_rows(e, npts, coords=(0, 1, 2), scale=1.0 / wp),
        alpha,
        values=lambda cols: res.theta[cols],
        free_effects={t.effect for t in free},
    )


def _warnings(dg: Diagnosis, nobs: int) -> None:
    res = dg.fit
    few = few_dof_warning(res.dof, nobs, len(res.names))
    if few:
        dg.warnings.append(few)
    if dg.sigma_source == "declared":
        floor = dg.floor
        ratio = res.rms_position / floor if floor > 0 else float("nan")
        if dg.verdict == "adequate" and ratio < OVERFIT:
            cv = dg.cv_rms_position_m
            held = f"; held-out RMS {cv * 1e3:.4g} mm = {cv / floor:.2f} x the floor" if cv is not None else ""
            dg.warnings.append(
                f"possible over-fitting: the RMS is {ratio:.2f} x the noise floor ({res.dof} residual dof of "
                f"{nobs}){held}; more configurations would tell"
            )
        cv = dg.cv_rms_position_m
        if dg.verdict == "adequate" and cv is not None and cv > 1.5 * floor:
            dg.warnings.append(
                f"the model fits these rows but predicts held-out configurations at {cv / floor:.2f} x the noise "
                f"floor: it does not generalise (over-fitted, or the configurations do not inform every parameter)"
            )
