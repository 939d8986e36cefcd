"""Figures of a robot model's stiffness along postures (PNG, written atomically)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.files import pyplot, save_figure

__all__ = ["stiffness_png"]


def stiffness_png(
    path: Path | str, Q: np.ndarray, C: np.ndarray, ok: np.ndarray, indices: dict, units: dict, lscale: float
) -> Path:
    """Principal compliances and the indices along the postures; singular
    postures (no stiffness, indices undefined) marked in grey."""
    plt = pyplot()
    # principal compliances: eigenvalues of the translational and rotational blocks
    et = np.linalg.eigvalsh(C[:, :3, :3])
    er = np.linalg.eigvalsh(C[:, 3:, 3:])
    fig, ax = plt.subplots(1, 3, figsize=(15, 4))
    x = np.arange(1, len(Q) + 1)
    mk = "." if len(Q) < 50 else None
    for k in range(3):
        ax[0].plot(x, et[:, k] * 1e6, marker=mk, label=f"principal {k + 1}")
        ax[1].plot(x, er[:, k] * 1e6, marker=mk)
    ax[0].set_ylabel("translational compliance (mm/kN)")
    ax[1].set_ylabel("rotational compliance (urad/(N m))")
    for name, v in indices.items():
        ax[2].plot(x, v, marker=mk, label=name)  # NaN leaves a gap
    ax[2].set_yscale("log")
    ax[2].set_ylabel(f"stiffness index ({', '.join(sorted(set(units.values())))}), l = {lscale:.3g} m")
    # runs of consecutive postures without a stiffness, one grey band each
    edges = np.diff(np.r_[0, (~ok).astype(int), 0])
    runs = list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))
    for a in ax:
        a.set_xlabel("posture")
        for b0, b1 in runs:
            a.axvspan(x[b0] - 0.5, x[b1 - 1] + 0.5, color="0.85", lw=0)
    if runs:
        ax[2].plot([], [], color="0.85", lw=6, label="no stiffness (indices undefined)")
    ax[0].legend(fontsize=8)
    ax[2].legend(fontsize=8)
    fig.tight_layout()
    try:
        return save_figure(fig, path, dpi=110)
    finally:
        plt.close(fig)
