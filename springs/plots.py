"""Figures of the parallel-robot results (PNG, written atomically):
the Orthoglide's compliance over its workspace and the McGill SMG's
stiffness indices along its test trajectory (Fig. 10)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.files import pyplot, save_figure
from ..robot.indices import Indices

__all__ = ["orthoglide_map_png", "smg_indices_png"]


def orthoglide_map_png(path: Path | str, xs: np.ndarray, ct3: np.ndarray, cr3: np.ndarray) -> Path:
    """Slices z = first, middle, last grid value of the largest translational
    (mm/N) and rotational (rad/(N mm)) compliance eigenvalue on the grid
    ``xs`` (mm) cubed, as log10 contour maps."""
    plt = pyplot()
    n = len(xs)
    ks = [0, n // 2, n - 1]
    fig, axs = plt.subplots(2, 3, figsize=(13, 8), constrained_layout=True)
    for row, (field, label) in enumerate(
        (
            (ct3, "log10 largest translational compliance, mm/N"),
            (cr3, "log10 largest rotational compliance, rad/(N mm)"),
        )
    ):
        lf = np.log10(field)
        levels = np.linspace(lf.min(), lf.max(), 25)
        for col, k in enumerate(ks):
            ax = axs[row, col]
            im = ax.contourf(xs, xs, lf[:, :, k].T, levels=levels, cmap="viridis")
            ax.set_title(f"z = {xs[k]:.0f} mm")
            ax.set_xlabel("x, mm")
            ax.set_ylabel("y, mm")
            ax.set_aspect("equal")
        fig.colorbar(im, ax=axs[row, :], label=label)
    fig.suptitle(
        "Orthoglide compliance over the 200 mm cube centred on the isotropic point\n"
        "(the corner -100,-100,-100 mm lies at 79 % of the way to the parallel singularity P = -L/sqrt(6) (1,1,1))"
    )
    try:
        return save_figure(fig, path, dpi=110)
    finally:
        plt.close(fig)


def smg_indices_png(path: Path | str, tau: np.ndarray, P: np.ndarray, theta: np.ndarray, idx: Indices) -> Path:
    """The trajectory (x, z) and kappa_t, kappa_r along it (cf. Fig. 10)."""
    plt = pyplot()
    fig, axs = plt.subplots(1, 3, figsize=(15, 4.2), constrained_layout=True)
    axs[0].plot((P[:, 0] - P[0, 0]) * 1e3, (P[:, 2] - P[0, 2]) * 1e3, "k-")
    axs[0].set_xlabel("x, mm")
    axs[0].set_ylabel("z, mm")
    axs[0].set_title("smoothed test trajectory (MP turns 180 deg)")
    axs[1].plot(tau, idx.kappa_t, "b-")
    axs[1].set_title(r"translational index $\kappa_t$")
    axs[2].plot(tau, idx.kappa_r, "r-")
    axs[2].set_title(r"rotational index $\kappa_r$")
    for ax in axs[1:]:
        ax.set_xlabel("normalised time")
        ax.set_ylabel("N")
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"McGill SMG stiffness indices (eqs. 31-39, l = {idx.lscale * 1e3:.0f} mm), cf. Fig. 10")
    try:
        return save_figure(fig, path, dpi=110)
    finally:
        plt.close(fig)
