"""The figure of ``stiffkit plan --png``: the expected error at every task
posture, planned against random (median of the random designs), and the
chosen postures' joint values against the candidates' range."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.files import pyplot, save_figure
from .plan import PlanResult

__all__ = ["plan_figure"]


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
    Q = s.candidates.q
    chosen = Q[s.posture[res.selected]]
    j = np.arange(Q.shape[1])
    b.vlines(j, Q.min(axis=0), Q.max(axis=0), color="0.8", lw=6, label="candidates' range")
    for i, q in enumerate(chosen):
        b.plot(j, q, ".-", lw=0.6, ms=4, alpha=0.7, label="chosen postures" if i == 0 else None)
    b.set_xticks(j, s.joint_names, rotation=60, ha="right", fontsize=7)
    b.set_ylabel("joint value (rad or m)")
    b.set_title("the chosen postures")
    b.legend(fontsize=8)
    fig.tight_layout()
    out = save_figure(fig, path)
    plt.close(fig)
    return out
