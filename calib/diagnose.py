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
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .._core import calib as core
from ..errors import InputError
from ..robot.model import Model, compensator_h, default_tau0, expand_effect
from . import crossval as CV
from . import residual_map as RM
from .fit import FitResult, Problem, as_inputs, fit, identified_model
from .measure import Measurements
from .robust import DataChecks, check_data, format_checks

if TYPE_CHECKING:
    from ..robot.model import Term
    from ..robot.urdf import Chain

ALPHA = 0.01
ZTOL = 1e-6  # a projected unit column shorter than this adds nothing
DUPLICATE_COS = 0.99
TIE_LOG10 = 1.0  # within a factor 10 of the leader's p-value: undecidable
CV_FOLDS = 5
CV_TOP = 5  # held-out error for this many leading candidates (and every tied one)
NOTHING_FITS = 0.5  # the leader explains less than this fraction of the excess residual
TOGETHER_FITS = 0.8  # ... unless the leading few together explain this much
LOW_DOF = 30  # fewer residual degrees of freedom than this (or than half the observations): warn
OVERFIT = 0.8  # an adequate RMS below this fraction of the noise floor: warn
NSIM = 999  # Monte Carlo draws of the max-score test
EQUIVALENT = 1e-6  # tied fits predicting the same to this relative level everywhere are one effect
COMPENSATOR_MATCH = 0.9  # a compensator shape explaining this share of a joint_profile's part: hint

HINT_COMPENSATOR = (
    "posture-dependent compliance of {j} that a gravity compensator could produce (a spring between "
    "the bodies of {j} explains {r2:.0%} of what the profile explains): if {j} carries one, model it "
    'as kind = "gravity_compensator" with its geometry a, b, beta, s0 (needs a joint effect on {j}); '
    "joint_profile is its generic form"
)


@dataclass
class Candidate:
    kind: str
    target: str
    effect: dict
    statistic: float = 0.0
    dof: int = 0
    log_p: float = 0.0
    explained_fraction: float = 0.0
    rms_after_m: float = 0.0
    hint: str = ""
    indistinguishable_from: list[str] = field(default_factory=list)
    excess_fraction: float = 0.0  # share of the residual above the noise it explains
    cv_rms_position_m: float | None = None  # held-out RMS with it added
    tied_with: list[str] = field(default_factory=list)

    @property
    def label(self) -> str:
        t = self.effect.get("template")
        return f"{self.kind}:{self.target}" + (f":{t}" if t else "")

    @property
    def family(self) -> tuple[str, str]:
        """Templates of one spring are one family (nested), not rivals."""
        return (self.kind, self.target)

    @property
    def p_value(self) -> float:
        return math.exp(self.log_p) if self.log_p > -745 else 0.0

    def to_json(self) -> dict:
        d = {
            "kind": self.kind,
            "target": self.target,
            "statistic": self.statistic,
            "p_value": self.p_value,
            "explained_fraction": self.explained_fraction,
            "rms_after_m": self.rms_after_m,
            "effect": self.effect,
            "dof": self.dof,
            "log10_p_value": self.log_p / math.log(10),
            "excess_fraction": self.excess_fraction,
            "cv_rms_position_m": self.cv_rms_position_m,
        }
        if self.hint:
            d["hint"] = self.hint
        if self.indistinguishable_from:
            d["indistinguishable_from"] = self.indistinguishable_from
        if self.tied_with:
            d["tied_with"] = self.tied_with
        return d


@dataclass
class Diagnosis:
    verdict: str
    test: str  # "chi2" or "lack-of-fit F"
    statistic: float
    dof: float
    log_p: float
    sigma_position: float
    sigma_source: str  # declared | pure error
    fit: FitResult  # on the rows kept after the data checks
    candidates: list[Candidate]
    non_identifiable: list[Candidate]
    alpha: float = ALPHA
    fit_all: FitResult | None = None  # on every row
    data_checks: DataChecks | None = None
    verdict_all_rows: str | None = None
    log_p_all_rows: float | None = None
    multiplicity_p: float | None = None
    bonferroni_p: float | None = None
    n_tests: int = 0
    nsim: int = 0
    omnibus_inadequate: bool = False
    best_inadequate: bool = False
    cv_rms_position_m: float | None = None
    cv_folds: int = 0
    ties: list[dict] = field(default_factory=list)
    nothing_fits: bool = False
    together_fraction: float | None = None
    excess: float = 0.0
    scale2: float = 1.0  # the residual's sums of squares over this are in chi-square units
    proposal: Candidate | None = None
    reasons: list[str] = field(default_factory=list)  # why no proposal
    warnings: list[str] = field(default_factory=list)
    residual_map: list[RM.Feature] = field(default_factory=list)
    shapes: list[dict] = field(default_factory=list)  # binned residual along the leading features

    @property
    def p_value(self) -> float:
        return math.exp(self.log_p) if self.log_p > -745 else 0.0

    @property
    def floor(self) -> float:
        return math.sqrt(3) * self.sigma_position

    def to_json(self) -> dict:
        dc = self.data_checks
        return {
            "verdict": self.verdict,
            "sigma_position_m": self.sigma_position,
            "rms_position_m": self.fit.rms_position,
            "candidates": [c.to_json() for c in self.candidates],
            # extensions
            "test": self.test,
            "statistic": self.statistic,
            "dof": self.dof,
            "p_value": self.p_value,
            "log10_p_value": self.log_p / math.log(10),
            "alpha": self.alpha,
            "sigma_source": self.sigma_source,
            "noise_floor_position_m": self.floor,
            "non_identifiable_candidates": [
                {"kind": c.kind, "target": c.target, "effect": c.effect} for c in self.non_identifiable
            ],
            "omnibus_inadequate": self.omnibus_inadequate,
            "multiplicity_p": self.multiplicity_p,
            "multiplicity_method": (
                f"max-score test over {self.n_tests} candidates, Monte Carlo ({self.nsim} draws)"
                if self.nsim
                else f"Bonferroni bound over {self.n_tests} candidates (far below alpha)"
            ),
            "bonferroni_p": self.bonferroni_p,
            "best_candidate_inadequate": self.best_inadequate,
            "data_checks": dc.to_json() if dc is not None else None,
            "n_rows": int(self.fit.measured.shape[0]),
            "n_rows_all": int(self.fit_all.measured.shape[0]) if self.fit_all is not None else None,
            "rms_position_all_rows_m": self.fit_all.rms_position if self.fit_all is not None else None,
            "verdict_all_rows": self.verdict_all_rows,
            "residual_dof": self.fit.dof,
            "cv_rms_position_m": self.cv_rms_position_m,
            "cv_folds": self.cv_folds,
            "ties": self.ties,
            "nothing_fits": self.nothing_fits,
            "together_excess_fraction": self.together_fraction,
            "proposal": self.proposal.effect if self.proposal is not None else None,
            "no_proposal_reasons": self.reasons,
            "warnings": self.warnings,
            "residual_map": [f.to_json() for f in self.residual_map],
            "residual_shapes": self.shapes,
        }


def candidate_tables(model: Model, tau0: dict | None = None) -> list[tuple[dict, str]]:
    """Every contract kind on every target the model does not already have:
    (effect table, hint). ``tau0`` {joint: N m} gives the smoothing torque
    of the joint_deadzone candidates (from the data's torque scale)."""
    ch = model.chain
    out = []
    joints = ch.actuated
    for j in joints:
        if not model.has("joint", j):
            out.append(({"kind": "joint", "target": j}, ""))
    for j in joints:
        if not model.has("joint_profile", j):
            out.append(({"kind": "joint_profile", "target": j}, ""))
    for j in joints:
        if not model.has("joint_cubic", j):
            out.append(({"kind": "joint_cubic", "target": j}, ""))
    for j in joints:
        if not model.has("joint_deadzone", j):
            t0 = (tau0 or {}).get(j, 1.0)
            out.append(({"kind": "joint_deadzone", "target": j, "tau0": t0}, ""))
    have = {(t.source, t.target, t.template) for t in model.terms if t.kind == "six"}
    for link in ch.links:
        if ch.is_tool_spring(link):  # its spring is the tool spring: offered as kind tool
            continue
        for tpl in ("beam", "diagonal", "full"):
            if ("link", link, tpl) not in have:
                out.append(({"kind": "link", "target": link, "template": tpl}, ""))
    last = [ln for ln in ch.links if ch.is_tool_spring(ln)]
    for kind in ("base", "tool"):
        for tpl in ("diagonal", "full"):
            if (kind, kind, tpl) not in have and not (kind == "tool" and any(("link", ln, tpl) in have for ln in last)):
                hint = (
                    f"the tool spring is also the spring of link {last[0]!r} (same frame)"
                    if kind == "tool" and last
                    else ""
                )
                out.append(({"kind": kind, "template": tpl}, hint))
    if not any(t.kind == "point_offset" for t in model.terms):
        out.append(({"kind": "point_offset"}, ""))
    return out


def pure_error(pb: Problem, meas: Measurements) -> tuple[float, int]:
    """Sum of squares and degrees of freedom of replicated rows (same q, w, p)."""
    key = np.round(np.hstack([meas.q, meas.w, meas.p]), 12)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    y = pb.y[: pb.rows].T  # (n, rows), unweighted
    ss, dof = 0.0, 0
    for g in np.nonzero(counts > 1)[0]:
        rows = y[inv == g]
        ss += float(((rows - rows.mean(axis=0)) ** 2).sum())
        dof += (rows.shape[0] - 1) * pb.rows
    return ss, dof


def logsf_chi2(x: float, k: float) -> float:
    return core.chi2_logsf(x, k)


def logsf_f(f: float, d1: float, d2: float) -> float:
    return core.f_logsf(f, d1, d2)


def _adequacy(
    res: FitResult, pb: Problem, meas: Measurements
) -> tuple[str, float, int, float, float, str, float, int | None]:
    """(test, statistic, dof, log p, sigma, source, scale2, d_pe)."""
    if pb.sigma_declared:
        stat, dof = res.chi2, res.dof
        return (
            "chi2",
            stat,
            dof,
            (logsf_chi2(stat, dof) if dof > 0 else 0.0),
            float(pb.sigma_position),
            "declared",
            1.0,
            None,
        )
    ss_pe, d_pe = pure_error(pb, meas)
    if d_pe == 0:
        raise InputError(
            f"{meas.path}: no [measurements] sigma_position in the model and no "
            f"replicated rows (same posture, wrench and point): the noise level is "
            f"unknown, so adequacy cannot be tested; declare sigma_position or "
            f"repeat measurements"
        )
    s2 = ss_pe / d_pe
    if not s2 > 0:
        raise InputError(
            f"{meas.path}: the replicated rows (same posture, wrench and point) repeat each other exactly "
            f"(pure error 0): they look copied, not measured again, so they tell nothing about the noise; "
            f"declare sigma_position or remove the copies"
        )
    d_lof = res.dof - d_pe
    if d_lof > 0:
        stat = ((res.chi2 - ss_pe) / d_lof) / s2
        dof, log_p = d_lof, logsf_f(stat, d_lof, d_pe)
    else:
        stat, dof, log_p = 0.0, 0, 0.0
    return "lack-of-fit F", stat, dof, log_p, math.sqrt(s2), "pure error", s2, d_pe


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
    cv_folds : folds of the cross-validation by configuration (0: none)
    nsim, seed : Monte Carlo draws of the max-score test

    Returns
    -------
    Diagnosis : verdict, tests, the fit on the kept rows, candidates ranked
        best first (log p of the score test) with their held-out error,
        ties, whether nothing fits, the proposal (or why none), warnings,
        the residual map; ``.to_json()`` has the contract keys.
    """

    model, meas = as_inputs(model, meas)
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
    res_all = fit(model, meas, problem=pb)
    test, stat, dof, log_p, sigma, source, scale2, d_pe = _adequacy(res_all, pb, meas)
    dc = check_data(res_all, alpha=alpha) if checks else None
    res, log_p_all, verdict_all = res_all, None, None
    if dc is not None and dc.set_aside:
        log_p_all = log_p
        verdict_all = "adequate" if log_p >= math.log(alpha) else "inadequate"
        keep = np.setdiff1d(np.arange(meas.n), dc.set_aside)
        meas = meas.subset(keep)
        pb = Problem(model, meas, extra_terms=flat, sigma_position=sigma_position)
        res = fit(model, meas, problem=pb)
        test, stat, dof, log_p, sigma, source, scale2, d_pe = _adequacy(res, pb, meas)
    nobs = res.nobs
    omnibus = log_p < math.log(alpha)

    # candidate columns, linearised at the fit
    fitted = identified_model(res)
    base_terms = fitted.terms
    Z, cstart = [], [1]
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
        cstart.append(cstart[-1] + Z[-1].shape[1])
    A = res.A if res.A.shape[1] else np.zeros((nobs, 1))
    Zall = np.hstack(Z) if Z else np.zeros((nobs, 0))
    if Z:
        stat_c, dof_c, pr = core.score(A, res.r, Zall, np.array(cstart, np.int32), 1e-10, ZTOL)
    rr = float(res.r @ res.r)
    excess = rr / scale2 - res.dof  # residual above the noise, in chi-square units
    wp = float(pb.wrow[0])
    npts = meas.n
    rpos = res.r[: 3 * npts].reshape(3, npts)
    ranked, spanned = [], []
    for c, (table, hint) in enumerate(cands):
        cand = Candidate(kind=table["kind"], target=table.get("target", table["kind"]), effect=dict(table), hint=hint)
        if dof_c[c] == 0:
            spanned.append(cand)
            continue
        cand.dof = int(dof_c[c])
        cand.statistic = float(stat_c[c] / scale2)
        if d_pe is None:
            cand.log_p = logsf_chi2(cand.statistic, cand.dof)
        else:
            cand.log_p = logsf_f(cand.statistic / cand.dof, cand.dof, d_pe)
        cand.explained_fraction = float(stat_c[c] / rr) if rr > 0 else 0.0
        cand.excess_fraction = float((cand.statistic - cand.dof) / excess) if excess > 0 else 0.0
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
        lobs = ranked[0].log_p
        bonf_p = min(1.0, len(ranked) * ranked[0].p_value)
        # the corrected p lies between the best p (one test) and Bonferroni's bound:
        # when both sides of alpha are settled, fewer draws give its value
        settled = ranked[0].p_value >= alpha or bonf_p < alpha
        nsim_used = min(nsim, 199) if settled else nsim
        if bonf_p < 0.01 * alpha:
            # Bonferroni's bound is far below alpha: the alarm is certain, the bound is reported
            mult_p, nsim_used = bonf_p, 0
        else:
            mult_p = core.max_score(A, Zall, np.array(cstart, np.int32), 1e-10, ZTOL, lobs, d_pe or 0, nsim_used, seed)
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
    folds = CV.config_folds(meas.config, cv_folds) if cv_folds else []
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
        cv_folds=len(folds) if len(folds) >= 2 else 0,
        excess=excess,
        scale2=scale2,
    )
    _rank_honestly(dg, pb, res, A, model, cterms, cands, sig)
    _warnings(dg, nobs)
    if verdict == "inadequate" and (dg.nothing_fits or dg.proposal is None):
        feats = RM.features(pb)
        dg.residual_map = RM.score_features(pb, A, res.r, feats, scale2, excess)
        dg.shapes = [residual_shape(pb, res, f) for f in dg.residual_map[:3]]
    for c in ranked:
        del c._pr, c._cols, c._index, c._cv
    return dg


def residual_shape(pb: Problem, res: FitResult, f: RM.Feature, bins: int = 6) -> dict:
    """The residual binned along a feature's variable: the joint rotation
    that best explains each row against the joint's torque or angle, the
    positional residual along the row order, or per configuration."""
    out = {"feature": f.name, "kind": f.kind, "target": f.target}
    if f.kind in ("torque", "angle"):
        jr = RM.joint_residuals(pb, res.residuals)[f.target]
        b = RM.binned(jr["tau" if f.kind == "torque" else "q"], jr["dq"], bins)
        out.update(x_unit="N m" if f.kind == "torque" else "rad", y_unit="rad", **b)
    elif f.kind == "order":
        idx = np.arange(res.residuals.shape[0], dtype=float)
        out.update(x_unit="row", y_unit="m")
        for a in range(3):
            b = RM.binned(idx, res.residuals[:, a], bins)
            out["x"] = b["x"]
            out[f"mean_d{'xyz'[a]}"] = b["mean"]
    else:
        e = np.linalg.norm(res.residuals, axis=1)
        per = {}
        for i, c in enumerate(pb.meas.config):
            per.setdefault(c, []).append(e[i])
        rms = sorted(((float(np.sqrt(np.mean(np.square(v)))), c) for c, v in per.items()), reverse=True)
        out.update(worst=[{"config": c, "rms_position_m": r} for r, c in rms[:5]])
    return out


def _shape_lines(sh: dict) -> list[str]:
    if sh["kind"] in ("torque", "angle"):
        xs = "".join(f"{v:10.4g}" for v in sh["x"])
        ys = "".join(f"{v * 1e6:10.3g}" for v in sh["mean"])
        return [
            f"  {sh['feature']}, binned ({sh['x_unit']}):{'':2s}{xs}",
            f"  {'mean joint rotation residual (urad):':{len(sh['feature']) + 14}s}{ys}",
        ]
    if sh["kind"] == "order":
        lines = [f"  {'row order, binned (row):':34s}" + "".join(f"{v:9.0f}" for v in sh["x"])]
        for a in "xyz":
            lines.append(
                f"  {'mean d' + a + ' residual (mm):':34s}" + "".join(f"{v * 1e3:9.3g}" for v in sh[f"mean_d{a}"])
            )
        return lines
    return [
        "  worst configurations: "
        + ", ".join(f"{w['config']} ({w['rms_position_m'] * 1e3:.3g} mm)" for w in sh["worst"])
    ]


def _nested(A: np.ndarray, Zs: np.ndarray, Zb: np.ndarray) -> bool:
    """Do the columns Zb span Zs off the model A (the smaller candidate is
    part of the bigger one, e.g. a joint's column in the next link's
    spring)?"""
    AZ = np.hstack([A, Zb])
    _, dof, _ = core.score(AZ, np.zeros(AZ.shape[0]), Zs, np.array([1, Zs.shape[1] + 1], np.int32), 1e-10, ZTOL)
    return int(dof[0]) == 0


def _cos(a: np.ndarray, b: np.ndarray) -> float:
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    return float(a @ b) / (na * nb) if na > 0 and nb > 0 else 0.0


def _cv(
    A: np.ndarray,
    r: np.ndarray,
    obs_rows: np.ndarray,
    folds: list[np.ndarray],
    npts: int,
    wp: float,
    labels: Sequence[object],
) -> tuple[float | None, np.ndarray | None]:
    """Held-out positional RMS (m) and the mean squared held-out error of
    each configuration (for paired comparisons); (None, None) when no fold
    can be fitted."""
    e = CV.held_out_residuals(A, r, obs_rows, folds)
    if not np.any(np.isfinite(e)):
        return None, None
    sq = np.sum((e.reshape(-1, npts)[0:3] / wp) ** 2, axis=0)
    _, idx = np.unique(np.asarray(labels, dtype=object).astype(str), return_inverse=True)
    ok = np.isfinite(sq)
    tot = np.bincount(idx[ok], weights=sq[ok], minlength=idx.max() + 1)
    cnt = np.bincount(idx[ok], minlength=idx.max() + 1)
    per = np.where(cnt > 0, tot / np.maximum(cnt, 1), np.nan)
    return CV.rms_rows(e, npts, coords=(0, 1, 2), scale=1.0 / wp), per


def _cv_better(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    """Paired comparison over configurations: is b's held-out error
    significantly below a's (t < -2)?"""
    if a is None or b is None or a.size < 3:
        return False
    d = b - a
    d = d[np.isfinite(d)]
    if d.size < 3:
        return False
    se = float(np.std(d, ddof=1)) / math.sqrt(d.size)
    return bool(se > 0 and d.mean() / se < -2.0)


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
    tied = []
    if L.log_p < sig:
        for c in ranked[1:]:
            if c.family == L.family or c.log_p >= sig:
                continue
            if c.dof > L.dof and _cos(L._pr, c._pr) > DUPLICATE_COS and _nested(A, L._cols, c._cols):
                continue  # the leader's columns plus more: the leader is the parsimonious choice
            close_p = (c.log_p - L.log_p) / math.log(10) <= TIE_LOG10
            # held-out error contradicting the ranking: c predicts new configurations significantly better
            close_cv = _cv_better(L._cv, c._cv)
            if close_p or close_cv:
                if all(t.family != c.family for t in tied):
                    tied.append(c)
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
    if dg.verdict == "inadequate" and dg.excess > 0:
        if L.excess_fraction < NOTHING_FITS:
            fams, blocks = [], []
            for c in ranked:
                if c.family not in fams and c.log_p < sig:
                    fams.append(c.family)
                    blocks.append(c._cols)
                if len(blocks) == 3:
                    break
            together = L.excess_fraction
            if len(blocks) > 1:
                Zt = np.hstack(blocks)
                st, dt, _ = core.score(A, res.r, Zt, np.array([1, Zt.shape[1] + 1], np.int32), 1e-10, ZTOL)
                together = float((st[0] / dg.scale2 - dt[0]) / dg.excess)
            dg.together_fraction = together
            # ... and the leader leaves the model inadequate (else the excess was mostly noise)
            rest = float(res.r @ res.r) / dg.scale2 - L.statistic
            rest_dof = res.dof - L.dof
            left = logsf_chi2(rest, rest_dof) < sig if rest_dof > 0 else False
            dg.nothing_fits = together < TOGETHER_FITS and left
    # the proposal
    if dg.verdict != "inadequate":
        if dg.data_checks is not None and dg.data_checks.set_aside:
            dg.reasons.append("the model fits the data once the rows listed by the data checks are set aside")
        return
    if dg.nothing_fits:
        dg.reasons.append(
            f"nothing in the catalogue fits: the best candidate explains {100 * L.excess_fraction:.0f} % of the "
            f"residual above the noise"
        )
    if tied:
        dg.reasons.append(f"undecidable: {', '.join([L.label] + [c.label for c in tied])} fit these data about as well")
    if L.cv_rms_position_m is not None and cv0 is not None and not L.cv_rms_position_m < cv0:
        dg.reasons.append(
            f"{L.label} does not lower the held-out error ({cv0 * 1e3:.4g} -> {L.cv_rms_position_m * 1e3:.4g} mm)"
        )
    if L.log_p >= sig:
        dg.reasons.append(
            f"no single candidate is significant on its own (best log10 p = {L.log_p / math.log(10):.3g})"
        )
    if not dg.reasons:
        dg.proposal = L
        if L.kind == "joint_profile":
            r2 = compensator_shape_match(pb, res, L, dg.scale2)
            if r2 >= COMPENSATOR_MATCH:
                L.hint = HINT_COMPENSATOR.format(j=L.target, r2=r2)


def _warnings(dg: Diagnosis, nobs: int) -> None:
    res = dg.fit
    if res.dof < LOW_DOF or res.dof < 0.5 * nobs:
        dg.warnings.append(
            f"few residual degrees of freedom: {res.dof} of {nobs} observations ({len(res.names)} parameters); "
            f"the tests have little power and a fit absorbs part of the noise (expected RMS "
            f"{math.sqrt(max(res.dof, 0) / nobs):.2f} x the noise floor); judge by the held-out error"
        )
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


def format_diagnosis(dg: Diagnosis, top: int = 10) -> str:
    r = dg.fit
    lines = []
    dc = dg.data_checks
    if dc is not None and not dc.clean:
        lines.append("data checks (before blaming the model):")
        lines += ["  " + s for s in format_checks(dc).splitlines()]
        if dc.set_aside and dg.fit_all is not None:
            lines.append(
                f"  with these {len(dc.set_aside)} rows: RMS {dg.fit_all.rms_position * 1e3:.4g} mm, verdict "
                f"{dg.verdict_all_rows}; without them: RMS {r.rms_position * 1e3:.4g} mm (noise floor "
                f"{dg.floor * 1e3:.4g} mm)"
            )
        lines.append("")
    lines += [
        f"adequacy ({dg.test}): statistic {dg.statistic:.4g} on {dg.dof:g} dof, "
        f"log10 p = {dg.log_p / math.log(10):.3g}  ->  {dg.verdict.upper()} (alpha {dg.alpha:g})",
    ]
    if dg.multiplicity_p is not None:
        if dg.nsim:
            bound = dg.multiplicity_p <= 1.0 / (dg.nsim + 1) + 1e-12
            how = (
                f"p {'<=' if bound else '='} {dg.multiplicity_p:.3g} (max-score test; Bonferroni {dg.bonferroni_p:.3g})"
            )
        else:
            how = f"p <= {max(dg.bonferroni_p, 1e-300):.3g} (Bonferroni bound)"
        lines.append(
            f"best candidate, corrected for looking at all {dg.n_tests}: {how}"
            + ("  -> alarm" if dg.best_inadequate else "")
        )
    cv = dg.cv_rms_position_m
    lines.append(
        f"noise sigma {dg.sigma_position * 1e3:.4g} mm ({dg.sigma_source}); noise floor "
        f"sqrt(3) sigma = {dg.floor * 1e3:.4g} mm; positional RMS now "
        f"{r.rms_position * 1e3:.4g} mm"
        + (f"; held-out ({dg.cv_folds} folds by configuration) {cv * 1e3:.4g} mm" if cv is not None else "")
    )
    for w in dg.warnings:
        lines.append(f"warning: {w}")
    if dg.candidates:
        lines.append("")
        lines.append(
            f"{'rank':>4s}  {'candidate':34s}{'dof':>4s}{'statistic':>12s}{'log10 p':>10s}"
            f"{'explains':>10s}{'excess':>8s}{'RMS after':>11s}{'held-out':>10s}  (mm)"
        )
        for i, c in enumerate(dg.candidates[:top], 1):
            cvs = f"{c.cv_rms_position_m * 1e3:10.4g}" if c.cv_rms_position_m is not None else f"{'':>10s}"
            lines.append(
                f"{i:4d}  {c.label:34s}{c.dof:4d}{c.statistic:12.4g}{c.log_p / math.log(10):10.3g}"
                f"{100 * c.explained_fraction:9.1f}%{100 * c.excess_fraction:7.0f}%{c.rms_after_m * 1e3:11.4g}{cvs}"
            )
            if c.indistinguishable_from:
                lines.append(f"{'':6s}the data cannot tell it apart from: {', '.join(c.indistinguishable_from)}")
    for t in dg.ties:
        lines.append("")
        lines.append(
            f"undecidable: {', '.join(t['candidates'])} fit these data about as well (within "
            f"{TIE_LOG10:g} in log10 p, or better on held-out configurations); adding one of them would be a guess."
        )
        for s in t["separate_by"]:
            ds = s.get("difference_sigma")
            sig = f" = {ds:.3g} sigma" if ds is not None else ""
            lines.append(
                f"  to separate {s['candidates'][0]} from {s['candidates'][1]}: measure at {s['posture_source']} "
                f"q = ({', '.join(f'{v:.3f}' for v in s['posture'])}) under a {s['load']}: they predict "
                f"{s['predicted_m'][0] * 1e3:.3g} and {s['predicted_m'][1] * 1e3:.3g} mm "
                f"(differ by {s['difference_m'] * 1e3:.3g} mm{sig})"
            )
            if ds is not None and ds < 3:
                reps = math.ceil((3.0 / max(ds, 1e-3)) ** 2)
                lines.append(
                    f"    that is below the noise: no single measurement separates them; about {reps} repeats "
                    f"there would (3 sigma)"
                )
    if dg.nothing_fits:
        lines.append("")
        L = dg.candidates[0] if dg.candidates else None
        msg = "nothing in the catalogue fits"
        if L is not None:
            msg += (
                f": the best candidate ({L.label}) explains {100 * max(L.excess_fraction, 0):.0f} % of the residual "
                f"above the noise"
            )
            if dg.together_fraction is not None:
                msg += f", the best three together {100 * max(dg.together_fraction, 0):.0f} %"
        lines.append(msg + ". Adding them would fit noise and shapes they do not have.")
    if dg.residual_map and dg.nothing_fits:
        lines.append("where the residual lives (share of the residual above the noise each shape takes):")
        for f in dg.residual_map[:6]:
            lp = f.log_p / math.log(10)
            lines.append(f"  {f.name:40s}{100 * f.excess_fraction:6.0f} %   ({f.dof} dof, log10 p = {lp:.3g})")
        if dg.shapes:
            lines += _shape_lines(dg.shapes[0])
        lines.append(
            "  a shape that takes most of it names the effect: torque -> a load-nonlinear joint (hardening, "
            "dead zone), angle -> a posture-dependent joint, row order -> drift of the instrument, "
            "configuration offsets -> a reference error per posture (see --plots)"
        )
    if dg.proposal is not None:
        best = dg.proposal
        lines.append("")
        gain = ""
        if best.cv_rms_position_m is not None and cv is not None:
            gain = f" (held-out RMS {cv * 1e3:.4g} -> {best.cv_rms_position_m * 1e3:.4g} mm)"
        lines.append(f"suggested: append to the model file and run fit again{gain}")
        lines.append(effect_toml(best.effect))
        if best.hint:
            lines.append(f"hint: {best.hint}")
    elif dg.verdict == "inadequate" or dg.reasons:
        lines.append("")
        lines.append("no effect is proposed: " + "; ".join(dg.reasons) if dg.reasons else "no effect is proposed")
    if dg.non_identifiable:
        lines.append("")
        lines.append(
            "non-identifiable additions (spanned by the model, or no influence on these data; "
            "not ranked): " + ", ".join(c.label for c in dg.non_identifiable)
        )
    return "\n".join(lines)


def effect_toml(effect: dict) -> str:
    out = ["[[effect]]"]
    for k, v in effect.items():
        out.append(f"{k} = {v!r}".replace("'", '"'))
    return "\n".join(out)
