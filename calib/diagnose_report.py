"""Reports of the deflection diagnosis (``calib.diagnose``): the
:class:`Diagnosis` record and its JSON, the text report, the residual's
shape along a feature, and the ready ``[[effect]]`` table of a proposal
(:func:`effect_toml`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..io.tomlw import effect_toml
from . import residual_map as RM
from .backward import BackwardStep, format_backward_steps
from .diagnose_candidates import Candidate
from .diagnose_stats import ALPHA
from .diagnosis_report import (
    multiplicity_line,
    multiplicity_method,
    nothing_fits_line,
    pipeline_json,
    proposal_lines,
    tie_line,
    verdict_line,
)
from .fit import FitResult, Problem
from .robust import DataChecks, format_checks

__all__ = ["Diagnosis", "format_diagnosis", "effect_toml", "residual_shape"]


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
    backward: list[BackwardStep] = field(default_factory=list)  # the model's effects tested without them
    removal: BackwardStep | None = None
    pruned: bool = False
    n_copied: int = 0  # exact copies of earlier rows, dropped before the fit

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
            "non_identifiable_candidates": [c.inert_json() for c in self.non_identifiable],
            "omnibus_inadequate": self.omnibus_inadequate,
            "multiplicity_p": self.multiplicity_p,
            "multiplicity_method": multiplicity_method(self.n_tests, self.nsim),
            "bonferroni_p": self.bonferroni_p,
            "n_tests": self.n_tests,
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
            "removal": self.removal.to_json() if self.removal is not None else None,
            "backward_steps": [s.to_json() for s in self.backward],
            "prune": self.pruned,
            "no_proposal_reasons": self.reasons,
            "warnings": self.warnings,
            "residual_map": [f.to_json() for f in self.residual_map],
            "residual_shapes": self.shapes,
            **pipeline_json("deflection", self.fit_all_rows, self.n_copied, self.fit.dof, self.alpha),
        }

    @property
    def fit_all_rows(self) -> int:
        """Distinct rows read (before the data checks set any aside)."""
        return int((self.fit_all if self.fit_all is not None else self.fit).measured.shape[0])


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
        lines.append(multiplicity_line(dg.multiplicity_p, dg.bonferroni_p, dg.n_tests, dg.nsim, dg.best_inadequate))
    cv = dg.cv_rms_position_m
    lines.append(
        f"noise sigma {dg.sigma_position * 1e3:.4g} mm ({dg.sigma_source}); noise floor "
        f"sqrt(3) sigma = {dg.floor * 1e3:.4g} mm; positional RMS now "
        f"{r.rms_position * 1e3:.4g} mm"
        + (f"; held-out ({dg.cv_folds} folds by configuration) {cv * 1e3:.4g} mm" if cv is not None else "")
    )
    lines.append(verdict_line(dg.verdict))
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
                f"{100 * c.explained_fraction:9.1f}%{_pct(c.excess_fraction):>8s}{c.rms_after_m * 1e3:11.4g}{cvs}"
            )
            if c.indistinguishable_from:
                lines.append(f"{'':6s}the data cannot tell it apart from: {', '.join(c.indistinguishable_from)}")
    for t in dg.ties:
        lines.append("")
        lines.append(tie_line(t["candidates"]))
        if t.get("plan_command"):
            lines.append(f"  postures and loads that would tell them apart: {t['plan_command']}")
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
        lines.append(nothing_fits_line())
        L = dg.candidates[0] if dg.candidates else None
        msg = "nothing in the catalogue fits"
        if L is not None:
            msg += (
                f": the best candidate ({L.label}) explains {_pct(L.excess_fraction)} of the residual above the noise"
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
    if dg.backward:
        lines.append("")
        lines += format_backward_steps(dg.backward, dg.removal)
    if dg.proposal is not None:
        best = dg.proposal
        lines.append("")
        gain = ""
        if best.cv_rms_position_m is not None and cv is not None:
            gain = f"held-out RMS with it {cv * 1e3:.4g} -> {best.cv_rms_position_m * 1e3:.4g} mm"
        lines += proposal_lines(best.effect, gain, best.hint)
    elif dg.verdict == "inadequate" or dg.reasons:
        lines.append("")
        lines.append("no effect is proposed: " + "; ".join(dg.reasons) if dg.reasons else "no effect is proposed")
    if dg.non_identifiable:
        lines.append("")
        lines.append("non-identifiable additions (not ranked):")
        why: dict[str, list[str]] = {}
        for c in dg.non_identifiable:
            why.setdefault(c.reason or "spanned by the model, or no influence on these data", []).append(c.label)
        for reason, labels in why.items():
            lines.append(f"  {reason}: {', '.join(labels)}")
    return "\n".join(lines)


def _pct(x: float | None) -> str:
    """A share as a whole percentage, '-' when it is not defined."""
    return "-" if x is None else f"{100 * x:.0f} %"
