"""The text report of the absolute diagnosis (``calib.absolute_diagnose``):
the data checks, the verdict, the candidates ranked, the ones that cannot
act and why, the backward steps, the proposal as a ready [[effect]] table.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from .backward import format_backward_steps
from .diagnose_report import effect_toml

if TYPE_CHECKING:
    from .absolute_diagnose import AbsoluteDiagnosis

__all__ = ["format_absolute_diagnosis"]


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
    if dg.backward:
        lines.append("")
        lines += format_backward_steps(dg.backward, dg.removal)
    if dg.proposal is not None:
        lines.append("")
        if dg.proposal.hint:
            lines.append(f"note: {dg.proposal.hint}")
        lines.append("proposal: append to the model and fit again:")
        lines.append(effect_toml(dg.proposal.effect))
    return "\n".join(lines)
