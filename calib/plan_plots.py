"""The figures of ``stiffkit plan --png``: the expected error at every task
posture, planned against random (median of the random designs), and the
chosen postures' joint values against the candidates' range; with
``--discriminate``, how well each candidate and the plan tell the tied
hypotheses apart, planned against random designs, and the chosen postures
(deflection data: coloured by their load)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.files import pyplot, save_figure
from ..robot.plan_candidates import Candidates
from .plan import PlanResult, discrimination_numbers

__all__ = ["plan_figure", "discrimination_figure"]


def plan_figure(res: PlanResult, path: str | Path) -> Path:
    plt = pyplot()
    s = res.setup
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.5))
    x = np.arange(1, s.task_q.shape[0] + 1)
    a.plot(
        x, res.random_posture_rms * 1e3, "o-", color="0.55", ms=3, label=f"random (median of {res.random_values.size})"
    )
    a.plot(x, res.task_posture_rms * 1e3, "o-", color="C0", ms=3, label=f"plan ({res.criterion})")
    a.set_xlabel("task posture")
    a.set_ylabel("expected RMS position error (mm)")
    a.set_title(f"K = {res.k}: plan {res.task_rms * 1e3:.3g} mm, random {res.random_task_rms * 1e3:.3g} mm")
    a.set_ylim(bottom=0)
    a.legend()
    _postures_panel(b, s.candidates, s.candidates.q[s.posture[res.selected]])
    fig.tight_layout()
    out = save_figure(fig, path)
    plt.close(fig)
    return out


def _postures_panel(ax: object, cands: Candidates, chosen: np.ndarray, group: np.ndarray | None = None) -> None:
    """The chosen postures' joint values over the candidates' range (one
    colour per ``group``: the load of a deflection pair, else one)."""
    Q = cands.q
    j = np.arange(Q.shape[1])
    ax.vlines(j, Q.min(axis=0), Q.max(axis=0), color="0.8", lw=6, label="candidates' range")
    seen = set()
    for i, q in enumerate(chosen):
        g = None if group is None else int(group[i])
        label = None
        if g not in seen:
            seen.add(g)
            label = "chosen postures" if g is None else "under load " + _load(cands.loads[g])
        ax.plot(j, q, ".-", lw=0.6, ms=4, alpha=0.7, color=None if g is None else f"C{g % 10}", label=label)
    ax.set_xticks(j, cands.joint_names, rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("joint value (rad or m)")
    ax.set_title("the chosen postures")
    ax.legend(fontsize=7)


def _scale(ax: object, v: np.ndarray) -> None:
    """Log scale when the values span more than 30 x (all positive), else linear from 0."""
    v = v[np.isfinite(v)]
    if v.size and v.min() > 0 and v.max() > 30 * v.min():
        ax.set_yscale("log")
    else:
        ax.set_ylim(bottom=0)


def _load(w: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:g}" for v in w) + ")"


def discrimination_figure(res: dict, cands: Candidates, path: str | Path, seed: int = 0) -> Path:
    """``--png`` with ``--discriminate``: (left) the smallest noncentrality
    between the tied hypotheses after adding each candidate alone to the
    rows measured so far, the chosen ones marked; (middle) that of the plan
    against random designs of the same size; (right) the chosen postures.
    The numbers are :func:`calib.plan.discrimination_numbers`'s."""
    return _discrimination_plot(discrimination_numbers(res, cands, seed), cands, path)


def _discrimination_plot(d: dict, cands: Candidates, path: str | Path) -> Path:
    plt = pyplot()
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(16, 4.5))
    alone = d["alone"]
    order = np.argsort(-alone)
    rank = np.empty(alone.size, int)
    rank[order] = np.arange(1, alone.size + 1)
    what = "(posture, load) pair" if d["loads"] is not None else "posture"
    a.plot(np.arange(1, alone.size + 1), alone[order], "-", color="0.55", lw=1, label=f"each candidate {what}")
    a.plot(rank[d["selected"]], alone[d["selected"]], "o", color="C3", ms=5, label="chosen")
    a.axhline(d["before"], color="k", ls=":", lw=1, label=f"rows measured so far ({d['before']:.3g})")
    _scale(a, np.append(alone, d["before"]))
    a.set_xlabel(f"candidate {what}, best first")
    a.set_ylabel("smallest noncentrality, added alone (sigma^2)")
    a.set_title(" vs ".join(d["hypotheses"]), fontsize=9)
    a.legend(fontsize=8)
    r = d["random"]
    b.plot(np.zeros(r.size) + np.linspace(-0.15, 0.15, r.size), r, "o", color="0.55", ms=4, label="random designs")
    b.hlines(np.median(r), -0.3, 0.3, color="0.3", label=f"random median {np.median(r):.3g}")
    b.hlines(d["plan"], -0.3, 0.3, color="C3", lw=2, label=f"plan {d['plan']:.3g}")
    b.hlines(d["before"], -0.3, 0.3, color="k", ls=":", lw=1, label=f"measured so far {d['before']:.3g}")
    b.set_xticks([])
    _scale(b, np.concatenate([r, [d["plan"], d["before"]]]))
    lo, hi = b.get_ylim()
    b.set_ylim(lo, hi * (1.6 if b.get_yscale() == "log" else 1.3))  # room for the legend above the plan
    b.set_ylabel("smallest noncentrality (sigma^2; > ~10: told apart)")
    b.set_title(f"K = {d['selected'].size}: plan against {r.size} random designs")
    b.legend(fontsize=8)
    _postures_panel(c, cands, d["q"], d["load_index"])
    fig.tight_layout()
    out = save_figure(fig, path)
    plt.close(fig)
    return out
