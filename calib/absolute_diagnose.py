"""Diagnosis on absolute data (docs/calibration.md section 6.4): is what the
model leaves noise, which geometric or elastic effect is missing, and which
effect of the model no longer earns its place?

1. The data first: the model is fitted, the points whose error is a gross
   outlier (against a robust scale, standing out from their own
   configuration) and configurations recorded in another unit are listed
   (calib/checks.py) and set aside before anything is blamed on the model.
2. Every catalogued effect the model lacks (calib/absolute_candidates.py:
   joint offsets, frame errors, joint and lateral compliance under gravity,
   link and base springs, each on every target and on ``all``) is added at
   zero to one extended model, whose analytic Jacobian at the fitted values
   gives every candidate's columns in one core call. A candidate that cannot
   move a measured point (no marker below it; zero columns; below the noise
   at its plausible size) is listed as non-identifiable with the reason and
   never scored. Each other candidate gets the score statistic of its
   columns projected off the model's (core/sk_calib.f90 score_tests), a log
   p-value (chi-square with a declared sigma, F with the residual's
   estimate otherwise), the share of the residual it explains (and, with a
   declared sigma, of the residual above the noise), and its held-out
   error: K-fold cross-validation by configuration of the model plus the
   candidate, linearised at the fit (one Gauss-Newton step per fold).
3. A candidate is proposed only when it is significant after the
   multiplicity of the candidates (max-score test, calib/diagnosis.py; the
   best candidate's corrected test is part of the verdict) and lowers the
   held-out error of the model by more than its noise; candidates whose
   held-out errors are within that margin of the leader's are reported as
   tied. Without a declared sigma the residual cannot be called noise by a
   chi-square test: the verdict then rests on the held-out error.
4. Backward steps (calib/backward.py): every effect already in the
   model is tested without it (its values against the noise, the held-out
   error without it); one that no longer earns its place is proposed for
   removal, before any addition. With ``prune=True`` only the backward
   steps are made, and the verdict is the adequacy test's (chi-square
   against the declared sigma, else the residual's structure).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable

import numpy as np

from .._core import calib as core_calib
from .._core import tree as core
from ..errors import StiffkitError
from ..robot.tree_model import TreeModel
from .absolute_candidates import (
    JOINT_KINDS,
    SPRING_TEMPLATE,
    absolute_candidates,
    duplicate_of,
    extended_model,
    inert_reason,
    numerical_inert,
    params_of,
)
from .absolute_data import AbsoluteData, row_values
from .absolute_diagnose_report import AbsoluteDiagnosis, format_absolute_diagnosis
from .absolute_fit import (
    AbsoluteFit,
    _loads,
    _marker_index,
    fit_absolute,
    huber_fit,
    predict,
)
from .absolute_propose import propose
from .absolute_structure import PATH_GAP, STRUCTURE_ALPHA, STRUCTURE_PERMUTATIONS, residual_structure, structure_verdict
from .backward import backward_steps, held_for_addition
from .checks import outlier_rows, unit_slips
from .crossval import FoldFactors
from .diagnose_candidates import Candidate
from .diagnosis import (
    ALPHA,
    CV_FOLDS,
    OUTLIER_ALPHA,
    Noise,
    bonferroni,
    catalogue_fails,
    check_residual,
    corrected_p,
    distinct_rows,
    few_dof_warning,
    fill_scores,
    folds_of,
    judged_fit,
    score_blocks,
)
from .plan_hint import plan_command
from .robust import MAX_SET_ASIDE

__all__ = [
    "AbsoluteDiagnosis",
    "diagnose_absolute",
    "diagnose_loop",
    "absolute_candidates",
    "format_absolute_diagnosis",
    "residual_structure",
    "JOINT_KINDS",
    "SPRING_TEMPLATE",
    "STRUCTURE_ALPHA",
    "STRUCTURE_PERMUTATIONS",
    "PATH_GAP",
]

#: LM iterations of the data checks' robust fit (from the plain fit's values)
HUBER_MAXIT = 50
#: held-out errors of this many leading candidates (each one CV of the linearised model)
CV_TOP = 6


def _data_checks(
    model: TreeModel, data: AbsoluteData, fit: AbsoluteFit, sig_decl: float | None, sigma_position: float | None
) -> tuple[AbsoluteData, AbsoluteFit, dict]:
    """Unit slips and gross errors named and set aside (the fit again without them)."""
    dchecks: dict = {
        "outliers": [],
        "unit_slips": [],
        "warnings": list(data.warnings),
        "set_aside": {"rows": [], "lines": []},
    }
    w = data.weight.copy()
    labels = [data.configs[p] for p in data.posture]
    # the rows are judged against a robust (Huber) fit, not pulled by them (one rule, both kinds:
    # the deflection checks' robust fit; was the plain fit)
    try:
        rm, sol, _hw = huber_fit(fit.model, data, fit.theta, fit.reduction.kept, w, HUBER_MAXIT)
        pred = predict(rm, data, sol["theta"])["pred"]
    except StiffkitError:
        pred = data.xyz - fit.residual
    residual = data.xyz - pred
    slips = unit_slips(data.xyz, pred, labels, sig_decl)
    # gross errors among the rows still in use (the reader sets gross unit slips aside)
    use = np.flatnonzero(w > 0)
    res_use = residual[use]
    scale = sig_decl if sig_decl else _robust_sigma(res_use)
    flags = outlier_rows(res_use, scale, [labels[i] for i in use], alpha=OUTLIER_ALPHA)
    for f in flags:
        f.row = int(use[f.row])
    dchecks["unit_slips"] = [s.to_json() for s in slips]
    dchecks["outliers"] = [f.to_json(line=data.lines[f.row]) for f in flags]
    flagged = {f.row for f in flags} | {r for s in slips for r in s.rows}
    # more than MAX_SET_ASIDE of the rows: the misfit is the model's, nothing is set aside (both kinds)
    dchecks["too_many_to_set_aside"] = len(flagged) > MAX_SET_ASIDE * max(use.size, 1)
    if dchecks["too_many_to_set_aside"]:
        flagged = set()
    aside = flagged | set(np.flatnonzero(w == 0).tolist())
    data_all = data
    if aside:
        w[list(aside)] = 0.0
        data = data.subset(w > 0)
        fit = fit_absolute(model, data, sigma_position=sigma_position)
        dchecks["set_aside_rows"] = sorted(int(x) for x in aside)
        dchecks["set_aside"] = {
            "rows": dchecks["set_aside_rows"],
            "lines": [int(data_all.lines[i]) for i in dchecks["set_aside_rows"]],
        }
    return data, fit, dchecks


def diagnose_absolute(
    model: TreeModel,
    data: AbsoluteData,
    sigma_position: float | None = None,
    alpha: float = ALPHA,
    cv_folds: int = CV_FOLDS,
    checks: bool = True,
    prune: bool = False,
    kinds: Iterable[str] | None = None,
) -> AbsoluteDiagnosis:
    """Fit ``model`` to ``data``, check the data, rank the missing effects and
    test the effects already in the model (module docstring). ``prune``:
    only the backward steps (no candidate is scored); ``kinds``: score only
    the candidates of these kinds."""
    kinds = set(kinds) if kinds else None
    data, copies = distinct_rows(data, row_values(data))  # copies are not replicates
    fit = judged_fit(
        lambda: fit_absolute(model, data, sigma_position=sigma_position), data.path, data.n, copies, model.free.size, 3
    )
    sig_decl = sigma_position if sigma_position is not None else model.sigma_position
    # 1. the data first
    dchecks: dict = {
        "outliers": [],
        "unit_slips": [],
        "warnings": list(data.warnings),
        "set_aside": {"rows": [], "lines": []},
    }
    if checks:
        data, fit, dchecks = _data_checks(model, data, fit, sig_decl, sigma_position)
    w = data.weight.copy()
    m = fit.model
    theta = fit.theta
    cands = [] if prune else [c for c in absolute_candidates(m) if not kinds or c["kind"] in kinds]
    ext = extended_model(m, cands)
    th_ext = ext.theta0.copy()
    for i, name in enumerate(ext.names):
        if name in m.names:
            th_ext[i] = theta[m.index(name)]
    ext.arrays["kw0"] = np.array(ext.arrays["kw0"], dtype=float)
    kept_names = [m.names[i] for i in fit.reduction.kept]
    base_cols = np.array([ext.index(n) for n in kept_names], int)
    cand_cols = [np.array([i for i in params_of(ext, c) if ext.names[i] not in m.names], int) for c in cands]
    allc = np.unique(np.concatenate([base_cols] + [c for c in cand_cols if c.size])).astype(int)
    ev = core.evaluate(
        ext.packed,
        th_ext,
        data.Q,
        _loads(ext, data),
        data.posture,
        _marker_index(ext, data),
        data.xyz,
        w,
        allc,
        ext.eqit,
        1e-9,
    )
    J, r = ev["jac"], -ev["res"]  # r: measured - predicted (weighted)
    col = {c: k for k, c in enumerate(allc)}
    A = J[:, [col[c] for c in base_cols]]
    nobs = 3 * int(np.sum(w > 0))
    rss = float(r @ r)
    p = int(fit.reduction.kept.size)
    check_residual(data.path, data.n, copies, nobs, p, 3)
    nres = nobs - p
    s2 = (sig_decl**2) if sig_decl else rss / nres
    sigma = math.sqrt(s2)
    # adequacy
    if sig_decl:
        test, stat, dof = "chi2", rss / s2, float(nres)
        log_p = core_calib.chi2_logsf(stat, dof)
        source = "declared"
    else:
        test, stat, dof, log_p = "held-out error (sigma not declared)", float("nan"), float(nres), 0.0
        source = "estimated from the residual"
    labels = [data.configs[q] for q in data.posture]
    folds = folds_of(labels, cv_folds)
    npts = data.n
    obs_rows = np.repeat(np.arange(npts), 3)
    dg = AbsoluteDiagnosis(
        verdict="adequate",
        sigma_position=sigma,
        sigma_source=source,
        fit=fit,
        candidates=[],
        non_identifiable=[],
        cv_rms_position_m=None,
        cv_folds=len(folds),
        data_checks=dchecks,
        test=test,
        statistic=stat,
        dof=dof,
        log_p=log_p,
        pruned=prune,
        alpha=alpha,
        residual_dof=nres,
        n_copied=copies,
    )
    # 2. candidates: score tests in one core call (the held-out errors below)
    ranked = [] if prune else _score_candidates(dg, ext, cands, cand_cols, J, col, A, r, s2, sig_decl, nres, w)
    # the multiplicity of the candidates (one rule, both kinds: diagnosis.corrected_p): the best
    # candidate's corrected test is part of the verdict, and a proposal must pass its own
    dg.n_tests = len(ranked)
    dg.bonferroni_p = bonferroni(ranked[0][0].p_value, len(ranked)) if ranked else None
    blocks = [J[:, [col[x] for x in cols]] for _c, cols in ranked]
    corrected: dict[int, float] = {}

    def significant(c: Candidate) -> bool:
        """Significant after the multiplicity of the candidates (max-score test)."""
        if id(c) not in corrected:
            corrected[id(c)], _ = corrected_p(A, blocks, c.log_p, alpha, 0 if sig_decl else nres)
        return corrected[id(c)] < alpha

    if ranked:
        dg.multiplicity_p, dg.nsim = corrected_p(A, blocks, ranked[0][0].log_p, alpha, 0 if sig_decl else nres)
        corrected[id(ranked[0][0])] = dg.multiplicity_p
        dg.best_inadequate = dg.multiplicity_p < alpha
        if dg.best_inadequate:
            dg.verdict = "inadequate"
    top = ranked[:CV_TOP]
    # every held-out error of the diagnosis (the model's, without each of its effects, with each
    # leading candidate) on one factorisation per fold of the model's and those candidates' columns
    extra = np.unique(np.concatenate([np.zeros(0, int)] + [np.array([col[x] for x in cols], int) for _c, cols in top]))
    p_a = A.shape[1]
    cvf = FoldFactors(np.hstack([A, J[:, extra]]), r, obs_rows, folds)
    at = {int(k): p_a + i for i, k in enumerate(extra)}  # Jacobian column -> column of the factors

    def cv_of(cols: np.ndarray, shift_cols: np.ndarray | None = None, shift: np.ndarray | None = None) -> float | None:
        return _cv_rms(cvf.held_out(cols, shift_cols, shift), w)

    cv_base = dg.cv_rms_position_m = cv_of(np.arange(p_a))
    # 4. backward steps: the effects already in the model
    kept = fit.reduction.kept
    dg.backward, dg.removal = backward_steps(
        list(m.effects),
        np.array([m.params[i].effect for i in kept], int),
        theta[kept],
        A,
        r,
        s2,
        bool(sig_decl),
        nres,
        None,
        cv_base,
        lambda e: _rms_points(e, w),
        alpha,
        free_effects={p.effect for p in m.params if p.free},
        cv_without=lambda rest, own, coef: cv_of(rest, own, coef),
    )
    if prune:
        _prune_verdict(dg, data, fit, w, sig_decl, alpha)
    else:
        # held-out errors by linearised CV of the leading candidates
        for cand, cols in top:
            e = cvf.held_out(np.concatenate([np.arange(p_a), [at[col[x]] for x in cols]]).astype(int))
            cand.cv_rms_position_m, cand._cv = _cv_rms(e, w), _cv_per_posture(e, w, data.posture)
        # 3. nothing fits (one rule, both kinds: diagnosis.catalogue_fails; with the noise known), the proposal
        if sig_decl and (dg.verdict == "inadequate" or log_p < math.log(alpha)):
            noise = Noise(s2, "declared", nres)
            dg.nothing_fits, dg.together_fraction = catalogue_fails([c for c, _ in ranked], A, r, noise, alpha)
        propose(
            dg,
            ranked,
            top,
            m,
            theta,
            kept_names,
            data,
            w,
            A,
            r,
            J,
            col,
            cv_base,
            ext.names,
            sig_decl,
            log_p,
            alpha,
            significant,
        )
    held_for_addition(dg)
    for c in dg.candidates:
        del c._pr, c._cols, c._cv
    for i, t in enumerate(dg.ties):  # name the command that plans the postures to tell them apart
        # (bare --discriminate takes the first tie; the others are named by their labels)
        tied = t.get("candidates") if i else None
        t["plan_command"], t["plan_select"] = plan_command(model.path, data.path, data.n_postures, tied)
    if not sig_decl:
        dg.warnings.append(
            "no sigma_position declared: the residual cannot be called noise by a chi-square test; the verdict "
            "rests on the held-out error (an effect is proposed only when it lowers it)"
        )
    few = few_dof_warning(nres, nobs, p)
    if few:
        dg.warnings.append(few)
    return dg


def diagnose_loop(
    model_of: Callable[[list[dict]], TreeModel],
    data: AbsoluteData,
    start: list[dict],
    steps: int = 8,
    prune_steps: int = 4,
    **kw: object,
) -> tuple[list[dict], list[AbsoluteDiagnosis]]:
    """The user's loop on absolute data: diagnose; delete the effect proposed
    for removal, or append the proposal; again, at most ``steps`` times;
    then diagnose with ``prune=True`` until nothing is proposed for removal
    (at most ``prune_steps`` times). ``model_of(effects)`` builds the model
    of a list of [[effect]] tables; ``kw`` goes to :func:`diagnose_absolute`.
    Returns the final effects and every diagnosis, in order."""
    effects = [dict(e) for e in start]
    seen: list[AbsoluteDiagnosis] = []
    for _ in range(steps):
        dg = diagnose_absolute(model_of(effects), data, **kw)
        seen.append(dg)
        if dg.removal is not None:
            effects.pop(dg.removal.index)
        elif dg.proposal is not None:
            effects.append(dict(dg.proposal.effect))
        else:
            break
    for _ in range(prune_steps):
        dg = diagnose_absolute(model_of(effects), data, prune=True, **kw)
        seen.append(dg)
        if dg.removal is None:
            break
        effects.pop(dg.removal.index)
    return effects, seen


def _prune_verdict(
    dg: AbsoluteDiagnosis, data: AbsoluteData, fit: AbsoluteFit, w: np.ndarray, sig_decl: float | None, alpha: float
) -> None:
    """The verdict of the model's adequacy test when only pruning: chi-square
    against the declared sigma, else the residual's structure."""
    if sig_decl:
        dg.verdict = "inadequate" if dg.log_p < math.log(alpha) else "adequate"
    else:
        structure_verdict(dg, data, fit, w)
        dg.nothing_fits = False  # no candidate was looked at
        if dg.verdict == "inadequate":
            dg.reasons.append("(diagnose without --prune ranks the effects that could explain it)")


def _score_candidates(
    dg: AbsoluteDiagnosis,
    ext: TreeModel,
    cands: list[dict],
    cand_cols: list[np.ndarray],
    J: np.ndarray,
    col: dict,
    A: np.ndarray,
    r: np.ndarray,
    s2: float,
    sig_decl: float | None,
    nres: int,
    w: np.ndarray,
) -> list[tuple[Candidate, np.ndarray]]:
    """Inert candidates listed with their reason, the others scored and
    ranked (best first) with their columns (indices of the extended model)."""
    sigma = math.sqrt(s2)
    norms = np.linalg.norm(J, axis=0)
    biggest: dict[str, float] = {}
    for c, k in col.items():
        kind = ext.params[c].kind
        biggest[kind] = max(biggest.get(kind, 0.0), float(norms[k]))
    # the structure first: which per-joint candidates can act, so that an `all` candidate
    # is scored on the joints that can
    acting_cols: dict[str, list[np.ndarray]] = {}
    inert: list[str] = []
    for c, cols in zip(cands, cand_cols):
        why = inert_reason(ext, c)
        if not why and c.get("target") != "all":
            why = numerical_inert(ext, cols, J[:, [col[x] for x in cols]], biggest, sigma)
        inert.append(why)
        if not why and c.get("target") not in (None, "all"):  # per-joint kinds, and `mass` per link
            acting_cols.setdefault(c["kind"], []).append(cols)
    # the same columns as an earlier candidate of its kind: one effect under two names
    for kind in {c["kind"] for c in cands}:
        idx = [k for k, c in enumerate(cands) if c["kind"] == kind and c.get("target") != "all" and not inert[k]]
        dup = duplicate_of([J[:, [col[x] for x in cand_cols[k]]] for k in idx])
        for k, d in zip(idx, dup):
            if d >= 0:
                first = cands[idx[d]]
                inert[k] = f"duplicates {first['kind']}:{first.get('target', first['kind'])} (the same columns)"
    blocks = []
    for c, cols, why in zip(cands, cand_cols, inert):
        cand = Candidate(kind=c["kind"], target=c.get("target", c["kind"]), effect=dict(c))
        if c.get("target") == "all" and not why:
            parts = acting_cols.get(c["kind"], [])
            cols = np.unique(np.concatenate(parts)) if parts else np.zeros(0, int)
            if cols.size == 0:
                why = "no joint of this kind can move a marker"
        if why:
            cand.reason = why
            dg.non_identifiable.append(cand)
        else:
            blocks.append((cand, cols))
    rss = float(r @ r)
    noise = Noise(s2, "declared" if sig_decl else "residual", nres)
    ranked = []
    st, df, _pr = score_blocks(A, r, [J[:, [col[x] for x in cols]] for _c, cols in blocks])
    for k, (cand, cols) in enumerate(blocks):
        d = int(df[k])
        if d == 0:
            cand.reason = "spanned by the model: its columns are combinations of the model's"
            dg.non_identifiable.append(cand)
            continue
        fill_scores(cand, float(st[k]), d, noise, rss)
        cand.rms_after_m = math.sqrt(max(rss - st[k], 0.0) / max(np.sum(w > 0), 1))
        # for the tie rule (diagnosis.tie_rivals): explained part, columns, held-out error per posture
        cand._pr, cand._cols, cand._cv = _pr[:, k], J[:, [col[x] for x in cols]], None
        ranked.append((cand, cols))
    ranked.sort(key=lambda x: x[0].log_p)
    dg.candidates = [c for c, _ in ranked]
    return ranked


def _robust_sigma(res: np.ndarray) -> float:
    d = np.linalg.norm(res, axis=1)
    return float(np.median(d)) / math.sqrt(2.366) if d.size else 1.0


def _rms_points(e: np.ndarray, w: np.ndarray) -> float:
    """RMS point error (m) of a weighted residual (3 per point; weights w per point, rows of weight 0 left out)."""
    e = e.reshape(-1, 3)
    use = w > 0
    d2 = np.sum(e[use] ** 2, axis=1) / w[use]
    return float(math.sqrt(np.mean(d2))) if d2.size else 0.0


def _cv_per_posture(e: np.ndarray, w: np.ndarray, posture: np.ndarray) -> np.ndarray | None:
    """Mean squared held-out point error (m^2) of each posture (for the
    paired comparison of the tie rule); None when no fold could be fitted."""
    e = e.reshape(-1, 3)
    sw = np.sqrt(np.where(w > 0, w, np.nan))
    d2 = np.sum((e / sw[:, None]) ** 2, axis=1)
    ok = np.isfinite(d2)
    if not ok.any():
        return None
    n = int(posture.max()) + 1
    tot = np.bincount(posture[ok], weights=d2[ok], minlength=n)
    cnt = np.bincount(posture[ok], minlength=n)
    return np.where(cnt > 0, tot / np.maximum(cnt, 1), np.nan)


def _cv_rms(e: np.ndarray, w: np.ndarray) -> float | None:
    """Held-out RMS point error (m) of held-out weighted residuals e (3 per
    point; crossval.FoldFactors: the linearised model by folds of
    configurations); weights w per point (rows of weight 0 left out)."""
    e = e.reshape(-1, 3)
    sw = np.sqrt(np.where(w > 0, w, np.nan))
    d2 = np.sum((e / sw[:, None]) ** 2, axis=1)
    ok = np.isfinite(d2)
    return float(math.sqrt(np.mean(d2[ok]))) if ok.any() else None
