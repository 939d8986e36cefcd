"""Backward steps of the diagnosis (``calib.absolute_diagnose`` and
``calib.diagnose``): does every effect already in the model still earn its
place?

For each ``[[effect]]`` table of the model (the tracker and the markers of
absolute data excepted), linearised at the fit (the Jacobian and the residual of the
diagnosis):

- its fitted values against the noise: the Wald statistic of its
  identified parameters, i.e. the rise of the residual sum of squares when
  they are set to zero and the others fitted again (the score statistic of
  its columns against the rest of the model, with the residual of the model
  without it), over sigma^2, against chi-square (declared sigma) or F
  (sigma estimated from the residual) with as many degrees of freedom as
  it has identified parameters;
- the held-out error without it: the same K-fold cross-validation by
  configuration as the candidates' (one Gauss-Newton step per fold).

An effect no longer earns its place when its values are within the noise
(p >= alpha) and the held-out error without it is unchanged (within
PRUNE_CV_TOL) or lower. An effect with no identified parameter left (every
one dropped by the reduction or held at 0 as a compliance) earns nothing.
The removal proposed is the one with the lowest held-out error without it;
one at a time (the others change when it goes). An addition proposed by
the same diagnosis comes first (:func:`held_for_addition`): on a model that
still lacks an effect, the values of the others are judged against a
residual that is not noise yet; the backward steps are made again after
it, and a final ``--prune`` removes what is left over.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._core import calib as core_calib

__all__ = [
    "BackwardStep",
    "backward_steps",
    "format_backward_steps",
    "held_for_addition",
    "PRUNE_CV_TOL",
    "FRAME_KINDS",
]

#: the held-out error without an effect may rise by this fraction and still count as unchanged
PRUNE_CV_TOL = 0.005
#: kinds that are not effects to prune: the frames of the measurement itself
FRAME_KINDS = ("tracker", "marker")
ZTOL = 1e-6


@dataclass
class BackwardStep:
    """One effect of the model tested for removal."""

    index: int  # its [[effect]] table (0-based, in the model file's order)
    effect: dict
    n_identified: int
    statistic: float = 0.0
    dof: int = 0
    log_p: float = 0.0
    max_abs_value: float = 0.0
    rms_without_m: float | None = None
    cv_rms_position_m: float | None = None  # held-out RMS without it
    remove: bool = False
    why: str = ""

    @property
    def label(self) -> str:
        e = self.effect
        return f"{e['kind']}:{e.get('target', e['kind'])}"

    def to_json(self) -> dict:
        return {
            "effect_index": self.index,
            "effect": self.effect,
            "label": self.label,
            "n_identified": self.n_identified,
            "statistic": self.statistic,
            "dof": self.dof,
            "log10_p_value": self.log_p / math.log(10),
            "max_abs_value": self.max_abs_value,
            "rms_without_m": self.rms_without_m,
            "cv_rms_position_m_without": self.cv_rms_position_m,
            "remove": self.remove,
            "why": self.why,
        }


def backward_steps(
    effects: list[dict],
    owner: np.ndarray,
    coef: np.ndarray,
    A: np.ndarray,
    r: np.ndarray,
    s2: float,
    declared: bool,
    nres: int,
    cv: Callable[[np.ndarray, np.ndarray], float | None] | None,
    cv_base: float | None,
    rms: Callable[[np.ndarray], float],
    alpha: float,
    values: Callable[[np.ndarray], np.ndarray] | None = None,
    free_effects: set[int] | None = None,
    cv_without: Callable[[np.ndarray, np.ndarray, np.ndarray], float | None] | None = None,
) -> tuple[list[BackwardStep], BackwardStep | None]:
    """Test every effect of the model (module docstring), on either data
    kind. ``effects``: the model's [[effect]] tables; ``A``: the weighted
    Jacobian at the fit of the identified parameters (columns), ``owner``
    the effect table (index into ``effects``) of each column, ``coef`` the
    fitted value of each column in A's units (so that A @ coef is the part
    of the prediction the parameters make, relative to their absence); ``r``
    the weighted residual, measured minus predicted; ``s2`` the noise
    variance in those units; ``cv(A, r)`` the held-out positional RMS of a
    linearised model; ``rms(e)`` the positional RMS of a weighted residual;
    ``values(cols)`` the fitted values of those columns in the parameters'
    units (default ``coef``); ``free_effects``: the effects with a
    parameter to identify (the others hold known values and are not
    tested; default: every effect); ``cv_without(rest, own, coef)``, in
    place of ``cv``: the same held-out RMS from the column indices (the
    columns ``rest`` of A, right-hand side r + A[:, own] @ coef), for a
    caller that shares the folds' factorisations. Returns the steps and the
    removal proposed (None when every effect earns its place)."""
    steps = []
    for e, table in enumerate(effects):
        if table.get("kind") in FRAME_KINDS or (free_effects is not None and e not in free_effects):
            continue
        own = np.flatnonzero(owner == e)
        st = BackwardStep(index=e, effect=dict(table), n_identified=int(own.size))
        if own.size == 0:
            st.remove, st.why = True, "no parameter of it is identified (dropped, or a compliance held at 0)"
            st.rms_without_m = rms(r)
            st.cv_rms_position_m = cv_base
            steps.append(st)
            continue
        Ae = A[:, own]
        rest = np.setdiff1d(np.arange(A.shape[1]), own)
        Ar = A[:, rest] if rest.size else np.zeros((A.shape[0], 1))
        r_without = r + Ae @ coef[own]  # its parameters at zero (its absence)
        stat, dof, pr = core_calib.score(Ar, r_without, Ae, np.array([1, own.size + 1], np.int32), 1e-10, ZTOL)
        st.dof = int(dof[0])
        st.statistic = float(stat[0] / s2)
        vals = coef[own] if values is None else values(own)
        st.max_abs_value = float(np.max(np.abs(vals)))
        if st.dof == 0:
            st.log_p = 0.0
        elif declared:
            st.log_p = core_calib.chi2_logsf(st.statistic, st.dof)
        else:
            st.log_p = core_calib.f_logsf(st.statistic / st.dof, st.dof, max(nres, 1))
        # the rest refitted without it: r is orthogonal to every column, so its residual is r
        # plus the part of r_without that the effect's columns explain off the rest
        st.rms_without_m = rms(r + pr[:, 0])
        if cv_without is not None:
            st.cv_rms_position_m = cv_without(rest, own, coef[own])
        else:
            st.cv_rms_position_m = cv(A[:, rest] if rest.size else np.zeros((A.shape[0], 0)), r_without)
        noise = st.log_p >= math.log(alpha)
        same_cv = (
            st.cv_rms_position_m is not None
            and cv_base is not None
            and st.cv_rms_position_m <= cv_base * (1 + PRUNE_CV_TOL)
        )
        if noise and same_cv:
            st.remove = True
            st.why = (
                f"its values are within the noise (p = {math.exp(st.log_p):.3g} >= {alpha:g}) and the held-out "
                f"error without it is {'lower' if st.cv_rms_position_m < cv_base else 'unchanged'} "
                f"({cv_base * 1e3:.4g} -> {st.cv_rms_position_m * 1e3:.4g} mm)"
            )
        elif not noise:
            st.why = f"its values are beyond the noise (log10 p = {st.log_p / math.log(10):.3g})"
        else:
            st.why = "the held-out error rises without it" + (
                f" ({cv_base * 1e3:.4g} -> {st.cv_rms_position_m * 1e3:.4g} mm)"
                if st.cv_rms_position_m is not None and cv_base is not None
                else ""
            )
        steps.append(st)
    out = [s for s in steps if s.remove]
    pick = min(out, key=lambda s: (s.cv_rms_position_m or 0.0, -s.log_p)) if out else None
    return steps, pick


def held_for_addition(dg: object) -> None:
    """A diagnosis (either kind: ``proposal``, ``removal``) that proposes an
    addition holds its removal back until after it (the steps that would
    remove stay in ``backward``)."""
    if dg.proposal is not None:
        dg.removal = None


def format_backward_steps(steps: list[BackwardStep], removal: BackwardStep | None) -> list[str]:
    """The table of backward steps and the removal proposed."""
    if not steps:
        return []
    mm = 1e-3
    lines = [
        "backward steps (each effect of the model tested without it; RMS and CV in mm):",
        f"  {'effect':32s}{'ident.':>7s}{'|value| max':>13s}{'log10 p':>10s}{'RMS w/o':>10s}{'CV w/o':>10s}  verdict",
    ]
    for s in steps:
        cv = f"{s.cv_rms_position_m / mm:10.4f}" if s.cv_rms_position_m is not None else f"{'-':>10s}"
        rms = f"{s.rms_without_m / mm:10.4f}" if s.rms_without_m is not None else f"{'-':>10s}"
        lines.append(
            f"  {s.label[:31]:32s}{s.n_identified:7d}{s.max_abs_value:13.4g} {s.log_p / math.log(10):9.3g}{rms}{cv}"
            f"  {'REMOVE' if s.remove else 'keep'}"
        )
    if removal is not None:
        lines.append("")
        lines.append(f"suggested removal: delete [[effect]] #{removal.index + 1} ({removal.label}): {removal.why}")
    elif any(s.remove for s in steps):
        lines.append("  (the addition proposed comes first; the backward steps are made again after it)")
    return lines
