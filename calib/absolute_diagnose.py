"""Diagnosis on absolute data (docs/calibration.md section 6.4): is what the
model leaves noise, and which geometric or elastic effect is missing?

1. The data first: the model is fitted, the points whose error is a gross
   outlier (against a robust scale, standing out from their own
   configuration) and configurations recorded in another unit are listed
   (calib/checks.py) and set aside before anything is blamed on the model.
2. Every catalogued effect the model lacks (joint offsets, frame errors,
   joint and lateral compliance under gravity, link and base springs, each
   on every target and on ``all``) is added at zero to one extended model,
   whose analytic Jacobian at the fitted values gives every candidate's
   columns in one core call. Each candidate gets the score statistic of its
   columns projected off the model's (core/sk_calib.f90 score_tests), a
   log p-value (chi-square with a declared sigma, F with the residual's
   estimate otherwise), the share of the residual it explains, and its
   held-out error: K-fold cross-validation by configuration of the model
   plus the candidate, linearised at the fit (one Gauss-Newton step per fold).
3. A candidate is proposed only when it is significant after the
   multiplicity of the candidates (Bonferroni over them) and lowers the
   held-out error of the model by more than its noise; candidates whose
   held-out errors are within that margin of the leader's are reported as
   tied. Without a declared sigma the residual cannot be called noise by a
   chi-square test: the verdict then rests on the held-out error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._core import calib as core_calib
from .._core import tree as core
from ..errors import StiffkitError
from ..io.tomlw import effect_toml
from ..robot.tree_model import TreeModel, tree_model_from_tables
from .absolute_data import AbsoluteData, row_values
from .absolute_fit import (
    AbsoluteFit,
    _loads,
    _marker_index,
    _nonnegative,
    _solve,
    fit_absolute,
    position_stats,
    predict,
)
from .checks import cannot_judge, drop_copies, outlier_rows, unit_slips
from .crossval import config_folds, held_out_residuals
from .diagnose import Candidate

__all__ = [
    "AbsoluteDiagnosis",
    "diagnose_absolute",
    "absolute_candidates",
    "format_absolute_diagnosis",
    "residual_structure",
]

ALPHA = 0.01
#: gross errors are judged against the residual of a model that may still lack effects (whose errors
#: are not Gaussian): a stricter level than the tests of the effects
OUTLIER_ALPHA = 1e-4
CV_FOLDS = 5
#: held-out errors of this many leading candidates (each one CV of the linearised model)
CV_TOP = 6
ZTOL = 1e-6
#: a candidate must lower the held-out RMS by this fraction at least (beyond noise)
CV_GAIN = 0.02
#: a smaller candidate contained in the best one is proposed first when it achieves this share of
#: the best one's held-out improvement (joint offsets before the frame errors that contain them)
NESTED_SHARE = 0.5
#: the residual's structure (when nothing is proposed): two neighbour-correlation permutation
#: tests (neighbouring postures, configurations measured one after the other), each at half
#: this level
STRUCTURE_ALPHA = 0.01
#: a proposal is checked by fitting the model with it (at most this many candidates): the fit
#: must realise this share of the in-sample improvement the linear prediction promised
VERIFY_TOP = 3
VERIFY_SHARE = 0.5
VERIFY_MAXIT = 5
STRUCTURE_PERMUTATIONS = 999
#: consecutive configurations closer in posture than this many times the nearest other posture:
#: the order test cannot tell drift from a posture effect
PATH_GAP = 1.5
#: per joint kinds, and the template of link / base springs among the candidates
JOINT_KINDS = ("joint_offset", "frame", "joint", "lateral")
SPRING_TEMPLATE = "beam"


@dataclass
class AbsoluteDiagnosis:
    """The verdict, the data checks, and the candidates ranked."""

    verdict: str
    sigma_position: float
    sigma_source: str
    fit: AbsoluteFit
    candidates: list[Candidate]
    non_identifiable: list[Candidate]
    cv_rms_position_m: float
    cv_folds: int
    data_checks: dict
    proposal: Candidate | None = None
    ties: list[dict] = field(default_factory=list)
    reasons: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    test: str = ""
    statistic: float = 0.0
    dof: float = 0.0
    log_p: float = 0.0
    nothing_fits: bool = False
    residual_structure: dict | None = None

    @property
    def floor(self) -> float:
        return math.sqrt(3) * self.sigma_position

    def to_json(self) -> dict:
        return {
            "verdict": self.verdict,
            "sigma_position_m": self.sigma_position,
            "rms_position_m": self.fit.rms_position,
            "candidates": [c.to_json() for c in self.candidates],
            "kind": "absolute",
            "sigma_source": self.sigma_source,
            "noise_floor_position_m": self.floor,
            "mean_position_m": position_stats(self.fit.residual[self.fit.weight > 0])["mean_position_m"],
            "cv_rms_position_m": self.cv_rms_position_m,
            "cv_folds": self.cv_folds,
            "test": self.test,
            "statistic": self.statistic if math.isfinite(self.statistic) else None,
            "dof": self.dof,
            "log10_p_value": self.log_p / math.log(10),
            "data_checks": self.data_checks,
            "proposal": self.proposal.effect if self.proposal is not None else None,
            "ties": self.ties,
            "nothing_fits": self.nothing_fits,
            "residual_structure": self.residual_structure,
            "no_proposal_reasons": self.reasons,
            "warnings": self.warnings,
            "non_identifiable_candidates": [
                {"kind": c.kind, "target": c.target, "effect": c.effect} for c in self.non_identifiable
            ],
            "fit": self.fit.to_json(),
        }


def absolute_candidates(model: TreeModel) -> list[dict]:
    """Effect tables of every catalogued kind on every target the model
    lacks, the per-joint kinds also on ``all``."""
    tree = model.tree
    have = {(p.kind, p.target) for p in model.params}
    out = []
    for kind in JOINT_KINDS:
        if kind in ("joint_offset", "joint"):
            joints = [j.name for j in tree.joints if j.moving]
        elif kind == "lateral":
            joints = [j.name for j in tree.joints if j.moving and j.type != "prismatic"]
        else:
            joints = [j.name for j in tree.joints]
        missing = [j for j in joints if (kind, j) not in have]
        if len(missing) > 1:
            out.append({"kind": kind, "target": "all"})
        out += [{"kind": kind, "target": j} for j in missing]
    massive = _links_carrying_mass(model)
    for link in massive:
        if ("link", link) not in have:
            out.append({"kind": "link", "target": link, "template": SPRING_TEMPLATE})
    if ("base", "base") not in have and massive:
        out.append({"kind": "base", "template": "full"})
    return out


def _links_carrying_mass(model: TreeModel) -> list[str]:
    """Links with at least one child joint and some mass beyond it."""
    tree = model.tree
    mass_below: dict[str, float] = {ln: 0.0 for ln in tree.links}
    for j in reversed(tree.joints):
        ine = tree.inertials.get(j.child)
        mass_below[j.child] += ine.mass if ine else 0.0
        mass_below[j.parent] += mass_below[j.child]
    return [ln for ln in tree.links if tree.children(ln) and mass_below[ln] > 0 and ln != tree.root]


def _extended(model: TreeModel, cands: list[dict]) -> TreeModel:
    """The model with every candidate's effect added (at zero): per joint
    effects once per joint (the ``all`` candidates are unions of them)."""
    extra, seen = [], set()
    for c in cands:
        if c.get("target") == "all":
            continue
        key = (c["kind"], c.get("target", c["kind"]))
        if key not in seen:
            seen.add(key)
            extra.append(dict(c))
    ext = tree_model_from_tables(
        model.tree, list(model.effects) + extra, model.gravity, model.iterations, "diagnosis", model.sigma_position
    )
    ext.arrays["rref"] = np.asfortranarray(model.arrays["rref"])
    return ext


def _params_of(model: TreeModel, cand: dict) -> list[int]:
    kind = cand["kind"]
    target = cand.get("target", kind)
    kinds = {"base": ("base",), "link": ("link",)}.get(kind, (kind,))
    return [
        i for i, p in enumerate(model.params) if p.kind in kinds and (target == "all" or p.target == target) and p.free
    ]


def diagnose_absolute(
    model: TreeModel,
    data: AbsoluteData,
    sigma_position: float | None = None,
    alpha: float = ALPHA,
    cv_folds: int = CV_FOLDS,
    checks: bool = True,
) -> AbsoluteDiagnosis:
    """Fit ``model`` to ``data``, check the data, rank the missing effects
    (module docstring)."""
    data, copies = drop_copies(data, row_values(data))  # copies are not replicates
    try:
        fit = fit_absolute(model, data, sigma_position=sigma_position)
    except StiffkitError as exc:  # too few rows: with copies, say what is left
        if not copies:
            raise
        raise cannot_judge(data.path, data.n, copies, str(exc).removeprefix(f"{data.path}: ")) from None
    sig_decl = sigma_position if sigma_position is not None else model.sigma_position
    # 1. the data first
    dchecks: dict = {"outliers": [], "unit_slips": [], "warnings": list(data.warnings)}
    w = data.weight.copy()
    if checks:
        labels = [data.configs[p] for p in data.posture]
        pred = data.xyz - fit.residual
        slips = unit_slips(data.xyz, pred, labels, sig_decl)
        # gross errors among the rows still in use (the reader sets gross unit slips aside)
        use = np.flatnonzero(w > 0)
        res_use = fit.residual[use]
        scale = sig_decl if sig_decl else _robust_sigma(res_use)
        flags = outlier_rows(res_use, scale, [labels[i] for i in use], alpha=OUTLIER_ALPHA)
        for f in flags:
            f.row = int(use[f.row])
        dchecks["unit_slips"] = [s.to_json() for s in slips]
        dchecks["outliers"] = [f.to_json(line=data.lines[f.row]) for f in flags]
        aside = {f.row for f in flags} | {r for s in slips for r in s.rows} | set(np.flatnonzero(w == 0).tolist())
        if aside:
            w[list(aside)] = 0.0
            kept = data.subset(w > 0)
            fit = fit_absolute(model, kept, sigma_position=sigma_position)
            data = kept
            w = data.weight.copy()
            dchecks["set_aside_rows"] = sorted(int(x) for x in aside)
    m = fit.model
    theta = fit.theta
    cands = absolute_candidates(m)
    ext = _extended(m, cands)
    th_ext = ext.theta0.copy()
    for i, name in enumerate(ext.names):
        if name in m.names:
            th_ext[i] = theta[m.index(name)]
    ext.arrays["kw0"] = np.array(ext.arrays["kw0"], dtype=float)
    kept_names = [m.names[i] for i in fit.reduction.kept]
    base_cols = np.array([ext.index(n) for n in kept_names], int)
    cand_cols = [np.array([i for i in _params_of(ext, c) if ext.names[i] not in m.names], int) for c in cands]
    allc = np.unique(np.concatenate([base_cols] + [c for c in cand_cols if c.size]))
    ev = core.evaluate(
        ext.ne,
        ext.arrays,
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
    if nobs <= p:
        raise cannot_judge(
            data.path, data.n, copies, f"{nobs} coordinates for {p} identified parameters leave no residual"
        )
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
    # 2. candidates: score tests in one core call, held-out errors by linearised CV
    blocks = [(c, cols) for c, cols in zip(cands, cand_cols) if cols.size]
    Z = np.hstack([J[:, [col[x] for x in cols]] for _c, cols in blocks]) if blocks else np.zeros((len(r), 0))
    cstart = np.cumsum([1] + [cols.size for _c, cols in blocks])
    ranked, spanned = [], []
    if blocks:
        st, df, _pr = core_calib.score(A, r, Z, cstart, 1e-10, ZTOL)
    labels = [data.configs[q] for q in data.posture]
    folds = config_folds(labels, cv_folds)
    npts = data.n
    obs_rows = np.repeat(np.arange(npts), 3)
    cv_base = _cv_rms(A, r, obs_rows, folds, w)
    for k, (c, cols) in enumerate(blocks):
        d = int(df[k])
        cand = Candidate(kind=c["kind"], target=c.get("target", c["kind"]), effect=dict(c))
        if d == 0:
            spanned.append(cand)
            continue
        cand.statistic = float(st[k] / s2)
        cand.dof = d
        if sig_decl:
            cand.log_p = core_calib.chi2_logsf(cand.statistic, d)
        else:
            rest = max(nres - d, 1)
            s2c = max(rss - st[k], 1e-300) / rest
            cand.log_p = core_calib.f_logsf((st[k] / d) / s2c, d, rest)
        cand.explained_fraction = float(st[k] / rss) if rss > 0 else 0.0
        cand.rms_after_m = math.sqrt(max(rss - st[k], 0.0) / max(np.sum(w > 0), 1))
        ranked.append((cand, cols))
    ranked.sort(key=lambda x: x[0].log_p)
    top = ranked[:CV_TOP]
    for cand, cols in top:
        Ac = np.hstack([A, J[:, [col[x] for x in cols]]])
        cand.cv_rms_position_m = _cv_rms(Ac, r, obs_rows, folds, w)
    dg = AbsoluteDiagnosis(
        verdict="adequate",
        sigma_position=sigma,
        sigma_source=source,
        fit=fit,
        candidates=[c for c, _ in ranked],
        non_identifiable=spanned,
        cv_rms_position_m=cv_base,
        cv_folds=len(folds),
        data_checks=dchecks,
        test=test,
        statistic=stat,
        dof=dof,
        log_p=log_p,
    )
    # 3. the proposal
    crit = math.log(alpha / max(len(ranked), 1))
    useful = [
        c
        for c, _ in top
        if c.log_p < crit and c.cv_rms_position_m is not None and c.cv_rms_position_m < cv_base * (1 - CV_GAIN)
    ]
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
            rms_new = _refit_rms(m, theta, kept_set, c, data, w)
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
    useful = [c for c in useful if c.label not in tried or c is best]
    if best is None:
        dg.reasons += notes
    else:
        dg.warnings += [f"not proposed: {n}" for n in notes]
    if best is not None:
        margin = best.cv_rms_position_m * CV_GAIN
        rivals = [
            c
            for c in useful
            if c is not best and c.cv_rms_position_m <= best.cv_rms_position_m + margin and not _nested(best, c)
        ]
        if rivals:
            dg.ties.append(
                {
                    "candidates": [best.label] + [c.label for c in rivals],
                    "cv_rms_position_m": [best.cv_rms_position_m] + [c.cv_rms_position_m for c in rivals],
                }
            )
        dg.proposal = best
        dg.verdict = "inadequate"
    else:
        if ranked and ranked[0][0].log_p < crit and not tried:
            dg.reasons.append(
                "the leading candidates are significant but none lowers the held-out error by more than "
                f"{CV_GAIN:.0%}: they would fit noise or the fit's own flexibility"
            )
        if sig_decl and log_p < math.log(alpha):
            dg.verdict = "inadequate"
            dg.nothing_fits = True
            dg.reasons.append(
                "the residual is larger than the declared noise, but no catalogued effect explains it: look at "
                "the data checks and at the residual's shape (fit --plots)"
            )
        if not sig_decl or dg.verdict == "inadequate":
            _structure_verdict(dg, data, fit, w)
    if not sig_decl:
        dg.warnings.append(
            "no sigma_position declared: the residual cannot be called noise by a chi-square test; the verdict "
            "rests on the held-out error (an effect is proposed only when it lowers it)"
        )
    if nres < 30:
        dg.warnings.append(f"only {nres} residual degrees of freedom: the tests have little power")
    return dg


def residual_structure(data: AbsoluteData, residual: np.ndarray, w: np.ndarray, model: TreeModel) -> dict:
    """Is what the model leaves a function of the posture, or of the order
    of measurement (drift), rather than noise? Two permutation tests of the
    neighbour correlation (core sk_calib neighbour_correlation): each
    point's error against that of the same marker in the nearest other
    posture (distance over the joints that move that marker), and in the
    configuration measured just before or after it (the file's order)."""
    tree = model.tree
    x = np.zeros((data.n, len(data.joints)))
    for fi, frame in enumerate(data.frames):
        moving = {tree.leader(j.name)[0] for j in tree.path(frame) if j.moving}
        mask = np.array([j in moving for j in data.joints], float)
        rows = data.frame == fi
        x[rows] = data.Q[data.posture[rows]] * mask
    out: dict = {"permutations": STRUCTURE_PERMUTATIONS, "alpha": STRUCTURE_ALPHA}
    gap = {}
    for key, coords in (("posture", x), ("order", data.posture[:, None].astype(float))):
        try:
            rho, pval, nn = core_calib.neighbour_correlation(
                coords, residual, w, data.posture, data.frame, STRUCTURE_PERMUTATIONS
            )
        except StiffkitError:  # too few points with a neighbour: no test
            continue
        out[key] = {"neighbour_correlation": rho, "p_value": pval}
        has = nn >= 0
        # how far apart in posture the neighbours of this test are (rad, over the marker's joints)
        gap[key] = float(np.median(np.linalg.norm(x[has] - x[nn[has]], axis=1))) if has.any() else float("nan")
    if "order" in out and "posture" in out:
        # measured along a path, consecutive configurations are near in posture too: the
        # order test then also sees effects of the posture
        ratio = gap["order"] / gap["posture"] if gap["posture"] > 0 else None
        out["order"]["posture_gap_ratio"] = ratio if ratio is not None and math.isfinite(ratio) else None
    return out


def _structure_verdict(dg: AbsoluteDiagnosis, data: AbsoluteData, fit: AbsoluteFit, w: np.ndarray) -> None:
    """No candidate proposed: say whether the residual is still structured
    (then nothing in the catalogue fits, and what the structure suggests)."""
    st = residual_structure(data, fit.residual, w, fit.model)
    dg.residual_structure = st
    found = {
        k: v
        for k, v in st.items()
        if isinstance(v, dict) and v["p_value"] < STRUCTURE_ALPHA / 2 and v["neighbour_correlation"] > 0
    }
    if not found:
        return
    dg.nothing_fits = True
    dg.verdict = "inadequate"
    rms = fit.rms_position * 1e3
    if "posture" in found:
        v = found["posture"]
        dg.reasons.append(
            f"nothing in the catalogue fits, yet the residual ({rms:.3g} mm RMS) is not noise: the errors of "
            f"neighbouring postures are alike (correlation {v['neighbour_correlation']:.2f}, p = {v['p_value']:.2g} "
            f"by {st['permutations']} permutations). An effect that varies with the posture is missing that no "
            "catalogued kind describes (e.g. a transmission error cyclic in a joint angle, a deformation of "
            "another law); its shape against each joint's angle and gravity torque: stiffkit fit --plots"
        )
    if "order" in found:
        v = found["order"]
        text = (
            f"the errors of configurations measured one after the other are alike (correlation "
            f"{v['neighbour_correlation']:.2f}, p = {v['p_value']:.2g}): drift during the measurement "
            "(temperature, the tracker's own drift)? Check against reference points measured at the start "
            "and the end; the residual against the row order: stiffkit fit --plots"
        )
        if v.get("posture_gap_ratio") is not None and v["posture_gap_ratio"] < PATH_GAP:
            text += (
                "; but consecutive configurations are also near in posture here (measured along a path): "
                "drift and an effect of the posture cannot be told apart by these data (measure in a "
                "shuffled order, or repeat a few postures at the start and the end)"
            )
        dg.reasons.append(text)


def _refit_rms(
    m: TreeModel,
    theta: np.ndarray,
    kept: set[str],
    cand: Candidate,
    data: AbsoluteData,
    w: np.ndarray,
) -> float | None:
    """RMS point error (m) of the fitted model ``m`` plus the candidate's
    effect, fitted: LM from the fitted values (the candidate at 0) on the
    identified parameters and the candidate's, compliances that come out
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
        free = np.array([k for k, name in enumerate(mc.names) if name in kept or name not in m.names], int)
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


def _nested(a: Candidate, b: Candidate) -> bool:
    """One candidate contains the other (a kind on ``all`` and on one joint)."""
    return a.kind == b.kind and "all" in (a.target, b.target)


def _robust_sigma(res: np.ndarray) -> float:
    d = np.linalg.norm(res, axis=1)
    return float(np.median(d)) / math.sqrt(2.366) if d.size else 1.0


def _cv_rms(A: np.ndarray, r: np.ndarray, obs_rows: np.ndarray, folds: list, w: np.ndarray) -> float | None:
    """Held-out RMS point error (m) of the linearised model A x ~ r, by folds
    of configurations; weights w per point (rows of weight 0 left out)."""
    e = held_out_residuals(A, r, obs_rows, folds)
    e = e.reshape(-1, 3)
    sw = np.sqrt(np.where(w > 0, w, np.nan))
    d2 = np.sum((e / sw[:, None]) ** 2, axis=1)
    ok = np.isfinite(d2)
    return float(math.sqrt(np.mean(d2[ok]))) if ok.any() else None


def format_absolute_diagnosis(dg: AbsoluteDiagnosis, top: int = 10) -> str:
    """The verdict, the data checks, the ranked candidates with their held-out
    errors, the proposal as a ready [[effect]] table."""
    mm = 1e-3
    lines = []
    dc = dg.data_checks
    for w in dc.get("warnings", []):
        lines.append(f"warning: {w}")
    for s in dc.get("unit_slips", []):
        lines.append(f"data: configuration {s['config']}: {s['meaning']} (ratio {s['ratio']:.4g}); fix: {s['fix']}")
    for o in dc.get("outliers", []):
        lines.append(
            f"data: line {o.get('line')} (config {o['config']}): gross error, {o['standardised_residual']:.1f} sigma"
        )
    if dc.get("set_aside_rows"):
        lines.append(f"data: {len(dc['set_aside_rows'])} row(s) set aside before the diagnosis")
    fit = dg.fit
    lines.append(
        f"model: RMS {fit.rms_position / mm:.4f} mm, held out ({dg.cv_folds}-fold CV by config) "
        f"{(dg.cv_rms_position_m or float('nan')) / mm:.4f} mm; sigma {dg.sigma_position / mm:.4g} mm "
        f"({dg.sigma_source}), noise floor {dg.floor / mm:.4g} mm"
    )
    if dg.test == "chi2":
        lines.append(f"chi-square {dg.statistic:.1f} on {dg.dof:.0f} dof: log10 p = {dg.log_p / math.log(10):.1f}")
    lines.append(f"verdict: {dg.verdict.upper()}")
    for w in dg.warnings:
        lines.append(f"warning: {w}")
    lines.append("")
    lines.append(f"{'candidate':34s}{'dof':>5s}{'log10 p':>10s}{'explains':>10s}{'RMS after':>11s}{'CV RMS':>9s}")
    for c in dg.candidates[:top]:
        cv = f"{c.cv_rms_position_m / mm:9.4f}" if c.cv_rms_position_m is not None else f"{'-':>9s}"
        lines.append(
            f"{c.label[:33]:34s}{c.dof:5d}{c.log_p / math.log(10):10.1f}{100 * c.explained_fraction:9.1f}%"
            f"{c.rms_after_m / mm:11.4f}{cv}"
        )
    if dg.non_identifiable:
        lines.append(
            "spanned by the model (not identifiable additions): "
            + ", ".join(c.label for c in dg.non_identifiable[:12])
            + (" ..." if len(dg.non_identifiable) > 12 else "")
        )
    for t in dg.ties:
        lines.append("tied (held-out errors within the margin): " + ", ".join(t["candidates"]))
    st = dg.residual_structure or {}
    for key, what in (("posture", "neighbouring postures"), ("order", "consecutive configurations")):
        if isinstance(st.get(key), dict):
            v = st[key]
            lines.append(
                f"residual structure: {what}: correlation {v['neighbour_correlation']:.3f}, p = {v['p_value']:.3g}"
            )
    if dg.nothing_fits:
        lines.append("NOTHING IN THE CATALOGUE FITS")
    for r in dg.reasons:
        lines.append(f"no proposal: {r}")
    if dg.proposal is not None:
        lines.append("")
        if dg.proposal.hint:
            lines.append(f"note: {dg.proposal.hint}")
        lines.append("proposal: append to the model and fit again:")
        lines.append(effect_toml(dg.proposal.effect))
    return "\n".join(lines)
