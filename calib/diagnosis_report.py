"""The report pieces both observation kinds share (``calib.diagnosis``): the
pipeline's JSON fields, the proposal block, and the nothing-fits headline.
"""

from __future__ import annotations

from ..io.tomlw import effect_toml
from .diagnosis import ALPHA, MIN_RESIDUAL_DOF, NOTHING_FITS_LINE, PROPOSAL_LINE

__all__ = ["pipeline_json", "proposal_lines", "nothing_fits_line", "verdict_line"]


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
