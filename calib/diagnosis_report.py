"""The report pieces both observation kinds share (``calib.diagnosis``): the
pipeline's JSON fields, the proposal block, and the nothing-fits headline.
"""

from __future__ import annotations

import math

from ..io.tomlw import effect_toml
from .diagnosis import ALPHA, MIN_RESIDUAL_DOF, NOTHING_FITS_LINE, PROPOSAL_LINE, TIE_LOG10

__all__ = [
    "pipeline_json",
    "proposal_lines",
    "nothing_fits_line",
    "verdict_line",
    "multiplicity_method",
    "multiplicity_line",
    "not_significant",
    "undecidable",
    "tie_line",
    "nothing_fits_reason",
]


def pipeline_json(kind: str, n_distinct: int, n_copied: int, residual_dof: int, alpha: float = ALPHA) -> dict:
    """The JSON fields that say which pipeline judged which rows."""
    return {
        "observation_kind": kind,
        "alpha": alpha,
        "residual_dof": int(residual_dof),
        "n_rows_distinct": int(n_distinct),
        "n_rows_copied": int(n_copied),
        "min_residual_dof": MIN_RESIDUAL_DOF,
    }


def proposal_lines(effect: dict, gain: str = "", hint: str = "") -> list[str]:
    """The proposal: the held-out gain (if known), a hint, the common line
    and the ready [[effect]] table last (what follows the line is the
    table to append)."""
    out = [gain] if gain else []
    if hint:
        out.append(f"hint: {hint}")
    return out + [PROPOSAL_LINE, effect_toml(effect)]


def nothing_fits_line(detail: str = "") -> str:
    return NOTHING_FITS_LINE + (f": {detail}" if detail else "")


def verdict_line(verdict: str) -> str:
    """The verdict, both kinds: ``verdict: ADEQUATE`` or ``verdict: INADEQUATE``."""
    return f"verdict: {verdict.upper()}"


def multiplicity_method(n_tests: int, nsim: int) -> str:
    """How the best candidate's p was corrected (``diagnosis.corrected_p``), both kinds."""
    if nsim:
        return f"max-score test over {n_tests} candidates, Monte Carlo ({nsim} draws)"
    return f"Bonferroni bound over {n_tests} candidates (far below alpha)"


def multiplicity_line(mult_p: float, bonf_p: float, n_tests: int, nsim: int, alarm: bool) -> str:
    """The report's line of the corrected test of the best candidate, both kinds."""
    if nsim:
        bound = mult_p <= 1.0 / (nsim + 1) + 1e-12
        how = f"p {'<=' if bound else '='} {mult_p:.3g} (max-score test; Bonferroni {bonf_p:.3g})"
    else:
        how = f"p <= {max(bonf_p, 1e-300):.3g} (Bonferroni bound)"
    return f"best candidate, corrected for looking at all {n_tests}: {how}" + ("  -> alarm" if alarm else "")


def not_significant(log_p: float, mult_p: float | None, n_tests: int) -> str:
    """Why the best candidate is not proposed when its corrected test does not reject, both kinds."""
    corr = f", corrected for looking at all {n_tests}: p = {mult_p:.3g}" if mult_p is not None else ""
    return f"no single candidate is significant on its own (best log10 p = {log_p / math.log(10):.3g}{corr})"


def undecidable(labels: list[str]) -> str:
    """Why a tie blocks the proposal, both kinds."""
    return f"undecidable: {', '.join(labels)} fit these data about as well"


def tie_line(labels: list[str]) -> str:
    """A tie in the report, both kinds (the rule: ``diagnosis.tie_rivals``)."""
    return (
        f"undecidable: {', '.join(labels)} fit these data about as well (within {TIE_LOG10:g} in log10 p, or "
        "better on held-out configurations); adding one of them would be a guess."
    )


def nothing_fits_reason(share: float | None) -> str:
    """Why nothing is proposed when nothing in the catalogue fits (``diagnosis.catalogue_fails``), both kinds."""
    return (
        f"nothing in the catalogue fits: the best candidate explains {100 * (share or 0.0):.0f} % "
        "of the residual above the noise"
    )
