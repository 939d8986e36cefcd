"""The record of the absolute diagnosis (``calib.absolute_diagnose``) and
its JSON, and its text report: the data checks, the verdict, the candidates ranked, the ones that cannot
act and why, the backward steps, the proposal as a ready [[effect]] table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .absolute_fit import AbsoluteFit, position_stats
from .backward import BackwardStep, format_backward_steps
from .diagnose_candidates import Candidate
from .diagnosis import ALPHA
from .diagnosis_report import (
    multiplicity_line,
    multiplicity_method,
    nothing_fits_line,
    pipeline_json,
    proposal_lines,
    tie_line,
    verdict_line,
)

__all__ = ["AbsoluteDiagnosis", "format_absolute_diagnosis"]


@dataclass
class AbsoluteDiagnosis:
    """The verdict, the data checks, the candidates ranked, the backward steps."""

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
    backward: list[BackwardStep] = field(default_factory=list)
    removal: BackwardStep | None = None
    pruned: bool = False  # only the backward steps were made (prune=True)
    alpha: float = ALPHA
    residual_dof: int = 0
    n_copied: int = 0  # exact copies of earlier rows, dropped before the fit
    n_tests: int = 0  # candidates scored
    bonferroni_p: float | None = None  # the best candidate's p times n_tests (at most 1)
    multiplicity_p: float | None = None  # the best candidate's p corrected by the max-score test
    nsim: int = 0  # its Monte Carlo draws (0: Bonferroni's bound, far below alpha)
    best_inadequate: bool = False  # the corrected test rejects at alpha
    together_fraction: float | None = None  # the best three's share of the excess (nothing-fits rule)

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
            "removal": self.removal.to_json() if self.removal is not None else None,
            "backward_steps": [s.to_json() for s in self.backward],
            "prune": self.pruned,
            "ties": self.ties,
            "nothing_fits": self.nothing_fits,
            "together_excess_fraction": self.together_fraction,
            "residual_structure": self.residual_structure,
            "no_proposal_reasons": self.reasons,
            "warnings": self.warnings,
            "non_identifiable_candidates": [c.inert_json() for c in self.non_identifiable],
            "fit": self.fit.to_json(),
            "n_tests": self.n_tests,
            "multiplicity_p": self.multiplicity_p,
            "multiplicity_method": multiplicity_method(self.n_tests, self.nsim),
            "best_candidate_inadequate": self.best_inadequate,
            "bonferroni_p": self.bonferroni_p,
            **pipeline_json("absolute", self.n_rows_distinct, self.n_copied, self.residual_dof, self.alpha),
        }

    @property
    def n_rows_distinct(self) -> int:
        """Distinct rows read (with those the data checks set aside)."""
        return int(self.fit.data.n) + len(self.data_checks.get("set_aside_rows", []))


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
    if dg.multiplicity_p is not None:
        lines.append(multiplicity_line(dg.multiplicity_p, dg.bonferroni_p, dg.n_tests, dg.nsim, dg.best_inadequate))
    lines.append(verdict_line(dg.verdict))
    for w in dg.warnings:
        lines.append(f"warning: {w}")
    lines.append("")
    if dg.candidates:
        lines.append(
            f"{'candidate':34s}{'dof':>5s}{'log10 p':>10s}{'explains':>10s}{'excess':>8s}{'RMS after':>11s}"
            f"{'CV RMS':>9s}"
        )
    for c in dg.candidates[:top]:
        cv = f"{c.cv_rms_position_m / mm:9.4f}" if c.cv_rms_position_m is not None else f"{'-':>9s}"
        ex = f"{100 * c.excess_fraction:7.0f}%" if c.excess_fraction is not None else f"{'-':>8s}"
        lines.append(
            f"{c.label[:33]:34s}{c.dof:5d}{c.log_p / math.log(10):10.1f}{100 * c.explained_fraction:9.1f}%"
            f"{ex}{c.rms_after_m / mm:11.4f}{cv}"
        )
    if dg.non_identifiable:
        lines.append("not identifiable additions (not ranked):")
        why: dict[str, list[str]] = {}
        for c in dg.non_identifiable:
            why.setdefault(c.reason, []).append(c.label)
        for reason, labels in why.items():
            more = f" and {len(labels) - 12} more" if len(labels) > 12 else ""
            lines.append(f"  {reason}: {', '.join(labels[:12])}{more}")
    for t in dg.ties:
        lines.append(tie_line(t["candidates"]))
        if t.get("plan_command"):
            lines.append(f"  postures that would tell them apart: {t['plan_command']}")
    st = dg.residual_structure or {}
    for key, what in (("posture", "neighbouring postures"), ("order", "consecutive configurations")):
        if isinstance(st.get(key), dict):
            v = st[key]
            lines.append(
                f"residual structure: {what}: correlation {v['neighbour_correlation']:.3f}, p = {v['p_value']:.3g}"
            )
    if dg.nothing_fits:
        lines.append(nothing_fits_line())
    for r in dg.reasons:
        lines.append(f"no proposal: {r}")
    if dg.backward:
        lines.append("")
        lines += format_backward_steps(dg.backward, dg.removal)
    if dg.proposal is not None:
        lines.append("")
        lines += proposal_lines(dg.proposal.effect, hint=dg.proposal.hint)
    return "\n".join(lines)
