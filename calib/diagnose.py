"""Model diagnosis: is what is left noise, and which effect is missing?

1. Adequacy: chi-square test of the weighted residual against the declared
   sigma (chi2 = |r/sigma|^2 with n_obs - rank degrees of freedom); without
   a declared sigma, the lack-of-fit F test against the pure error of
   replicated rows (same posture, wrench and point).
2. Candidates: every contract kind on every target the model lacks. Each is
   scored by a score (Lagrange-multiplier) test in the core: its columns
   (linearised at the current fit for nonlinear kinds) are projected off the
   model's column space; the rank left is the degrees of freedom, the part
   of the residual in that space the statistic. Candidates with nothing
   left are reported as non-identifiable, not ranked. Ranking by log
   p-value (statistic against its degrees of freedom), never the raw p.
3. Candidates that explain the same part of the residual (cosine of the
   explained parts above 0.99) are flagged: the data cannot tell them apart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._core import calib as core
from ..errors import InputError
from ..robot.model import Model, expand_effect
from .fit import FitResult, Problem, as_inputs, fit, identified_model
from .measure import Measurements

ALPHA = 0.01
ZTOL = 1e-6  # a projected unit column shorter than this adds nothing
DUPLICATE_COS = 0.99

HINT_COMPENSATOR = (
    "posture-dependent compliance of {j}: if {j} carries a gravity compensator, model it "
    'as kind = "gravity_compensator" with its geometry a, b, beta, s0 (needs a joint '
    "effect on {j}); joint_profile is its generic form"
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

    @property
    def label(self) -> str:
        t = self.effect.get("template")
        return f"{self.kind}:{self.target}" + (f":{t}" if t else "")

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
        }
        if self.hint:
            d["hint"] = self.hint
        if self.indistinguishable_from:
            d["indistinguishable_from"] = self.indistinguishable_from
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
    fit: FitResult
    candidates: list[Candidate]
    non_identifiable: list[Candidate]
    alpha: float = ALPHA

    @property
    def p_value(self) -> float:
        return math.exp(self.log_p) if self.log_p > -745 else 0.0

    def to_json(self) -> dict:
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
            "noise_floor_position_m": math.sqrt(3) * self.sigma_position,
            "non_identifiable_candidates": [
                {"kind": c.kind, "target": c.target, "effect": c.effect} for c in self.non_identifiable
            ],
        }


def candidate_tables(model: Model) -> list[tuple[dict, str]]:
    """Every contract kind on every target the model does not already have:
    (effect table, hint)."""
    ch = model.chain
    out = []
    joints = ch.actuated
    for j in joints:
        if not model.has("joint", j):
            out.append(({"kind": "joint", "target": j}, ""))
    for j in joints:
        if not model.has("joint_profile", j):
            out.append(({"kind": "joint_profile", "target": j}, HINT_COMPENSATOR.format(j=j)))
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


def logsf_chi2(x, k) -> float:
    return core.chi2_logsf(x, k)


def logsf_f(f, d1, d2) -> float:
    return core.f_logsf(f, d1, d2)


def diagnose(model: Model, meas: Measurements, sigma_position=None, alpha: float = ALPHA, kinds=None) -> Diagnosis:
    """Fit ``model``, test its adequacy and rank the missing effects (contract s4).

    Parameters
    ----------
    model, meas : as for :func:`~stiffkit.calib.fit.fit` (objects or paths)
    sigma_position : overrides the declared noise (m); without any, the pure
        error of replicated rows is used (lack-of-fit F test)
    alpha : level of the adequacy test
    kinds : restrict the candidates to these kinds

    Returns
    -------
    Diagnosis : verdict, test statistic and log p-value, the fit, candidates
        ranked best first (log p of the score test), non-identifiable
        additions; ``.to_json()`` has the contract keys.
    """

    model, meas = as_inputs(model, meas)
    cands = candidate_tables(model)
    if kinds:
        kinds = set(kinds) | ({"joint_profile"} if "gravity_compensator" in kinds else set())
        cands = [c for c in cands if c[0]["kind"] in kinds]
    n0 = len(model.effects)
    cterms = []
    for i, (table, _) in enumerate(cands):
        cterms.append(expand_effect(model.chain, table, n0 + i, "candidate"))
    pb = Problem(model, meas, extra_terms=[t for ts in cterms for t in ts], sigma_position=sigma_position)
    res = fit(model, meas, problem=pb)
    nobs = res.nobs
    # noise level
    if pb.sigma_declared:
        sigma, source = float(pb.sigma_position), "declared"
        test, stat, dof = "chi2", res.chi2, res.dof
        log_p = logsf_chi2(stat, dof) if dof > 0 else 0.0
        scale2 = 1.0
        d_pe = None
    else:
        ss_pe, d_pe = pure_error(pb, meas)
        if d_pe == 0:
            raise InputError(
                f"{meas.path}: no [measurements] sigma_position in the model and no "
                f"replicated rows (same posture, wrench and point): the noise level is "
                f"unknown, so adequacy cannot be tested; declare sigma_position or "
                f"repeat measurements"
            )
        s2 = ss_pe / d_pe
        sigma, source = math.sqrt(s2), "pure error"
        d_lof = res.dof - d_pe
        test = "lack-of-fit F"
        if d_lof > 0:
            stat = ((res.chi2 - ss_pe) / d_lof) / s2
            dof = d_lof
            log_p = logsf_f(stat, d_lof, d_pe)
        else:
            stat, dof, log_p = 0.0, 0, 0.0
        scale2 = s2  # weights were 1: divide sums of squares by sigma^2
    verdict = "adequate" if log_p >= math.log(alpha) else "inadequate"

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
        cols = pb.weighted(J)
        Z.append(cols)
        cstart.append(cstart[-1] + cols.shape[1])
    A = res.A if res.A.shape[1] else np.zeros((nobs, 1))
    if Z:
        stat_c, dof_c, pr = core.score(A, res.r, np.hstack(Z), np.array(cstart, np.int32), 1e-10, ZTOL)
    rr = float(res.r @ res.r)
    wp = pb.wrow[0]
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
        after = (rpos - pr[: 3 * npts, c].reshape(3, npts)) / wp
        cand.rms_after_m = float(np.sqrt(np.mean((after**2).sum(axis=0))))
        cand._pr = pr[:, c]
        ranked.append(cand)
    ranked.sort(key=lambda c: (c.log_p, c.dof, -c.statistic))
    # near-duplicates among the significant leaders
    lead = [c for c in ranked[:15] if c.log_p < math.log(alpha)]
    for i, a in enumerate(lead):
        for b in lead[i + 1 :]:
            if (a.kind, a.target) == (b.kind, b.target):
                continue
            na, nb = np.linalg.norm(a._pr), np.linalg.norm(b._pr)
            if na > 0 and nb > 0 and float(a._pr @ b._pr) / (na * nb) > DUPLICATE_COS:
                a.indistinguishable_from.append(b.label)
                b.indistinguishable_from.append(a.label)
    for c in ranked:
        del c._pr
    return Diagnosis(
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
    )


def format_diagnosis(dg: Diagnosis, top: int = 10) -> str:
    r = dg.fit
    lines = [
        f"adequacy ({dg.test}): statistic {dg.statistic:.4g} on {dg.dof:g} dof, "
        f"log10 p = {dg.log_p / math.log(10):.3g}  ->  {dg.verdict.upper()} (alpha {dg.alpha:g})",
        f"noise sigma {dg.sigma_position * 1e3:.4g} mm ({dg.sigma_source}); noise floor "
        f"sqrt(3) sigma = {math.sqrt(3) * dg.sigma_position * 1e3:.4g} mm; positional RMS now "
        f"{r.rms_position * 1e3:.4g} mm",
    ]
    if dg.candidates:
        lines.append("")
        lines.append(
            f"{'rank':>4s}  {'candidate':34s}{'dof':>4s}{'statistic':>12s}{'log10 p':>10s}"
            f"{'explains':>10s}{'RMS after, mm':>15s}"
        )
        for i, c in enumerate(dg.candidates[:top], 1):
            lines.append(
                f"{i:4d}  {c.label:34s}{c.dof:4d}{c.statistic:12.4g}{c.log_p / math.log(10):10.3g}"
                f"{100 * c.explained_fraction:9.1f}%{c.rms_after_m * 1e3:15.4g}"
            )
            if c.indistinguishable_from:
                lines.append(f"{'':6s}the data cannot tell it apart from: {', '.join(c.indistinguishable_from)}")
        best = dg.candidates[0]
        if dg.verdict == "inadequate":
            lines.append("")
            lines.append("suggested: append to the model file and run fit again")
            lines.append(effect_toml(best.effect))
            if best.hint:
                lines.append(f"hint: {best.hint}")
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
