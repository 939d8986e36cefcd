"""Figures of a fit on absolute data (``stiffkit fit/diagnose --plots DIR``):
the point errors before and after, and where the error left lives: its
size against each joint's angle and against the gravity torque about each
joint, and along the configurations (drift)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .._core import tree as core
from ..io.files import pyplot, save_figure
from ..robot.tree_model import EQ_TOL
from .absolute_fit import AbsoluteFit, _loads

__all__ = ["absolute_plots"]

MM = 1e-3


def absolute_plots(fit: AbsoluteFit, outdir: str | Path, label: str = "fit") -> list[Path]:
    """Write the figures into ``outdir``; returns their paths."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    plt = pyplot()
    d = fit.data
    use = fit.weight > 0
    after = np.linalg.norm(fit.residual, axis=1)
    before = np.linalg.norm(fit.before, axis=1)
    files = []
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    bins = np.linspace(0, max(before[use].max(), 1e-12) / MM, 40)
    ax[0].hist(before[use] / MM, bins=bins, alpha=0.6, label="before (nominal, tracker fitted)")
    ax[0].hist(after[use] / MM, bins=bins, alpha=0.6, label="after")
    ax[0].set_xlabel("point error, mm")
    ax[0].set_ylabel("points")
    ax[0].legend(fontsize=8)
    order = np.argsort(d.posture, kind="stable")
    for k, f in enumerate(d.frames):
        sel = order[(d.frame[order] == k) & use[order]]
        ax[1].plot(d.posture[sel], after[sel] / MM, ".", ms=3, label=f)
    ax[1].set_xlabel("configuration (file order)")
    ax[1].set_ylabel("error after the fit, mm")
    ax[1].legend(fontsize=8)
    fig.suptitle(f"point errors ({label}): RMS {_rms(before[use]) / MM:.3f} -> {_rms(after[use]) / MM:.3f} mm")
    fig.tight_layout()
    files.append(save_figure(fig, outdir / f"{label}_errors.png"))
    plt.close(fig)
    # the error against each joint's angle and the gravity torque about it
    m = fit.model
    P = core.poses(m.packed, fit.theta, d.Q, _loads(m, d), m.eqit, EQ_TOL)
    tau = P["tauq"]
    joints = m.actuated
    n = len(joints)
    cols = min(n, 6)
    rows = 2 * math.ceil(n / cols)
    fig, axs = plt.subplots(rows, cols, figsize=(2.6 * cols, 2.1 * rows), squeeze=False)
    per_post = np.zeros(d.n_postures)
    cnt = np.zeros(d.n_postures)
    np.add.at(per_post, d.posture[use], after[use] ** 2)
    np.add.at(cnt, d.posture[use], 1)
    rms_post = np.sqrt(per_post / np.maximum(cnt, 1)) / MM
    for j, name in enumerate(joints):
        r, c = 2 * (j // cols), j % cols
        axs[r, c].plot(d.Q[:, j], rms_post, ".", ms=2)
        axs[r, c].set_title(name, fontsize=8)
        axs[r, c].set_xlabel("angle, rad", fontsize=7)
        axs[r + 1, c].plot(tau[:, j], rms_post, ".", ms=2, color="C1")
        axs[r + 1, c].set_xlabel("gravity torque, N m", fontsize=7)
        for a in (axs[r, c], axs[r + 1, c]):
            a.tick_params(labelsize=6)
    for j in range(n, (rows // 2) * cols):
        axs[2 * (j // cols), j % cols].axis("off")
        axs[2 * (j // cols) + 1, j % cols].axis("off")
    fig.suptitle("where the error left lives: RMS of each configuration (mm) against each joint's angle and torque")
    fig.tight_layout()
    files.append(save_figure(fig, outdir / f"{label}_residual_map.png"))
    plt.close(fig)
    return files


def _rms(x: np.ndarray) -> float:
    return float(math.sqrt(np.mean(x**2))) if x.size else 0.0
