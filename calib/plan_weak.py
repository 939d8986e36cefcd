"""Which parameters a plan leaves weak, and why (the report of ``stiffkit
plan``, docs/plan.md section 4).

A parameter is weak for one of three reasons, each with its numbers (from
the design core: ``design.covariance`` and ``design.weakness``, core/sk_design_weak.f90):

- **not identifiable**: the plan's information is singular and the
  parameter lies in its null space (``null_share``: the diagonal of the
  projector onto the null space of the unit-diagonal information; with the
  parameters sharing that null space). The parameters the fit's reduction
  sets aside (not identifiable from any candidate) are listed too, with the
  reduction's reason.
- **correlated**: its expected standard deviation is inflated by its
  correlation with others: the variance inflation diag(M^-1) diag(M) above
  WEAK_VIF (``inflation`` = std / the std it would have if uncorrelated,
  1/sqrt(M_jj)), with the parameters it correlates with most.
- **weakly excited**: the plan's rows barely see it, by either of two
  measures relative to the median over the parameters (the parameters' own
  units cancel): ``excitation``, the norm of its column of the scaled
  Jacobian (columns scaled over all candidates, as the criteria are) over
  the plan, sqrt(M_jj / P_jj) with P the information of all candidates (low:
  the plan's postures barely load it, where other candidates would); and
  ``task_excitation``, sqrt(M_jj / T_jj) with T_jj the sum of squares of its
  task column (low: the plan sees it weakly for how much it moves the task
  points; ``candidates_task_excitation`` the same over all candidates says
  whether any candidate loads it more). Below WEAK_EXCITATION its
  variance is more than ~11 x what the median parameter's excitation would
  give. A parameter that does not move the task points (the tracker's own)
  has no task excitation (None).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # calib.plan's PlanResult calls this module
    from .plan import PlanResult

__all__ = ["excitation", "task_excitation", "weak_parameters", "WEAK_VIF", "WEAK_EXCITATION", "NULL_SHARE"]

#: a parameter whose variance is inflated by more than this (against an orthogonal design) is weak
WEAK_VIF = 10.0
#: a parameter excited less than this (relative to the median, per unit of task influence) is weak
WEAK_EXCITATION = 0.3
#: a parameter whose share of the plan's null space exceeds this is not identifiable
NULL_SHARE = 1.0e-6
#: partners named per weak parameter (those beyond PARTNER_R, at least the strongest)
PARTNERS = 3
PARTNER_R = 0.5


def _relative(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    raw = np.full(num.size, np.nan)
    ok = den > 0
    raw[ok] = np.sqrt(num[ok] / den[ok])
    fin = raw[np.isfinite(raw)]
    med = float(np.median(fin)) if fin.size else 0.0
    return raw / med if med > 0 else np.full(raw.size, np.nan)


def excitation(res: PlanResult) -> np.ndarray:
    """(npar,) each parameter's column norm of the scaled Jacobian over the
    plan, sqrt(M_jj / P_jj), over its median across the parameters (module
    docstring)."""
    w = res.weakness
    return np.full(res.setup.npar, np.nan) if w is None else _relative(w.info, w.pool)


def task_excitation(res: PlanResult) -> np.ndarray:
    """(npar,) sqrt(M_jj / T_jj) (T_jj: the task column's sum of squares)
    over its median across the parameters; NaN without task influence."""
    w = res.weakness
    return np.full(res.setup.npar, np.nan) if w is None else _relative(w.info, w.task)


def _num(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def _partners(names: list[str], row: np.ndarray, j: int, key: str) -> list[dict]:
    """The parameters of ``row`` (correlations, or null-space shares) strongest first, without j."""
    r = np.abs(row).astype(float)
    r[j] = -1.0
    order = [int(k) for k in np.argsort(-r) if r[k] > 0]
    keep = [k for k in order if r[k] >= PARTNER_R] or order[:1]
    return [{"name": names[k], key: float(row[k])} for k in keep[:PARTNERS]]


def _uncorrelated(res: PlanResult) -> np.ndarray:
    info = res.weakness.info if res.weakness is not None else np.zeros(res.setup.npar)
    return np.divide(1.0, np.sqrt(info), out=np.full(info.size, math.inf), where=info > 0)


def weak_parameters(res: PlanResult) -> list[dict]:
    """The weak parameters of the plan, each with ``reasons`` (``not
    identifiable``, ``correlated``, ``weakly excited``), ``why`` (a sentence
    with the numbers) and the numbers: ``std`` (expected), ``std_uncorrelated``,
    ``inflation`` (their ratio), ``vif``, ``excitation``, ``task_excitation``,
    ``candidates_task_excitation`` (module docstring), ``correlated_with``
    [{name, r}], ``null_share`` and ``null_with`` [{name, share}]; the
    parameters the fit's reduction sets aside last (``source``
    "reduction"). Not identifiable first, then the most inflated."""
    s = res.setup
    names = s.names
    w = res.weakness
    exc = excitation(res)
    texc = task_excitation(res)
    pool_texc = np.full(len(names), np.nan) if w is None else _relative(w.pool, w.task)
    std0 = _uncorrelated(res)
    nnull = 0 if w is None else w.nnull
    regular = np.all(np.isfinite(res.vif))
    found = []
    for j, name in enumerate(names):
        e, et = exc[j], texc[j]
        d = {
            "name": name,
            "source": "plan",
            "reasons": [],
            "std": _num(res.std[j]),
            "std_uncorrelated": _num(std0[j]),
            "inflation": _num(res.std[j] / std0[j]) if regular and std0[j] > 0 else None,
            "vif": _num(res.vif[j]),
            "excitation": _num(e),
            "task_excitation": _num(et),
            "candidates_task_excitation": _num(pool_texc[j]),
        }
        parts = []
        if nnull and w.null[j, j] > NULL_SHARE:
            d["reasons"].append("not identifiable")
            d["null_share"] = float(w.null[j, j])
            coupled = np.abs(w.null[j])
            coupled[j] = 0.0
            near = [int(k) for k in np.argsort(-coupled) if coupled[k] > NULL_SHARE][:PARTNERS]
            d["null_with"] = [{"name": names[k], "share": float(w.null[k, k])} for k in near]
            parts.append(
                f"not identifiable from the plan: it lies in the null space of the plan's information (share "
                f"{w.null[j, j]:.3g})"
                + "".join(
                    f"{', with' if i == 0 else ','} {p['name']} (share {p['share']:.3g})"
                    for i, p in enumerate(d["null_with"])
                )
            )
        elif regular and res.vif[j] > WEAK_VIF:
            d["reasons"].append("correlated")
            d["correlated_with"] = _partners(names, res.corr[j], j, "r")
            with_ = ", ".join(f"{p['name']} (r = {p['r']:+.3f})" for p in d["correlated_with"])
            parts.append(
                f"correlated with {with_}: expected std {res.std[j]:.3g}, {d['inflation']:.3g} x the "
                f"{std0[j]:.3g} it would have if uncorrelated (variance inflation {res.vif[j]:.3g})"
            )
        low = [math.isfinite(v) and v < WEAK_EXCITATION for v in (e, et)]
        if any(low) and "not identifiable" not in d["reasons"]:
            d["reasons"].insert(0, "weakly excited")
            how = []
            if low[0]:
                how.append(
                    f"the plan's postures barely load it: its column of the scaled Jacobian is {e:.3g} x the median "
                    "parameter's (columns scaled over all candidates)"
                )
            if low[1]:
                pe = pool_texc[j]
                how.append(
                    f"for its effect on the task the plan sees it {et:.3g} x as strongly as the median parameter"
                    + (
                        f" (all candidates together: {pe:.3g} x; add candidate postures, or for deflection data "
                        "[plan] loads, that load it)"
                        if pe < WEAK_EXCITATION
                        else f" (all candidates together: {pe:.3g} x: the plan left out the ones that load it)"
                    )
                )
            elif math.isfinite(et) and et > 1.0 / WEAK_EXCITATION:
                how.append(f"it matters little to the task ({et:.3g} x the median, for its effect on the task)")
            sd = f"expected std {res.std[j]:.3g}, " if not d["reasons"][1:] and math.isfinite(res.std[j]) else ""
            parts.insert(0, f"weakly excited: {'; '.join(how)} ({sd}uncorrelated std {std0[j]:.3g})")
        if d["reasons"]:
            d["why"] = "; and ".join(parts)
            found.append(d)

    def rank(d: dict) -> tuple:
        if "not identifiable" in d["reasons"]:
            return (0, -d["null_share"])
        e = min(v for v in (d["excitation"], d["task_excitation"], math.inf) if v is not None)
        weak = math.inf if e == 0 else 1.0 / e**2 if e < math.inf else 0.0
        return (1, -max(d["vif"] or 0.0, weak))

    found.sort(key=rank)
    found += [
        {
            "name": n,
            "source": "reduction",
            "reasons": ["not identifiable"],
            "why": f"set aside by the fit's reduction: {why}",
        }
        for n, why in s.not_planned
    ]
    return found
