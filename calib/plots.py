"""PNG figures of a fit: residual vectors per configuration, residual
histograms per axis with the noise level, measured vs predicted."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .diagnose import Diagnosis
    from .results import FitResult


def _plt() -> ModuleType:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def point_positions(res: FitResult) -> np.ndarray:
    """Measured points in base coordinates (n, 3)."""
    ch = res.model.chain
    meas = res.problem.meas
    out = np.empty((meas.n, 3))
    cache = {}
    for i in range(meas.n):
        key = tuple(meas.q[i])
        if key not in cache:
            cache[key] = ch.forward(meas.q[i])
        R, p = cache[key]
        out[i] = p + R @ meas.p[i]
    return out


def fit_plots(res: FitResult, outdir: Path | str, label: str = "fit") -> list[str]:
    """Write the three figures of a fit into outdir; returns the file names."""
    plt = _plt()
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    files = []
    pos = point_positions(res)
    before, after = res.measured, res.residuals
    span = max(np.ptp(pos, axis=0).max(), 1e-3)
    scale = 0.08 * span / max(np.linalg.norm(before, axis=1).max(), 1e-300)  # arrow metres per metre
    rscale = 0.08 * span / max(np.linalg.norm(after, axis=1).max(), 1e-300)
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.5))
    for ax, (i, j, name) in zip(axes, [(0, 1, "top view (x, y)"), (0, 2, "side view (x, z)")]):
        ax.scatter(pos[:, i], pos[:, j], s=8, c="k", zorder=3)
        ax.quiver(
            pos[:, i],
            pos[:, j],
            before[:, i] * scale,
            before[:, j] * scale,
            angles="xy",
            scale_units="xy",
            scale=1,
            color="0.7",
            width=0.003,
            label=f"measured deflection (x {scale:.3g})",
        )
        ax.quiver(
            pos[:, i],
            pos[:, j],
            after[:, i] * rscale,
            after[:, j] * rscale,
            angles="xy",
            scale_units="xy",
            scale=1,
            color="C3",
            width=0.004,
            label=f"residual after fit (x {rscale:.3g})",
        )
        ax.set_aspect("equal")
        ax.set_title(name)
        ax.set_xlabel("xyz"[i] + " (m)")
        ax.set_ylabel("xyz"[j] + " (m)")
    axes[0].legend(loc="best", fontsize=8)
    fig.suptitle(
        f"{label}: residual vectors per configuration (max residual "
        f"{np.linalg.norm(after, axis=1).max() * 1e3:.3g} mm, max deflection "
        f"{np.linalg.norm(before, axis=1).max() * 1e3:.3g} mm)"
    )
    fig.tight_layout()
    f = out / f"{label}_residual_vectors.png"
    fig.savefig(f, dpi=110)
    plt.close(fig)
    files.append(str(f))

    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    sig = res.sigma
    for i, ax in enumerate(axes):
        e = after[:, i] * 1e3
        ax.hist(e, bins=max(10, min(60, e.size // 8)), density=True, color="C0", alpha=0.7)
        if np.isfinite(sig) and sig > 0:
            s = sig * 1e3
            x = np.linspace(min(e.min(), -4 * s), max(e.max(), 4 * s), 200)
            ax.plot(x, np.exp(-0.5 * (x / s) ** 2) / (s * np.sqrt(2 * np.pi)), "k-", label=f"noise N(0, {s:.3g} mm)")
            ax.axvline(-s, color="k", ls=":")
            ax.axvline(s, color="k", ls=":")
            ax.legend(fontsize=8)
        ax.set_title(f"{'xyz'[i]}: RMS {np.sqrt(np.mean(e**2)):.3g} mm")
        ax.set_xlabel("residual (mm)")
    fig.suptitle(f"{label}: residual histograms per axis (sigma {'declared' if res.sigma_declared else 'estimated'})")
    fig.tight_layout()
    f = out / f"{label}_residual_histograms.png"
    fig.savefig(f, dpi=110)
    plt.close(fig)
    files.append(str(f))

    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2))
    for i, ax in enumerate(axes):
        m, p = before[:, i] * 1e3, res.predicted[:, i] * 1e3
        ax.scatter(m, p, s=6)
        lim = [min(m.min(), p.min()), max(m.max(), p.max())]
        ax.plot(lim, lim, "k--", lw=1)
        ax.set_xlabel(f"measured d{'xyz'[i]} (mm)")
        ax.set_ylabel(f"predicted d{'xyz'[i]} (mm)")
        ax.set_aspect("equal")
    fig.suptitle(f"{label}: measured vs predicted deflection")
    fig.tight_layout()
    f = out / f"{label}_measured_vs_predicted.png"
    fig.savefig(f, dpi=110)
    plt.close(fig)
    files.append(str(f))
    return files


def error_fall_plot(steps: Sequence[tuple[str, dict]], path: Path | str, noise_floor: float | None = None) -> str:
    """Bar chart of positional RMS / MAX per calibration step [(label, stats)]."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 4.5))
    labels = [s[0] for s in steps]
    rms = [s[1]["rms_position_m"] * 1e3 for s in steps]
    mx = [s[1]["max_position_m"] * 1e3 for s in steps]
    x = np.arange(len(steps))
    ax.bar(x - 0.2, mx, 0.4, label="MAX positional")
    ax.bar(x + 0.2, rms, 0.4, label="RMS positional")
    if noise_floor:
        ax.axhline(noise_floor * 1e3, color="k", ls="--", label="noise floor sqrt(3) sigma")
    ax.set_yscale("log")
    ax.set_xticks(x)
    ax.set_xticklabels(labels, rotation=15, ha="right", fontsize=8)
    ax.set_ylabel("compliance error (mm)")
    ax.legend(fontsize=8)
    ax.set_title("calibration loop: error after each model")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)


def candidates_plot(dg: Diagnosis, path: Path | str, top: int = 12) -> str:
    """Horizontal bars of the leading candidates: -log10 p (statistic
    against its dof) and the fraction of the residual each explains."""
    plt = _plt()
    cands = dg.candidates[:top]
    fig, axes = plt.subplots(1, 2, figsize=(12, 0.45 * max(len(cands), 4) + 1.5), sharey=True)
    y = np.arange(len(cands))[::-1]
    lab = [f"{c.label} ({c.dof} dof)" for c in cands]
    axes[0].barh(y, [-c.log_p / np.log(10) for c in cands], color="C0")
    axes[0].axvline(-np.log10(dg.alpha), color="k", ls=":", label=f"alpha = {dg.alpha:g}")
    axes[0].set_xscale("symlog", linthresh=10)
    axes[0].set_xlabel("-log10 p (score test)")
    axes[0].set_yticks(y)
    axes[0].set_yticklabels(lab, fontsize=8)
    axes[0].legend(fontsize=8)
    axes[1].barh(y, [100 * c.explained_fraction for c in cands], color="C2")
    axes[1].set_xlabel("residual explained (%)")
    for yi, c in zip(y, cands):
        if c.indistinguishable_from:
            axes[1].text(
                1, yi, "cannot be told apart from " + ", ".join(c.indistinguishable_from[:2]), fontsize=6, va="center"
            )
    fig.suptitle(f"diagnose: {dg.verdict} (log10 p = {dg.log_p / np.log(10):.3g}); candidates best first")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)


def residual_plots(dg: Diagnosis, outdir: Path | str, label: str = "diagnose") -> list[str]:
    """Where the residual lives (diagnose --plots): the residual as the
    rotation of each joint that would best explain it, against the joint's
    angle and against its torque (with binned means), and the positional
    residual per configuration and along the row order (drift), with the
    rows set aside by the data checks marked."""
    from .residual_map import binned, joint_residuals

    plt = _plt()
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    files = []
    res = dg.fit
    pb = res.problem
    jr = joint_residuals(pb, res.residuals)
    names = list(jr)
    ncol = min(3, max(len(names), 1))
    nrow = max(1, -(-len(names) // ncol))
    for key, xlabel, unit, fname in (
        ("q", "joint angle", "rad", "residual_vs_joint_angle"),
        ("tau", "torque about the joint", "N m", "residual_vs_joint_torque"),
    ):
        fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.2 * nrow), squeeze=False)
        for ax, name in zip(axes.flat, names):
            x, y = jr[name][key], jr[name]["dq"] * 1e6
            ax.scatter(x, y, s=5, c="0.6")
            b = binned(x, y)
            ax.errorbar(b["x"], b["mean"], yerr=b["sem"], color="C3", marker="o", ms=3, lw=1.2, label="binned mean")
            ax.axhline(0, color="k", lw=0.6)
            ax.set_title(name, fontsize=9)
            ax.set_xlabel(f"{xlabel} ({unit})", fontsize=8)
            ax.set_ylabel("joint rotation residual (urad)", fontsize=8)
        for ax in list(axes.flat)[len(names) :]:
            ax.axis("off")
        axes.flat[0].legend(fontsize=7)
        fig.suptitle(
            f"{label}: residual as the joint rotation that best explains each row, against the {xlabel} "
            f"(a trend names a {'posture' if key == 'q' else 'load'}-dependent joint)",
            fontsize=9,
        )
        fig.tight_layout()
        f = out / f"{label}_{fname}.png"
        fig.savefig(f, dpi=110)
        plt.close(fig)
        files.append(str(f))

    full = dg.fit_all if dg.fit_all is not None else res
    e = np.linalg.norm(full.residuals, axis=1) * 1e3
    aside = set(dg.data_checks.set_aside) if dg.data_checks is not None else set()
    cfgs = list(dict.fromkeys(full.problem.meas.config))
    per = {c: [] for c in cfgs}
    for i, c in enumerate(full.problem.meas.config):
        if i not in aside:
            per[c].append(e[i])
    fig, ax = plt.subplots(figsize=(max(6, 0.25 * len(cfgs) + 2), 4))
    rms = [float(np.sqrt(np.mean(np.square(per[c])))) if per[c] else 0.0 for c in cfgs]
    ax.bar(np.arange(len(cfgs)), rms, color="C0")
    ax.axhline(dg.floor * 1e3, color="k", ls="--", label="noise floor sqrt(3) sigma")
    for i, c in enumerate(full.problem.meas.config):
        if i in aside:
            ax.plot(cfgs.index(c), e[i], "rx", ms=6)
    ax.set_xticks(np.arange(len(cfgs)))
    ax.set_xticklabels(cfgs, rotation=90, fontsize=6)
    ax.set_yscale("symlog", linthresh=max(dg.floor * 1e3, 1e-6))
    ax.set_ylabel("positional residual RMS (mm)")
    ax.set_title(f"{label}: residual per configuration (x: rows set aside by the data checks)", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    f = out / f"{label}_residual_vs_configuration.png"
    fig.savefig(f, dpi=110)
    plt.close(fig)
    files.append(str(f))

    fig, ax = plt.subplots(figsize=(9, 4))
    r = full.residuals * 1e3
    idx = np.arange(r.shape[0])
    keep = np.array([i not in aside for i in idx])
    w = max(3, r.shape[0] // 20)
    for a in range(3):
        ax.plot(idx[keep], r[keep, a], ".", ms=3, color=f"C{a}", alpha=0.5)
        sm = np.convolve(r[keep, a], np.ones(w) / w, mode="same")
        ax.plot(idx[keep], sm, "-", color=f"C{a}", label=f"d{'xyz'[a]} (moving mean of {w})")
    if aside:
        ax.plot(idx[~keep], np.zeros((~keep).sum()), "rx", label="set aside")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xlabel("row (file order)")
    ax.set_ylabel("residual (mm)")
    lim = 6 * dg.sigma_position * 1e3
    if np.any(keep):
        lim = max(lim, float(np.abs(r[keep]).max()) * 1.1)
    ax.set_ylim(-lim, lim)
    ax.set_title(f"{label}: residual along the row order (a trend is drift of the instrument or fixture)", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    f = out / f"{label}_residual_vs_row_order.png"
    fig.savefig(f, dpi=110)
    plt.close(fig)
    files.append(str(f))
    return files
